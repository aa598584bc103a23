#!/usr/bin/env python
"""Where the validation runs' pool comes from: uniform against arcsine, on fixed surrogates.

The ``+cv`` intervals of a validated PCE (:mod:`uqguide.pce.validation`) come from its
validation runs, stratified by the surrogate's value from a pool of 200 points per run
(:mod:`uqguide.pce.validation_design`). This script holds each surrogate fixed and draws many
validation designs for it, so that the coverage it prints is that of the intervals alone (not
of the fit):

1. a zoo problem (``benchmarks/defaults_zoo.py``) is run once per ``--seeds`` seed through
   ``uqguide.run`` at the adaptive PCE's defaults; its surrogate and validation size are kept;
2. for each of ``--designs`` validation seeds and each pool (``uniform``: every input flat;
   ``arcsine``: the default, Beta(1/2, 1/2) in the inputs the surrogate is curved in when
   at most two are, uniform otherwise), the
   validation runs are drawn, the model is run at them, and the raw control-variate
   intervals (:func:`uqguide.pce.validation.corrected_moments`, before the report's far-tail
   widening and its checks against the runs) are scored against the zoo's reference at every
   report time;
3. the table gives, per pool and statistic, the coverage over seeds x designs x times, and the
   mean half-width relative to the uniform pool's.

Usage::

    python benchmarks/validation_pool.py --problem oscillator --seeds 3 --designs 40
    python benchmarks/validation_pool.py --problem oscillator --first-seed 32 --seeds 1
    python benchmarks/validation_pool.py --problem ramp --seeds 2 --designs 40 --times all

``--times all`` scores every step of a series (reference from 2^18 scrambled Sobol' points);
the default, the zoo's three report times.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent
sys.path.insert(0, str(ROOT.parent))
sys.path.insert(0, str(ROOT))

import defaults_zoo as zoo  # noqa: E402

import uqguide  # noqa: E402
from uqguide.pce.validation import corrected_moments  # noqa: E402
from uqguide.pce.validation_design import curved_inputs, stratified_validation  # noqa: E402

STATS = ("mean", "std", "skewness", "kurtosis")


def _pce_config(p: zoo.Problem, seed: int) -> dict:
    cfg = zoo.config(p, seed)
    cfg["methods"] = [m for m in cfg["methods"] if m["name"] == "pce_adaptive"]
    return cfg


def _columns(p: zoo.Problem, every_step: bool) -> np.ndarray | None:
    """Indices of the scored steps of a series (None: a scalar)."""
    if not p.report_times:
        return None
    t = np.asarray(p.function(np.ones((1, p.d)))["time"])
    if every_step:
        return np.arange(1, t.size)  # t = 0 is exact for every design
    return np.array([int(np.argmin(np.abs(t - rt))) for rt in p.report_times])


def _model(p: zoo.Problem, u: np.ndarray, name: str, cols: np.ndarray | None) -> np.ndarray:
    """The output at unit-cube points ``u`` (the scored columns of a series), the inputs
    mapped as the zoo's reference maps them."""
    x = zoo.to_inputs(p, u)
    y = np.asarray(p.function(x)[name], dtype=float)
    return y.reshape(y.shape[0], -1) if cols is None else y[:, cols]


def _reference(p: zoo.Problem, name: str, cols: np.ndarray | None, log2_n: int) -> np.ndarray:
    """Moments ``(4, columns)`` from ``2^log2_n`` scrambled Sobol' points, by chunks (power
    sums about the first chunk's mean)."""
    from scipy.stats import qmc

    u = qmc.Sobol(p.d, scramble=True, seed=20261128).random_base2(log2_n)
    shift, sums, n = None, None, 0
    for lo in range(0, u.shape[0], 1 << 14):
        y = _model(p, u[lo:lo + (1 << 14)], name, cols)
        shift = y.mean(axis=0) if shift is None else shift
        d = y - shift
        part = np.array([np.sum(d**k, axis=0) for k in (1, 2, 3, 4)])
        sums = part if sums is None else sums + part
        n += y.shape[0]
    m1, m2, m3, m4 = sums / n
    mu2 = m2 - m1**2
    mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
    mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
    return np.array([shift + m1, np.sqrt(mu2), mu3 / mu2**1.5, mu4 / mu2**2])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="oscillator",
                    choices=[p.name for p in zoo.PROBLEMS])
    ap.add_argument("--seeds", type=int, default=3, help="fitted surrogates (N seeds)")
    ap.add_argument("--first-seed", type=int, default=1)
    ap.add_argument("--designs", type=int, default=40, help="validation designs per surrogate")
    ap.add_argument("--times", choices=("report", "all"), default="report")
    ap.add_argument("--ref-log2", type=int, default=18)
    args = ap.parse_args(argv)
    p = next(q for q in zoo.PROBLEMS if q.name == args.problem)
    name = p.outputs[0]["name"]
    cols = _columns(p, args.times == "all")
    ref = _reference(p, name, cols, args.ref_log2)
    pools = ("uniform", "arcsine")
    hits = {k: {s: 0 for s in STATS} for k in pools}
    total = {k: {s: 0 for s in STATS} for k in pools}
    width = {k: {s: [] for s in STATS} for k in pools}
    t0 = time.process_time()
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        est = uqguide.run(_pce_config(p, seed)).run("apce").estimate
        sur = est.surrogate
        n_val = int(est.diagnostics.get("n_validation", 0))
        if n_val < 4 or name not in sur.expansions:
            print(f"seed {seed}: no validation runs or no fitted {name}; skipped")
            continue
        st = sur.statistics(name)
        pick = (lambda a: a) if cols is None else (lambda a: np.asarray(a)[cols])
        own = type(st)(mean=pick(st.mean), std=pick(st.std), skewness=pick(st.skewness),
                       kurtosis=pick(st.kurtosis), cov=np.zeros(1), n_used=st.n_used)
        curved = curved_inputs([sur.expansions[name].trimmed().alpha], p.d)
        for r in range(args.designs):
            for pool in pools:
                flat = np.zeros(p.d, dtype=bool)
                vd = stratified_validation(
                    lambda u, f=sur: {name: f.at_unit(u, [name])[name]}, 1000 * seed + r,
                    "pool", n_val, p.d, curved=curved if pool == "arcsine" else flat)
                y = _model(p, vd.u, name, cols)
                s = sur.at_unit(vd.u, [name])[name]
                s = s if cols is None else s[:, cols]
                cv = corrected_moments(own, y, s, weight=vd.weight, stratum=vd.stratum,
                                       share=vd.share, pool=vd.pool)
                for j, k in enumerate(STATS):
                    lo, hi = (np.asarray(cv.ci[k][0]).ravel(), np.asarray(cv.ci[k][1]).ravel())
                    v = np.asarray(ref[j]).ravel()
                    ok = np.isfinite(lo) & np.isfinite(hi)
                    hits[pool][k] += int(np.sum((lo <= v) & (v <= hi) & ok))
                    total[pool][k] += int(ok.sum())
                    width[pool][k].append(np.nanmean((hi - lo) / 2))
        print(f"seed {seed}: {n_val} validation runs, curved inputs {int(curved.sum())} of "
              f"{p.d}, {time.process_time() - t0:.0f} CPU-s so far", flush=True)
    print(f"\n{p.name}: raw +cv intervals, {args.seeds} surrogates x {args.designs} designs, "
          f"{'every step' if args.times == 'all' else 'report times'}")
    print(f"{'pool':<8} " + " ".join(f"{k:>22}" for k in STATS))
    for pool in pools:
        cells = []
        for k in STATS:
            n = total[pool][k]
            cover = hits[pool][k] / n if n else math.nan
            rel = np.nanmean(width[pool][k]) / np.nanmean(width["uniform"][k])
            cells.append(f"{100 * cover:6.1f}% (n {n:5d}) x{rel:4.2f}")
        print(f"{pool:<8} " + " ".join(f"{c:>22}" for c in cells))
    print(f"(coverage of the 95% intervals; x: mean half-width over the uniform pool's; "
          f"{time.process_time() - t0:.0f} CPU-s)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
