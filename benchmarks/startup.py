"""Start-up cost of the command line: CPU and wall time of each command, and whether it imported
chaospy or scipy.stats (it should not for --help, validate, check, baseline).

    python benchmarks/startup.py [--repeat 5]

Each command runs in a fresh interpreter, as `uqguide ...` does; the CPU time is the child's
user + system time (median of the repeats). The inputs are made once in a temporary folder: a
small result file (linear-Gaussian Monte Carlo) and its baseline.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# Runs the command line in-process, then reports on stderr which heavy modules it imported.
PROBE = """
import sys
from uqguide.cli import main
try:
    main(sys.argv[1:], prog_name="uqguide")
except SystemExit as exc:
    code = exc.code
heavy = [m for m in ("chaospy", "scipy.stats", "sklearn", "numba", "pandas", "matplotlib")
         if m in sys.modules]
print("HEAVY " + ",".join(heavy), file=sys.stderr)
"""


def _make_inputs(folder: Path) -> tuple[Path, Path]:
    import uqguide
    from uqguide.gate.check import write_baseline

    result = uqguide.run({
        "name": "run",  # a result is written only under a name the config gives
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 1000}], "seed": 1},
        out=folder)
    h5 = folder / "run.h5"
    base = folder / "run.json"
    write_baseline(result, base, 0.02)
    return h5, base


def _measure(args: list[str], repeat: int, cwd: Path) -> tuple[float, float, str]:
    cpu, wall, heavy = [], [], ""
    for _ in range(repeat):
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", PROBE, *args], cwd=cwd, capture_output=True,
                           text=True, env={**os.environ, "PYTHONWARNINGS": "ignore"})
        wall.append(time.perf_counter() - t0)
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        line = [ln for ln in p.stderr.splitlines() if ln.startswith("HEAVY")]
        heavy = line[-1][6:] if line else "?"
    return statistics.median(cpu), statistics.median(wall), heavy or "none"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    opts = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        h5, base = _make_inputs(folder)
        config = ROOT / "configs" / "ftcapn_table5.yaml"
        commands = {
            "uqguide --help": ["--help"],
            "uqguide validate ftcapn_table5": ["validate", str(config)],
            "uqguide models ftcapn": ["models", "ftcapn"],
            "uqguide check RESULT --baseline B": ["check", str(h5), "--baseline", str(base)],
            "uqguide baseline RESULT -o B": ["baseline", str(h5), "-o", str(folder / "b2.json"),
                                             "--force"],
        }
        print(f"{'command':<36} {'CPU s':>6} {'wall s':>7}  heavy modules imported")
        for name, args in commands.items():
            cpu, wall, heavy = _measure(args, opts.repeat, folder)
            print(f"{name:<36} {cpu:6.3f} {wall:7.3f}  {heavy}")
        cpu, wall, _ = _measure(["--version"], opts.repeat, folder)
        print(f"{'(python + click + uqguide.cli)':<36} {cpu:6.3f} {wall:7.3f}")
        base_cpu = []
        for _ in range(opts.repeat):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            subprocess.run([sys.executable, "-c", "import chaospy"], check=True)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            base_cpu.append(after.ru_utime - before.ru_utime + after.ru_stime - before.ru_stime)
        print(f"{'(for scale: python -c import chaospy)':<36} {statistics.median(base_cpu):6.3f}")


if __name__ == "__main__":
    main()
