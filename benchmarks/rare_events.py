"""Subset simulation against plain Monte Carlo: model runs and coefficient of variation.

Cases (``--cases``, default ``analytic ftcapn``; ``gmm`` on purpose: about a minute of GMM
runs):

- ``analytic``: ``y = sum x_i / sqrt(d)`` of ``d`` standard normals above ``Phi^-1(1 - p)``,
  for ``p`` = 1e-3, 1e-4, 1e-5 (``d = 6``, and ``d = 20`` at 1e-5): the exact probability is
  ``p``. Over ``--seeds`` seeds (default 50) the table gives subset simulation's mean runs,
  mean estimate, the CoV observed over the seeds, its mean reported CoV (independent levels)
  and upper bound, and how often its 95% interval held ``p``. ``MC runs same CoV`` is what plain
  Monte Carlo needs for the observed CoV, ``(1 - p) / (p CoV^2)``, and ``MC CoV same runs`` the
  CoV plain Monte Carlo has with subset simulation's runs, ``sqrt((1 - p) / (n p))``.
- ``ftcapn``: configs/ftcapn_table4_rotating.yaml's model and inputs, the event zem > 33 m:
  subset simulation (N = 1000, p0 = 0.1) beside a 1e6-run Monte Carlo (Clopper-Pearson), one
  seed each, and whether they agree within their combined intervals.
- ``gmm``: configs/gmm_dispersion.yaml's model and inputs, the event min_clearance < 0.01 m
  (the path within 1 cm of a panel or antenna): subset simulation (N = 500) beside the stored
  1e4-run Monte Carlo of results/gmm_dispersion (its per-sample clearances), or beside a new
  Monte Carlo of ``--gmm-mc N`` runs.

    python benchmarks/rare_events.py [--seeds 50] [--cases analytic ftcapn gmm] [--gmm-mc N]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from uqguide.config.run_config import load_yaml, validate_config  # noqa: E402
from uqguide.core.events import clopper_pearson  # noqa: E402
from uqguide.driver.propagate import run  # noqa: E402
from uqguide.results.result import read_hdf5  # noqa: E402


def _fmt(v: float) -> str:
    return f"{v:.3g}"


def analytic(seeds: int) -> None:
    print("Analytic: P(sum of d normals / sqrt(d) > t) = p; subset simulation N = 800, p0 = 0.1")
    head = ("p", "d", "runs", "mean P", "CoV obs", "CoV rep", "CoV up", "in 95% CI",
            "MC runs same CoV", "MC CoV same runs", "wall s")
    print(" ".join(f"{h:>16}" for h in head))
    for p, d in ((1e-3, 6), (1e-4, 6), (1e-5, 6), (1e-5, 20)):
        cfg = validate_config({
            "model": {"name": "linear_gaussian", "coefficients": [[1 / np.sqrt(d)] * d]},
            "inputs": [{"name": f"x{i + 1}", "dist": "normal", "mean": 0.0, "std": 1.0}
                       for i in range(d)],
            "outputs": ["y"],
            "events": [{"name": "far", "output": "y", "above": float(stats.norm.isf(p))}],
            "methods": [{"name": "subset_simulation", "n_per_level": 800, "p0": 0.1,
                         "event": "far"}]})
        t0 = time.perf_counter()
        est, cov, up, runs, hit = [], [], [], [], 0
        for seed in range(seeds):
            r = run(cfg.with_seed(seed)).runs[0]
            ev = r.estimate.events["far"]
            est.append(ev.probability)
            cov.append(ev.cov)
            up.append(r.estimate.diagnostics["cov_upper"])
            runs.append(r.n_runs)
            hit += ev.ci[0] <= p <= ev.ci[1]
        est = np.array(est)
        obs = est.std(ddof=1) / est.mean()
        n = np.mean(runs)
        row = (p, d, f"{n:.0f}", _fmt(est.mean()), _fmt(obs), _fmt(np.mean(cov)),
               _fmt(np.mean(up)), f"{hit}/{seeds}", f"{(1 - p) / (p * obs**2):.3g}",
               _fmt(np.sqrt((1 - p) / (n * p))), f"{time.perf_counter() - t0:.1f}")
        print(" ".join(f"{str(v):>16}" for v in row))


def _side_by_side(name: str, sus, mc_k: int, mc_n: int, mc_seconds: float) -> None:
    ev = sus.estimate.events[name]
    lo, hi = clopper_pearson(mc_k, mc_n)
    p_mc = mc_k / mc_n
    cov_mc = np.sqrt((1 - p_mc) / (mc_n * p_mc)) if mc_k else float("nan")
    print(f"{'method':>20} {'runs':>8} {'P':>10} {'95% interval':>24} {'CoV':>7} {'model s':>8}")
    print(f"{'subset_simulation':>20} {sus.n_runs:>8} {ev.probability:>10.3g} "
          f"{f'[{ev.ci[0]:.3g}, {ev.ci[1]:.3g}]':>24} {ev.cov:>7.3g} "
          f"{sus.model_seconds:>8.1f}")
    print(f"{'monte_carlo':>20} {mc_n:>8} {p_mc:>10.3g} {f'[{lo:.3g}, {hi:.3g}]':>24} "
          f"{cov_mc:>7.3g} {mc_seconds:>8.1f}")
    agree = ev.ci[0] <= hi and lo <= ev.ci[1]
    print(f"intervals overlap: {'yes' if agree else 'NO'}; plain MC at subset simulation's "
          f"CoV would need {(1 - p_mc) / (p_mc * ev.cov**2):.3g} runs" if mc_k else "")


def ftcapn() -> None:
    base = load_yaml(ROOT / "configs" / "ftcapn_table4_rotating.yaml")
    common = {"model": base["model"], "inputs": base["inputs"], "outputs": ["zem"],
              "events": [{"name": "wide", "output": "zem", "above": 33.0}], "seed": 4}
    cfg = validate_config({**common, "methods": [
        {"name": "subset_simulation", "label": "sus", "n_per_level": 1000, "event": "wide"},
        {"name": "monte_carlo", "label": "mc1e6", "n_samples": 1_000_000, "bootstrap": 0}]})
    print("\nFTCAPN Table 4, rotating maneuver frame: P(zem > 33 m)")
    res = run(cfg)
    mc = res.run("mc1e6").estimate.events["wide"]
    _side_by_side("wide", res.run("sus"), mc.n_in, mc.n_used, res.run("mc1e6").model_seconds)


def gmm(mc_runs: int) -> None:
    base = load_yaml(ROOT / "configs" / "gmm_dispersion.yaml")
    common = {"model": base["model"], "inputs": base["inputs"], "outputs": ["min_clearance"],
              "events": [{"name": "graze", "output": "min_clearance", "below": 0.01}],
              "seed": base["seed"]}
    cfg = validate_config({**common, "methods": [
        {"name": "subset_simulation", "label": "sus", "n_per_level": 500, "event": "graze"}]})
    res = run(cfg)
    if mc_runs:
        print(f"\nGMM-NTSMC dispersion: P(min_clearance < 0.01 m); Monte Carlo {mc_runs} runs")
        mc = run(validate_config({**common, "methods": [
            {"name": "monte_carlo", "label": "mc", "n_samples": mc_runs, "bootstrap": 0}]}))
        r = mc.run("mc")
        ev = r.estimate.events["graze"]
        _side_by_side("graze", res.run("sus"), ev.n_in, ev.n_used, r.model_seconds)
        return
    stored = read_hdf5(ROOT / "results" / "gmm_dispersion" / "gmm_dispersion.h5")
    mc = stored.run("mc10000")
    clear = mc.scalars["min_clearance"][~mc.failed, 0]
    print("\nGMM-NTSMC dispersion: P(min_clearance < 0.01 m); Monte Carlo: the stored 1e4 runs")
    _side_by_side("graze", res.run("sus"), int((clear < 0.01).sum()), clear.size,
                  mc.model_seconds)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--gmm-mc", type=int, default=0, metavar="N",
                    help="gmm case: run a Monte Carlo of N runs (1e5: about 20 min on 2 cores) "
                         "instead of using the stored 1e4")
    ap.add_argument("--cases", nargs="+", default=["analytic", "ftcapn"],
                    choices=["analytic", "ftcapn", "gmm"])
    a = ap.parse_args()
    for case in a.cases:
        {"analytic": lambda: analytic(a.seeds), "ftcapn": ftcapn,
         "gmm": lambda: gmm(a.gmm_mc)}[case]()


if __name__ == "__main__":
    main()
