"""Per-sample overhead of the ``fmu`` model, with an FMU that does almost no work.

    python benchmarks/fmu_overhead.py [--samples 500] [--steps 1,10,100,1000]

The FMU is the test suite's ``decay`` (``tests/fmu_decay.py``, compiled here with ``cc``): one
``exp`` per communication step, so what is measured is uqguide's and FMPy's share per sample
(the start values set, initialisation, the stepping loop in Python, the recording, the reset).
Columns: ``steps`` communication steps per simulation (``stop_time / output_interval``);
``ms/sample`` a whole batch's model call over its samples, a scalar output only; ``+series
ms`` the same with the state also recorded as a series; ``us/step`` the part of a sample that
grows with the steps; ``batch ms`` the batch's fixed cost (instantiating the FMU), measured
as a one-sample batch minus a sample. One model call per batch, in this process.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # the test FMU lives in tests/
    sys.path.insert(0, str(ROOT))


def _per_sample(model, x: np.ndarray, outputs: list[str], repeat: int = 3) -> float:
    model.evaluate(x[:2], ["x0", "k"], outputs)  # warm: the unzip, the library load
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        out = model.evaluate(x, ["x0", "k"], outputs)
        best = min(best, time.perf_counter() - t0)
    assert not out.failed.any()
    return best / x.shape[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=500, help="samples per batch")
    ap.add_argument("--steps", default="1,10,100,1000", help="communication steps per run")
    args = ap.parse_args()
    if shutil.which("cc") is None:
        sys.exit("no C compiler 'cc' on PATH: the benchmark compiles its FMU")
    from tests.fmu_decay import build

    from uqguide.models.fmu import FmuModel

    rng = np.random.default_rng(0)
    x = np.column_stack([rng.normal(1.0, 0.2, args.samples), rng.uniform(0.2, 0.8, args.samples)])
    with tempfile.TemporaryDirectory() as tmp:
        fmu = build(Path(tmp))
        print(f"{'steps':>6} {'ms/sample':>10} {'+series ms':>11} {'us/step':>8} "
              f"{'batch ms':>9} {'samples/s':>10}")
        first = None
        for steps in (int(s) for s in args.steps.split(",")):
            model = FmuModel({"path": str(fmu), "inputs": ["x0", "k"],
                              "outputs": ["x", {"name": "p", "kind": "series", "variable": "x"}],
                              "stop_time": 1.0, "output_interval": 1.0 / steps})
            scalar = _per_sample(model, x, ["x"])
            series = _per_sample(model, x, ["x", "p"])
            one = min(_per_sample(model, x[:1], ["x"], repeat=1) for _ in range(20))
            first = first or (steps, scalar)
            per_step = (scalar - first[1]) / (steps - first[0]) if steps > first[0] else np.nan
            print(f"{steps:>6} {scalar * 1e3:>10.3f} {series * 1e3:>11.3f} "
                  f"{per_step * 1e6:>8.1f} {(one - scalar) * 1e3:>9.3f} {1 / scalar:>10,.0f}")


if __name__ == "__main__":
    main()
