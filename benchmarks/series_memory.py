"""Series memory: the adaptive PCE's fit of a time series at 500 runs, T = 50, 200, 1000.

A damped oscillator with four uncertain inputs (frequency, damping, amplitude, phase) sampled
at ``T`` steps, run through ``uqguide.driver.propagate.run`` with ``pce_adaptive`` at its
defaults but for a fixed budget (``n_samples = max_runs = 500``). Prints, per ``T``, the CPU
seconds and wall time of the whole run (the model costs microseconds: nearly all of it is the
fit) and the peak resident memory (``ru_maxrss``) of a fresh subprocess, so each peak is its own
and load does not change it. Issue 48 asks for a peak that grows at most linearly in ``T`` and
stays under 500 MB at ``T = 1000``.

Usage::

    python benchmarks/series_memory.py                 # T = 50, 200, 1000
    python benchmarks/series_memory.py --steps 1000 --one   # one measurement, JSON
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
RUNS = 500


def _oscillator(steps: int):
    t = np.linspace(0.0, 10.0, steps)

    def model(x):
        omega, zeta, amp, phase = (x[:, j:j + 1] for j in range(4))
        wd = omega * np.sqrt(1.0 - zeta**2)
        return {"time": t, "x": amp * np.exp(-zeta * omega * t) * np.cos(wd * t + phase)}

    return model


def measure(steps: int) -> dict:
    """One run of the adaptive PCE on the ``steps``-step oscillator, in this process."""
    from uqguide.config.run_config import validate_config
    from uqguide.driver.execution import SerialExecutor
    from uqguide.driver.propagate import run

    names = ["omega", "zeta", "amp", "phase"]
    cfg = validate_config({
        "name": f"series_memory_{steps}",
        "model": {"name": "callable", "function": _oscillator(steps), "inputs": names,
                  "nominal": [2.0, 0.1, 1.0, 0.0], "isolate": False,
                  "outputs": [{"name": "x", "kind": "series"}]},
        "inputs": [{"name": "omega", "dist": "uniform", "low": 1.5, "high": 2.5},
                   {"name": "zeta", "dist": "uniform", "low": 0.05, "high": 0.15},
                   {"name": "amp", "dist": "normal", "mean": 1.0, "std": 0.05},
                   {"name": "phase", "dist": "normal", "mean": 0.0, "std": 0.1}],
        "methods": [{"name": "pce_adaptive", "label": "apce", "n_samples": RUNS,
                     "max_runs": RUNS}],
        "report_times": [1.0, 5.0, 10.0],
        "seed": 1,
    })
    executor = SerialExecutor()
    c0 = time.process_time()
    t0 = time.perf_counter()
    try:
        result = run(cfg, executor)
    finally:
        executor.close()
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    s = result.run("apce").estimate.stats["x"]
    digest = hashlib.sha256()
    for k in ("mean", "std", "skewness", "kurtosis"):
        digest.update(np.ascontiguousarray(getattr(s, k)).tobytes())
    for k in sorted(s.ci):
        digest.update(np.ascontiguousarray(s.ci[k]).tobytes())
    return {"T": steps, "runs": RUNS, "cpu_s": cpu, "wall_s": wall,
            "load": os.getloadavg()[0],
            "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
            "stats_sha256": digest.hexdigest()[:16]}


def _spawn(steps: int) -> dict:
    out = subprocess.run([sys.executable, __file__, "--one", "--steps", str(steps)],
                         capture_output=True, text=True, cwd=ROOT,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, check=False)
    if out.returncode != 0:
        sys.exit(f"measurement T={steps} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--steps", type=int, nargs="+", default=[50, 200, 1000],
                    help="time steps T of the series")
    ap.add_argument("--one", action="store_true", help="one measurement, printed as JSON")
    args = ap.parse_args()
    if args.one:
        print(json.dumps(measure(args.steps[0])))
        return
    print(f"{'T':>5} {'runs':>5} {'fit CPU-s':>10} {'wall s':>7} {'peak MiB':>9} {'load':>5}"
          "  stats")
    for steps in args.steps:
        r = _spawn(steps)
        print(f"{r['T']:>5} {r['runs']:>5} {r['cpu_s']:>10.1f} {r['wall_s']:>7.1f} "
              f"{r['peak_mib']:>9.0f} {r['load']:>5.1f}  {r['stats_sha256']}")
    print("fit CPU-s / wall s: the whole run in one process (the model's share is negligible); "
          "peak MiB: ru_maxrss of a fresh subprocess, interpreter and imports included.")


if __name__ == "__main__":
    main()
