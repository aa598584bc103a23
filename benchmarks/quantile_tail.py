"""The end-of-run quantile tail of a 1e6-run Monte Carlo, on synthetic values shaped like the
FTCAPN study's (``configs/ftcapn_table3.yaml``, ``quantiles: 3sigma``): 2 series outputs of 9
lanes each, handed over as lane-major chunks of 8192 runs, and 5 scalar outputs.

Times what ``MonteCarlo.estimate_reduced`` runs in the driver once the workers are idle (the
order statistics of every output, on 1 and on ``--threads`` threads) and checks that the numbers
are the same bit for bit whatever the thread count.

Usage::

    python benchmarks/quantile_tail.py [--n 1000000] [--threads 2] [--repeat 7]
"""

from __future__ import annotations

import argparse
import hashlib
import time
from functools import partial

import numpy as np

from uqguide.methods import monte_carlo as mc
from uqguide.stats.quantiles import THREE_SIGMA, lane_quantiles


def jobs(n: int, chunk: int = 8192, seed: int = 0) -> dict:
    rng = np.random.default_rng(seed)
    out = {}
    for i in range(2):
        full = rng.standard_normal((9, n)) * rng.uniform(0.5, 2, (9, 1))
        lanes = [np.ascontiguousarray(full[:, a:a + chunk]) for a in range(0, n, chunk)]
        out[f"series{i}"] = (full.size, partial(lane_quantiles, lanes, (1, 9), THREE_SIGMA))
    good = np.ones(n, dtype=bool)
    for i in range(5):
        y = rng.standard_normal(n) ** (1 + i % 2)
        out[f"scalar{i}"] = (n, partial(mc._scalar_quantiles, y, good, THREE_SIGMA))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=1_000_000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    work = jobs(args.n)
    digests = set()
    for threads in sorted({1, args.threads}):
        mc.QUANTILE_THREADS = threads
        mc._run_jobs(work)  # warm-up
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            got = mc._run_jobs(work)
            times.append(time.perf_counter() - t0)
        h = hashlib.sha256()
        for name in work:
            for a in got[name]:
                h.update(a.tobytes())
        digests.add(h.hexdigest()[:16])
        print(f"{threads} thread(s): min {min(times):.3f} s, median {np.median(times):.3f} s"
              f"  ({len(work)} outputs, {args.n} runs; {h.hexdigest()[:16]})")
    print("bit-identical across thread counts:", len(digests) == 1)


if __name__ == "__main__":
    main()
