"""Late approach of ``configs/ftcapn_pce_table3.yaml``: where the degree-1 PCEs of omega_s stop
holding, whether uqguide flags it, and whether the corrected intervals hold the Monte Carlo curve.

For each seed, the config's tensor and Smolyak PCEs (with their 100 validation runs) run beside
a 1e5-run Monte Carlo; over the time steps in ``[--t0, --t1]`` (default 60-78 s) the table gives,
per PCE and statistic (mean, std): the largest relative error of the PCE value against the MC
(over the window, and over its steps before the first flag), the times from which uqguide flags
the PCE: its validation runs refute its statistics ("validation disagrees ... from t = ...") and
its out-of-sample error exceeds ``usable_error`` ("no usable surrogate from t = ..."), and the
share of
steps where the corrected value's 95% interval holds the MC value (``covered``) or where the
difference lies within both estimates' 95% half-widths in quadrature (``combined``: the report's
agreement flag; the MC's bootstrap intervals exist at the report times only, so between them
its relative half-width is interpolated).

    python benchmarks/pce_late_approach.py [--seeds 1 2 3] [--t0 60] [--t1 78]

About a minute per seed on one core.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import numpy as np
import yaml

import uqguide

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--t0", type=float, default=60.0)
    ap.add_argument("--t1", type=float, default=78.0)
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    cfg = yaml.safe_load((ROOT / "configs" / "ftcapn_pce_table3.yaml").read_text())
    pces = [m for m in cfg["methods"] if m["name"].startswith("pce_")]
    mc = {"name": "monte_carlo", "label": "mc1e5", "n_samples": 100_000, "sampling": "random"}
    cfg = dict(cfg, methods=[mc] + pces, reference="mc1e5", outputs=["omega_s"])
    print(f"{'seed':>4s} {'label':12s} {'stat':5s} {'max |pce-mc|/mc':>16s} "
          f"{'unflagged':>13s} {'disagrees':>11s} {'unusable':>11s} "
          f"{'covered':>8s} {'combined':>9s}   (steps {args.t0:g}-{args.t1:g} s)")
    for seed in args.seeds:
        r = uqguide.run(dict(cfg, seed=seed))
        t = r.time
        steps = (t >= args.t0) & (t <= args.t1)
        ref = r.run("mc1e5").estimate.stats["omega_s"]
        for p in pces:
            run = r.run(p["label"])
            s = run.estimate.stats["omega_s"]
            diag = run.estimate.diagnostics
            unusable = diag.get("no_usable_surrogate_from.omega_s")
            disagrees = diag.get("disagrees_from.omega_s")
            flags = [f for f in (unusable, disagrees) if f is not None]
            flag = min(flags) if flags else None
            # the PCE's own value where it was withdrawn: recompute from the kept surrogate
            own = run.estimate.surrogate.statistics("omega_s")
            for stat in ("mean", "std"):
                rv = ref.stat(stat)[steps, 0]
                if stat in ref.ci:
                    rlo, rhi = ref.ci[stat][0][steps, 0], ref.ci[stat][1][steps, 0]
                else:
                    rlo, rhi = rv - 1.96 * ref.sem[steps, 0], rv + 1.96 * ref.sem[steps, 0]
                pv = own.stat(stat)[steps, 0]
                cv = s.corrected[stat][steps, 0]
                lo, hi = s.corrected_ci[stat][0][steps, 0], s.corrected_ci[stat][1][steps, 0]
                covered = np.mean((lo <= rv) & (rv <= hi))
                half = np.where(rv > cv, hi - cv, cv - lo)
                # the MC's bootstrap intervals exist at the report times only; elsewhere its
                # error is taken from the nearest step that has one, relative to its value
                rel = np.abs(np.where(cv > rv, rhi - rv, rv - rlo) / rv)
                known = np.isfinite(rel)
                rel = np.interp(np.flatnonzero(steps), np.flatnonzero(steps)[known], rel[known]) \
                    if known.any() else np.zeros_like(rv)
                combined = np.mean(np.abs(cv - rv) <= np.hypot(half, rel * np.abs(rv)))
                rerr = np.abs(pv - rv) / np.abs(rv)
                err = np.max(rerr)
                kept = t[steps] < flag if flag is not None else np.ones_like(rerr, bool)
                err_kept = np.max(rerr[kept]) if kept.any() else float("nan")
                print(f"{seed:4d} {p['label']:12s} {stat:5s} {100 * err:15.1f}% "
                      f"{(f'{100 * err_kept:.1f}%' if kept.any() else 'none'):>13s} "
                      f"{_t(disagrees):>11s} {_t(unusable):>11s} "
                      f"{100 * covered:7.0f}% {100 * combined:8.0f}%", flush=True)


def _t(t: float | None) -> str:
    return f"{t:g} s" if t is not None else "-"


if __name__ == "__main__":
    main()
