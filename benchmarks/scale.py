"""Scale: a 1e6-sample Monte Carlo of FTCAPN (Table 3) through the real pipeline.

Measures, for each worker count, after a warm-up run that starts the workers and loads the
compiled kernel, the wall time of ``uqguide.driver.propagate.run`` (design, chunked
evaluation in a process pool, streaming statistics with delta-method intervals and exact
3-sigma quantiles at the report times), the CPU seconds of the driver and of the workers, and
the peak resident memory of the driver and of the workers, then the speed-up
of ``w`` processes over 1, and checks that every statistic is bit-identical across worker
counts. A smaller serial run shows how memory grows with ``n``: only by the per-sample inputs
and scalar outputs (8 bytes x (7 + 5) per sample), not by the series, which never leave the
chunks (``n x T x k x 8`` bytes if they did).

Each measurement runs in a fresh subprocess so peak memory (``ru_maxrss``) is its own.

Usage::

    python benchmarks/scale.py                    # 1e6 samples, 1 and 2 processes, 1e5 serial
    python benchmarks/scale.py --n 200000 --workers 1 2
    python benchmarks/scale.py --one --n 1000 --workers 0    # one measurement, JSON

The FTCAPN kernel runs single-threaded (``threads: 1``) so processes are the only parallelism.
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
import yaml

ROOT = Path(__file__).resolve().parents[1]
CONFIG = ROOT / "configs" / "ftcapn_table3.yaml"


def _workers_cpu(executor) -> float:
    """CPU seconds the pool's worker processes have used so far (Linux /proc; NaN elsewhere or
    in-process)."""
    pool = getattr(executor, "_pool", None)
    if pool is None:
        return float("nan")
    tick = os.sysconf("SC_CLK_TCK")
    total = 0.0
    for pid in list(getattr(pool, "_processes", {})):
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        except OSError:
            return float("nan")
        total += (int(fields[11]) + int(fields[12])) / tick  # utime + stime
    return total


def measure(n: int, workers: int) -> dict:
    """One run of ``n`` samples with ``workers`` processes (0: in this process)."""
    from uqguide.config.run_config import validate_config
    from uqguide.driver.execution import ProcessExecutor, SerialExecutor
    from uqguide.driver.propagate import run

    raw = yaml.safe_load(CONFIG.read_text())
    raw["model"]["threads"] = 1
    raw.pop("reference", None)

    def config(n_samples: int):
        raw["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": n_samples,
                           "sampling": "random"}]
        return validate_config(raw)

    cfg = config(n)
    executor = ProcessExecutor(workers) if workers else SerialExecutor()
    try:
        # Warm-up: start the workers and load (or compile) the numba kernel in each, one
        # 8192-sample chunk per worker; reported apart from the timed run.
        t0 = time.perf_counter()
        run(config(8192 * max(workers, 1)), executor)
        warm = time.perf_counter() - t0
        load = os.getloadavg()[0]
        w0 = _workers_cpu(executor)
        c0 = time.process_time()
        t0 = time.perf_counter()
        result = run(cfg, executor)
        wall = time.perf_counter() - t0
        driver_cpu = time.process_time() - c0
        workers_cpu = _workers_cpu(executor) - w0
    finally:
        executor.close()
    r = result.run("mc")
    digest = hashlib.sha256()
    for _name, s in sorted(r.estimate.stats.items()):
        for k in ("mean", "std", "skewness", "kurtosis", "cov"):
            digest.update(np.ascontiguousarray(getattr(s, k)).tobytes())
        for k in sorted(s.ci):
            digest.update(np.ascontiguousarray(s.ci[k]).tobytes())
        for q in (s.quantiles, s.ci_quantiles):  # the exact 3-sigma quantiles too
            if q is not None:
                digest.update(np.ascontiguousarray(q).tobytes())
    omega = r.estimate.stats["omega_s"]
    zem = r.estimate.stats["zem"]
    series_bytes = sum(8 * n * result.time.size * o.k for o in result.outputs
                       if o.kind == "series")
    return {
        "n": n, "workers": workers, "wall_s": wall, "warmup_s": warm, "load": load,
        "driver_cpu_s": driver_cpu, "workers_cpu_s": workers_cpu,
        "model_s": r.model_seconds,
        "n_failed": r.n_failed, "T": int(result.time.size),
        "driver_peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "worker_peak_mib": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
        "series_if_kept_mib": series_bytes / 2**20,
        "stats_sha256": digest.hexdigest()[:16],
        "omega_s_end_mean": float(omega.mean[-1, 0]), "omega_s_end_std": float(omega.std[-1, 0]),
        "zem_mean": float(zem.mean[0]), "zem_std": float(zem.std[0]),
    }


def _spawn(n: int, workers: int) -> dict:
    out = subprocess.run([sys.executable, __file__, "--one", "--n", str(n), "--workers",
                          str(workers)], capture_output=True, text=True, cwd=ROOT,
                         env={**os.environ, "PYTHONPATH": str(ROOT)}, check=False)
    if out.returncode != 0:
        sys.exit(f"measurement n={n} workers={workers} failed:\n{out.stderr}")
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1_000_000, help="samples of the scale runs")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2],
                    help="process counts to compare (0: in-process)")
    ap.add_argument("--small", type=int, default=100_000,
                    help="samples of the serial memory-growth reference (0: skip)")
    ap.add_argument("--one", action="store_true", help="one measurement, printed as JSON")
    args = ap.parse_args()
    if args.one:
        print(json.dumps(measure(args.n, args.workers[0])))
        return
    rows = [_spawn(args.n, w) for w in args.workers]
    if args.small:
        rows.append(_spawn(args.small, 0))
    print(f"FTCAPN Table 3 Monte Carlo, {CONFIG.name}; {os.cpu_count()} CPUs")
    print(f"{'n':>9} {'workers':>7} {'warm-up s':>9} {'wall s':>8} {'runs/s':>8} "
          f"{'driver cpu':>10} {'workers cpu':>11} {'load':>5} {'model s':>8} "
          f"{'failed':>6} {'driver MiB':>10} {'worker MiB':>10} {'series MiB':>10}  stats")
    for r in rows:
        print(f"{r['n']:>9,} {r['workers']:>7} {r['warmup_s']:>9.1f} {r['wall_s']:>8.2f} "
              f"{r['n'] / r['wall_s']:>8.0f} {r['driver_cpu_s']:>10.1f} "
              f"{r['workers_cpu_s']:>11.1f} {r['load']:>5.2f} "
              f"{r['model_s']:>8.1f} {r['n_failed']:>6} {r['driver_peak_mib']:>10.0f} "
              f"{r['worker_peak_mib']:>10.0f} {r['series_if_kept_mib']:>10.0f}  "
              f"{r['stats_sha256']}")
    base = next((r for r in rows if r["workers"] == 1 and r["n"] == args.n), None)
    for r in rows:
        if base and r is not base and r["n"] == args.n:
            print(f"speed-up of {r['workers']} processes over 1: "
                  f"{base['wall_s'] / r['wall_s']:.3f}x")
    same = {r["stats_sha256"] for r in rows if r["n"] == args.n}
    print("statistics bit-identical across worker counts: "
          + ("yes" if len(same) == 1 else f"NO ({same})"))
    big = rows[0]
    print(f"omega_s at the end: mean {big['omega_s_end_mean']:.4e} rad/s, std "
          f"{big['omega_s_end_std']:.4e} rad/s; zem mean {big['zem_mean']:.4f} m, std "
          f"{big['zem_std']:.4f} m")
    print("load: 1-minute load average at the start of the timed run (wall times and the "
          "speed-up are only meaningful on an idle machine, load < 1); driver cpu: CPU seconds "
          "of the driver process (all of the run with 0 workers)")
    print("warm-up: worker start and numba kernel load, one chunk per worker (not in wall); "
          "workers cpu: CPU seconds of the worker processes in the timed run (/proc); "
          "model s: wall seconds in the model summed over the workers (above the model's share "
          "of workers cpu when the workers wait for a core); series MiB: what the time series "
          "alone would take if kept in memory; driver / worker MiB: peak resident set (ru_maxrss) "
          "of the driver and of its largest worker")


if __name__ == "__main__":
    main()
