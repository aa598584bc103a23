"""Coverage of a validated PCE's corrected 95% intervals, over design seeds.

For each case, the adaptive PCE is run with ``--seeds`` design seeds (each with its own
validation stream: the seed keys both) and 100 validation runs; the table gives, per moment,
the share of the control-variate intervals (:mod:`uqguide.pce.validation`) that contain the
reference value, with the average half-width and the average absolute error of the corrected
and of the plain PCE value:

- ``table5``: ``configs/ftcapn_table5.yaml``'s adaptive PCE (150 -> 300 runs + 100
  validation) for the ZEM; reference: a pooled Monte Carlo of ``--mc-runs`` x 1e5 runs (4e5 by
  default) with its own 95% bootstrap interval. The reference is itself uncertain, so a
  second column ("combined") counts the seeds where the difference lies within the interval
  of the difference, both 95% half-widths combined in quadrature (the report's agreement
  flag); the literal share is bounded above by how much narrower the reference's interval is
  than the PCE's.
- ``ishigami`` (100 runs + 100 validation) and ``borehole`` (50 runs + 100 validation): exact
  references (closed form / tensor Gauss rules, as ``benchmarks/pce_accuracy.py``).

    python benchmarks/pce_coverage.py [--seeds 20] [--cases table5 ishigami borehole]
                                      [--mc-runs 4]

The full run (20 seeds, 4e5 MC) takes about 15 minutes of one core; ``--seeds 3 --mc-runs 1``
is a quick check.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

from uqguide.methods.pce_adaptive import AdaptivePCE  # noqa: E402
from uqguide.stats import STAT_NAMES, bootstrap_intervals, central_moments  # noqa: E402
from uqguide.types import ModelOutput  # noqa: E402

VALIDATION = 100


def _corrected(method: AdaptivePCE, model: Any, space: Any, output: str, seed: int
               ) -> tuple[dict[str, float], dict[str, float], dict[str, tuple[float, float]]]:
    design = method.design(space, seed)
    out = model.evaluate(design.x, space.names, [output])
    while (bigger := method.refine(space, design, out)) is not None:
        more = model.evaluate(bigger.x[design.n_runs:], space.names, [output])
        design, out = bigger, ModelOutput.concatenate([out, more])
    s = method.estimate(space, design, out).stats[output]
    return ({k: float(s.stat(k)[0]) for k in STAT_NAMES},
            {k: float(s.corrected[k][0]) for k in STAT_NAMES},
            {k: (float(s.corrected_ci[k][0, 0]), float(s.corrected_ci[k][1, 0]))
             for k in STAT_NAMES})


def analytic_case(name: str, n_seeds: int) -> list[dict[str, Any]]:
    from pce_accuracy import cases

    case = next(c for c in cases() if c["name"] == name)
    n = {"ishigami": 100, "borehole": 50}[name]
    rows = []
    for seed in range(1, n_seeds + 1):
        m = AdaptivePCE({"n_samples": n, "validation": {"n_samples": VALIDATION},
                         "label": "apce"})
        pce, cv, ci = _corrected(m, case["model"], case["space"], case["output"], seed)
        rows.append({"pce": pce, "cv": cv, "ci": ci})
    return [{"case": f"{name} ({n} + {VALIDATION} runs)", "ref": case["ref"],
             "ref_half": {k: 0.0 for k in STAT_NAMES}, "rows": rows}]


def table5_case(n_seeds: int, mc_runs: int) -> list[dict[str, Any]]:
    import uqguide

    cfg = yaml.safe_load((ROOT / "configs" / "ftcapn_table5.yaml").read_text())
    apce = next(m for m in cfg["methods"] if m["name"] == "pce_adaptive")
    mc = next(m for m in cfg["methods"] if m["label"] == "mc1e5")
    cfg.pop("reference", None)
    t0 = time.perf_counter()
    pooled = []
    for i in range(mc_runs):
        r = uqguide.run(dict(cfg, methods=[mc], seed=900_000 + i))
        run = r.runs[0]
        pooled.append(np.asarray(run.scalars["zem"])[~np.asarray(run.failed, bool), 0])
    y = np.concatenate(pooled)
    mean, mu2, mu3, mu4 = central_moments(y)
    ref = {"mean": float(mean), "std": float(np.sqrt(mu2)),
           "skewness": float(mu3 / mu2**1.5), "kurtosis": float(mu4 / mu2**2)}
    ci = bootstrap_intervals(y[:, None], n_resamples=400, seed=1)
    ref_half = {k: float(ci[k][1, 0] - ci[k][0, 0]) / 2 for k in STAT_NAMES}
    print(f"table5: pooled MC of {y.size} runs in {time.perf_counter() - t0:.0f} s: "
          + ", ".join(f"{k} {ref[k]:.5g} +- {ref_half[k]:.2g}" for k in STAT_NAMES),
          flush=True)
    rows = []
    for seed in range(1, n_seeds + 1):
        t0 = time.perf_counter()
        r = uqguide.run(dict(cfg, methods=[apce], seed=seed))
        s = r.runs[0].estimate.stats["zem"]
        rows.append({"pce": {k: float(s.stat(k)[0]) for k in STAT_NAMES},
                     "cv": {k: float(s.corrected[k][0]) for k in STAT_NAMES},
                     "ci": {k: (float(s.corrected_ci[k][0, 0]), float(s.corrected_ci[k][1, 0]))
                            for k in STAT_NAMES}})
        print(f"  seed {seed}: {time.perf_counter() - t0:.0f} s, " + ", ".join(
            f"{k} {rows[-1]['cv'][k]:.5g} [{rows[-1]['ci'][k][0]:.5g}, "
            f"{rows[-1]['ci'][k][1]:.5g}]" for k in STAT_NAMES), flush=True)
    return [{"case": f"table5 zem (300 + {VALIDATION} runs; ref {y.size} MC)", "ref": ref,
             "ref_half": ref_half, "rows": rows}]


def table(results: list[dict[str, Any]]) -> str:
    lines = [f"{'case':46s} {'moment':9s} {'covered':>8s} {'combined':>9s} {'half-width':>11s} "
             f"{'|cv - ref|':>11s} {'|pce - ref|':>11s} {'ref +-':>9s}"]
    for res in results:
        rows = res["rows"]
        for k in STAT_NAMES:
            ref, rh = res["ref"][k], res["ref_half"][k]
            lo = np.array([r["ci"][k][0] for r in rows])
            hi = np.array([r["ci"][k][1] for r in rows])
            cv = np.array([r["cv"][k] for r in rows])
            pce = np.array([r["pce"][k] for r in rows])
            half = (hi - lo) / 2
            covered = np.mean((lo <= ref) & (ref <= hi))
            combined = np.mean(np.abs(cv - ref) <= np.hypot(half, rh))
            lines.append(f"{res['case']:46s} {k:9s} {100 * covered:7.0f}% {100 * combined:8.0f}% "
                         f"{np.mean(half):11.3g} {np.mean(np.abs(cv - ref)):11.3g} "
                         f"{np.nanmean(np.abs(pce - ref)):11.3g} {rh:9.2g}")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--mc-runs", type=int, default=4, help="1e5-run MC runs pooled (table5)")
    ap.add_argument("--cases", nargs="+", default=["table5", "ishigami", "borehole"],
                    choices=["table5", "ishigami", "borehole"])
    args = ap.parse_args()
    logging.disable(logging.WARNING)
    t0 = time.perf_counter()
    results = []
    for c in args.cases:
        results += table5_case(args.seeds, args.mc_runs) if c == "table5" \
            else analytic_case(c, args.seeds)
    print()
    print(f"Coverage of the corrected 95% intervals over {args.seeds} design seeds "
          f"({VALIDATION} validation runs each); covered: the interval holds the reference; "
          f"combined: |cv - ref| within both half-widths in quadrature")
    print(table(results))
    print(f"\nwall {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
