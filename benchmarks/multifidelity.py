"""Multi-fidelity Monte Carlo against plain Monte Carlo at equal CPU (issue 30, item 5).

Cases (``--case``):

- ``analytic``: ``y_0 = x + 0.2 x^2``, levels ``y_j = y_0 + s_j e_j`` with known correlations
  and costs 1 : 0.05 : 0.01: the allocation against PWG16's closed form (eq 3.10, 3.13), and
  over ``--seeds`` seeds at equal cost the standard errors of mean and std of MFMC and MC, and
  the coverage of MFMC's 95% intervals of the exact mean and std (0.2, sqrt(1.08));
- ``uncorrelated``: a cheap level uncorrelated with the expensive one (a user's callable at
  two "fidelities"): plain MC, its standard error and its cost against the budget;
- ``euler``: the ``euler_decay`` model at dt = 0.01 / 0.1 / 0.4 through the ``mfmc`` method
  (pinned costs), coverage of the highest level's exact mean over seeds;
- ``ftcapn``, ``gmm_ftc``, ``ft_as``: a pilot of ``--pilot`` runs at each step of the model's
  dispersion config: measured CPU seconds per run (``time.process_time``, one thread), the
  correlation of each level with the highest per output, the allocation the ``mfmc`` method
  would make for the outputs together, and the CPU plain MC would need for the same standard
  error of the mean (and of the variance) against MFMC's;
- ``ft_as-run``: the ``mfmc`` method on FT-AS Case 2 (configs/ft_as_dispersion.yaml with
  ``controller: case2``) for ``--budget`` CPU seconds, serial or on ``--workers``; with
  ``--pce N`` a PCE level too (``pce_adaptive`` on N runs at ``--pce-step``, listed before
  ``mfmc``), its runs and fit charged to the saving. Printed: the h = 0.01 s plain-MC runs
  that would give the standard errors reached for the mean and for the variance of the worst
  output (the estimator's variance formula), the CPU saving, and per output the mean +- its
  standard error and the std with its bootstrap interval.

Every figure is printed in a table; nothing is asserted (the tests do that on small cases).

    python benchmarks/multifidelity.py --case analytic [--seeds 50]
    python benchmarks/multifidelity.py --case ft_as --pilot 60
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import numpy as np

from uqguide.config.run_config import load_yaml, validate_config
from uqguide.stats.mfmc_allocation import (
    mfmc_ratios, sample_sizes, select_allocation, variance_factor, variance_ratio,
)
from uqguide.stats.mfmc_estimator import mfmc_statistics

ROOT = Path(__file__).resolve().parents[1]

#: (config, fidelity parameter, levels highest first, outputs, model overrides)
PILOTS: dict[str, tuple[str, str, list[float], list[str], dict[str, Any]]] = {
    "ft_as": ("configs/ft_as_dispersion.yaml", "step", [0.01, 0.02, 0.05, 0.1],
              ["delta_v", "settle_r_e"], {"controller": "case2", "threads": 1}),
    "gmm_ftc": ("configs/gmm_ftc_dispersion.yaml", "dt", [0.1, 0.2, 0.5, 1.0],
                ["delta_v", "t_settle", "min_clearance"], {}),
    "ftcapn": ("configs/ftcapn_table3.yaml", "dt", [0.5, 1.0, 2.0], ["zem", "dv_total"], {}),
}


def _wilson(k: int, n: int) -> tuple[float, float]:
    z = 1.96
    p = k / n
    c = (p + z * z / (2 * n)) / (1 + z * z / n)
    h = z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return c - h, c + h


# ---------------------------------------------------------------------------------- pilot
def pilot(case: str, n: int, seed: int = 1) -> None:
    """Measured costs, correlations and the allocation of a pilot of ``n`` runs per level."""
    path, param, steps, outputs, overrides = PILOTS[case]
    raw = load_yaml(ROOT / path)
    raw["model"].update(overrides)
    raw.pop("reference", None)
    raw.pop("quantiles", None)
    raw.pop("events", None)
    cfg = validate_config({**raw, "methods": [{"name": "monte_carlo", "n_samples": n}]},
                          source=str(ROOT / path))
    names = outputs or list(cfg.outputs)
    rng = np.random.default_rng(seed)
    x = cfg.space.from_unit(rng.random((n, cfg.space.dim)))
    rows: list[dict[str, np.ndarray]] = []
    seconds = []
    for h in steps:
        model = cfg.model.at_fidelity({param: h})
        model.evaluate(x[:1], cfg.space.names, names)  # (compiles or loads the kernel)
        t0 = time.process_time()
        out = model.evaluate(x, cfg.space.names, names)
        seconds.append((time.process_time() - t0) / n)
        rows.append({k: out.scalars[k].reshape(n, -1) for k in names if k in out.scalars}
                    | {"_failed": out.failed})
        print(f"  {param} = {h:g}: {seconds[-1]:.4g} CPU-s per run, "
              f"{int(out.failed.sum())} failed", flush=True)
    ok = ~np.any([r["_failed"] for r in rows], axis=0)
    cols = [(k, c) for k in rows[0] if k != "_failed" for c in range(rows[0][k].shape[1])]
    keep = [(k, c) for k, c in cols if rows[0][k][ok, c].std() > 0]
    print(f"\n{case}: pilot of {n} runs ({int(ok.sum())} without failure); correlation with "
          f"{param} = {steps[0]:g} (of y, then of (y - mean)^2)")
    print(f"{'output':>22} " + " ".join(f"{param}={h:<8g}" for h in steps[1:]))
    rho = np.ones((2 * len(keep), len(steps)))
    for q, (k, c) in enumerate(keep):
        y0 = rows[0][k][ok, c]
        for j in range(1, len(steps)):
            yj = rows[j][k][ok, c]
            rho[q, j] = np.corrcoef(y0, yj)[0, 1]
            rho[len(keep) + q, j] = np.corrcoef((y0 - y0.mean())**2, (yj - yj.mean())**2)[0, 1]
        print(f"{k + f'[{c}]':>22} " + " ".join(f"{rho[q, j]:<.4f}/{rho[len(keep) + q, j]:<.4f}"
                                                for j in range(1, len(steps))))
    w = np.array(seconds)
    costs = w / w[0]
    alloc = select_allocation(np.nan_to_num(rho), w, 1.1)
    vr = variance_ratio(np.nan_to_num(rho)[:, list(alloc.levels)], w[list(alloc.levels)],
                        alloc.ratios)
    print(f"\nrelative cost per run: {', '.join(f'{c:.3g}' for c in costs)}")
    print(f"allocation: levels {[steps[i] for i in alloc.levels]}, m_i/m_0 = "
          f"{', '.join(f'{r:.3g}' for r in alloc.ratios)}")
    for q, (k, c) in enumerate(keep):
        print(f"  {k}[{c}]: CPU of plain MC / CPU of MFMC for the same s.e.: mean "
              f"{1 / vr[q]:.3g}x, variance {1 / vr[len(keep) + q]:.3g}x")
    print(f"  worst over the outputs: {1 / alloc.variance_ratio:.3g}x")


# ---------------------------------------------------------------------------------- analytic
NOISE = np.array([0.0, 0.3, 1.0])
COST = np.array([1.0, 0.05, 0.01])


def analytic(seeds: int, budget: float) -> None:
    """Closed-form allocation, then MFMC against MC at equal cost over seeds."""
    # y_0 = x + 0.2 x^2 has variance 1.08; y_j adds s_j e_j: rho_j = sqrt(1.08 / (1.08 + s_j^2))
    rho = np.sqrt(1.08 / (1.08 + NOISE**2))
    alloc = select_allocation(rho[None, :], COST)
    r_closed = mfmc_ratios(rho[list(alloc.levels)], COST[list(alloc.levels)])
    r2 = np.append(rho[list(alloc.levels)] ** 2, 0)
    closed = np.sum(np.sqrt(COST[list(alloc.levels)] * (r2[:-1] - r2[1:]))) ** 2 / COST[0]
    print(f"analytic: rho = {np.round(rho, 4).tolist()}, cost = {COST.tolist()}")
    print(f"  selected levels {alloc.levels}, ratios {np.round(alloc.ratios, 3).tolist()} "
          f"(closed form eq 3.10: {np.round(r_closed, 3).tolist()}), variance ratio "
          f"{alloc.variance_ratio:.4f} (eq 3.13: {closed:.4f})")
    sizes = sample_sizes(alloc, COST, budget=budget)
    n_mc = int(budget / COST[0])
    g = float(variance_factor(rho[list(alloc.levels)], sizes / sizes[0]))
    print(f"  budget {budget:g}: MFMC runs {sizes.tolist()}, plain MC runs {n_mc}; predicted "
          f"s.e. ratio of the mean {np.sqrt(g / sizes[0] * n_mc):.3f}")
    est = {"mfmc": [], "mc": []}
    hits = {"mean": 0, "std": 0}
    t_cpu = time.process_time()
    for s in range(seeds):
        rng = np.random.default_rng([s, 30])
        n = int(sizes[-1])
        x = rng.standard_normal(max(n, n_mc))
        y0 = x + 0.2 * x**2
        lv = [(y0 + NOISE[i] * rng.standard_normal(y0.size))[:sizes[j], None]
              for j, i in enumerate(alloc.levels)]
        st = mfmc_statistics(lv, sizes, n_resamples=200, seed=s)
        est["mfmc"].append((st.mean[0], st.std[0]))
        mc = y0[:n_mc]
        est["mc"].append((mc.mean(), mc.std()))
        hits["mean"] += st.ci["mean"][0, 0] <= 0.2 <= st.ci["mean"][1, 0]
        hits["std"] += st.ci["std"][0, 0] <= np.sqrt(1.08) <= st.ci["std"][1, 0]
    print(f"  over {seeds} seeds ({time.process_time() - t_cpu:.1f} CPU-s):")
    print(f"  {'':>6} {'s.e. mean':>10} {'s.e. std':>10} {'bias mean':>10}")
    for k, v in est.items():
        a = np.array(v)
        print(f"  {k:>6} {a[:, 0].std(ddof=1):10.5f} {a[:, 1].std(ddof=1):10.5f} "
              f"{a[:, 0].mean() - 0.2:+10.5f}")
    for k, h in hits.items():
        lo, hi = _wilson(h, seeds)
        print(f"  coverage of the exact {k}: {h}/{seeds} = {h / seeds:.2f} "
              f"(95% Wilson [{lo:.2f}, {hi:.2f}])")


# ---------------------------------------------------------------------------------- euler
EULER_LEVELS = [0.01, 0.1, 0.4]
EULER_COSTS = [1e-4, 1e-5, 2.5e-6]


def _euler_exact(dt: float, power: int, a: float = 0.5, b: float = 1.5) -> float:
    """``E[(1 - k dt)^(power n)]``, ``k ~ U(a, b)``, ``n = 2 / dt``."""
    n = power * round(2.0 / dt)
    return ((1 - a * dt) ** (n + 1) - (1 - b * dt) ** (n + 1)) / ((n + 1) * dt * (b - a))


def euler(seeds: int, budget: float) -> None:
    """The ``mfmc`` method on ``euler_decay`` against plain MC of dt = 0.01 at equal (pinned)
    cost, over seeds: standard errors and coverage of the exact mean and std."""
    from uqguide.driver.execution import SerialExecutor
    from uqguide.driver.propagate import propagate

    mean = _euler_exact(0.01, 1)
    std = np.sqrt(1.01 * _euler_exact(0.01, 2) - mean**2)  # E[y0^2] = 1 + 0.1^2
    base = {"model": {"name": "euler_decay", "dt": 0.01},
            "inputs": [{"name": "k", "dist": "uniform", "low": 0.5, "high": 1.5},
                       {"name": "y0", "dist": "normal", "mean": 1.0, "std": 0.1}],
            "outputs": ["y_end"]}
    rows: dict[str, list[tuple[float, float]]] = {"mfmc": [], "mc": []}
    hits = {"mean": 0, "std": 0}
    n_mc = int(budget / EULER_COSTS[0])
    t0 = time.process_time()
    diag: dict[str, Any] = {}
    for s in range(seeds):
        mf = validate_config({**base, "seed": s, "methods": [{
            "name": "mfmc", "fidelities": [{"dt": h} for h in EULER_LEVELS],
            "costs": EULER_COSTS, "budget_cpu_s": budget, "n_pilot": 50,
            "chunk_size": 1024}]})
        mc = validate_config({**base, "seed": s, "methods": [{
            "name": "monte_carlo", "n_samples": n_mc, "sensitivity": "off"}]})
        a = propagate(mf.methods[0], mf.model, mf.space, mf.outputs, s, SerialExecutor(4096))
        b = propagate(mc.methods[0], mc.model, mc.space, mc.outputs, s, SerialExecutor(4096))
        st, sb = a.estimate.stats["y_end"], b.estimate.stats["y_end"]
        rows["mfmc"].append((st.mean[0], st.std[0]))
        rows["mc"].append((sb.mean[0], sb.std[0]))
        hits["mean"] += st.ci["mean"][0, 0] <= mean <= st.ci["mean"][1, 0]
        hits["std"] += st.ci["std"][0, 0] <= std <= st.ci["std"][1, 0]
        diag = a.estimate.diagnostics
    print(f"euler_decay dt = {EULER_LEVELS}, pinned costs {EULER_COSTS} s per run, budget "
          f"{budget:g} s: MFMC runs {list(diag['runs_per_level'])}, plain MC {n_mc} runs; "
          f"{seeds} seeds, {time.process_time() - t0:.1f} CPU-s")
    print(f"  exact highest-level mean {mean:.6f}, std {std:.6f}")
    print(f"  {'':>6} {'s.e. mean':>10} {'s.e. std':>10} {'bias mean':>10}")
    for k, v in rows.items():
        arr = np.array(v)
        print(f"  {k:>6} {arr[:, 0].std(ddof=1):10.6f} {arr[:, 1].std(ddof=1):10.6f} "
              f"{arr[:, 0].mean() - mean:+10.6f}")
    for k, h in hits.items():
        lo, hi = _wilson(h, seeds)
        print(f"  coverage of the exact {k}: {h}/{seeds} = {h / seeds:.2f} "
              f"(95% Wilson [{lo:.2f}, {hi:.2f}])")


# ---------------------------------------------------------------------------------- useless
def fine(x: np.ndarray) -> np.ndarray:
    """The expensive level of the ``uncorrelated`` case: ``x1 + 0.2 x1^2``."""
    return x[:, 0] + 0.2 * x[:, 0] ** 2


def unrelated(x: np.ndarray) -> np.ndarray:
    """A cheap level that ignores ``x1``: uncorrelated with :func:`fine`."""
    return x[:, 1]


def uncorrelated(seeds: int, budget: float) -> None:
    """An uncorrelated cheap level: ``mfmc`` should run plain MC of the highest level, at
    plain MC's cost less the cheap level's pilot."""
    from uqguide.driver.execution import SerialExecutor
    from uqguide.driver.propagate import propagate

    costs = [1e-3, 1e-5]
    spent, ratios, plain = [], [], 0
    for s in range(seeds):
        cfg = validate_config({
            "model": {"name": "callable", "function": "multifidelity:fine", "isolate": False,
                      "inputs": ["x1", "x2"], "outputs": ["y"],
                      "module_dir": str(Path(__file__).resolve().parent)},
            "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
                       {"name": "x2", "dist": "normal", "std": 1.0}],
            "methods": [{"name": "mfmc", "fidelities": [{}, {"function":
                                                             "multifidelity:unrelated"}],
                         "costs": costs, "budget_cpu_s": budget, "n_pilot": 100}],
            "seed": s})
        r = propagate(cfg.methods[0], cfg.model, cfg.space, cfg.outputs, s,
                      SerialExecutor(10000))
        d, st = r.estimate.diagnostics, r.estimate.stats["y"]
        plain += bool(d["plain_mc"])
        cost = float(np.dot(d["runs_per_level"], costs))
        spent.append(cost / budget)
        # its standard error against plain MC's over the runs the budget buys
        ratios.append(st.sem[0] / (st.std[0] / np.sqrt(budget / costs[0])))
    print(f"uncorrelated cheap level, {seeds} seeds, budget {budget:g} s at pinned costs "
          f"{costs}: plain MC chosen {plain}/{seeds}; cost / budget {min(spent):.4f} to "
          f"{max(spent):.4f}; s.e. of the mean / plain MC's at the budget {min(ratios):.4f} "
          f"to {max(ratios):.4f}")


# ---------------------------------------------------------------------------------- FT-AS run
def ft_as_run(budget: float, n_pilot: int, workers: int, pce: int = 0,
              pce_step: float = 0.02, seed: int | None = None) -> None:
    """The ``mfmc`` method on FT-AS Case 2 at h = 0.01 s for ``budget`` CPU seconds."""
    from uqguide.driver.execution import ProcessExecutor, SerialExecutor
    from uqguide.driver.propagate import run

    raw = load_yaml(ROOT / "configs/ft_as_dispersion.yaml")
    raw["model"].update(controller="case2", threads=1)
    raw.pop("reference", None)
    raw["outputs"] = ["delta_v", "settle_r_e"]
    levels: list[dict[str, Any]] = [{"step": h} for h in (0.01, 0.02, 0.05, 0.1)]
    raw["methods"] = []
    if pce:
        raw["model"]["step"] = pce_step  # the fidelity the PCE learns
        raw["methods"].append({"name": "pce_adaptive", "label": "apce", "n_samples": pce,
                               "max_runs": pce})
        levels.append({"surrogate": "apce"})
    raw["methods"].append({"name": "mfmc", "fidelities": levels, "budget_cpu_s": budget,
                           "n_pilot": n_pilot, "chunk_size": 20})
    if seed is not None:
        raw["seed"] = seed
    cfg = validate_config(raw, source=str(ROOT / "configs/ft_as_dispersion.yaml"))
    ex = ProcessExecutor(workers, batch_size=20) if workers > 1 else SerialExecutor(20)
    t0 = time.process_time()
    try:
        result = run(cfg, ex)
    finally:
        ex.close()
    r = result.runs[-1]
    d = r.estimate.diagnostics
    spent = float(np.sum(d["cpu_per_level"])) + float(d.get("surrogate_cpu_s", 0.0))
    print(f"FT-AS Case 2 mfmc, budget {budget:g} CPU-s, pilot {n_pilot}, {workers} worker(s), "
          f"PCE level {'on ' + str(pce) + f' runs at h = {pce_step:g} s' if pce else 'none'}: "
          f"this process {time.process_time() - t0:.1f} CPU-s, model {r.model_seconds:.1f} s")
    for k in ("levels", "levels_used", "runs_per_level", "cpu_per_level", "cost_per_run",
              "surrogate_cpu_s", "estimated_variance_reduction", "equivalent_mc_runs",
              "equivalent_mc_runs_std", "equivalent_mc_cpu_s", "cpu_saving", "note"):
        print(f"  {k}: {d.get(k)}")
    c0 = float(d["cost_per_run"][0])
    print(f"  all CPU (levels + the PCE's runs and fit): {spent:.1f} s; h = 0.01 s costs "
          f"{c0:.3g} s per run")
    for name, st in r.estimate.stats.items():
        assert st.sem is not None and st.ci is not None
        for c in range(st.mean.shape[-1]):
            print(f"  {name}[{c}]: mean {st.mean[c]:.6g} +- {st.sem[c]:.3g} | std "
                  f"{st.std[c]:.6g} [{st.ci['std'][0, c]:.6g}, {st.ci['std'][1, c]:.6g}]")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default="analytic",
                    choices=["analytic", "euler", "uncorrelated", *PILOTS, "ft_as-run"])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--pilot", type=int, default=60)
    ap.add_argument("--budget", type=float, default=100.0,
                    help="cost units (analytic), CPU seconds (euler, ft_as-run)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--pce", type=int, default=0,
                    help="ft_as-run: add a PCE level fitted on this many runs (0: none)")
    ap.add_argument("--pce-step", type=float, default=0.02,
                    help="ft_as-run: the step of the runs the PCE learns [s]")
    ap.add_argument("--seed", type=int, default=None)
    a = ap.parse_args()
    if a.case == "analytic":
        analytic(a.seeds, a.budget)
    elif a.case == "uncorrelated":
        uncorrelated(a.seeds, a.budget)
    elif a.case == "euler":
        euler(a.seeds, a.budget)
    elif a.case in PILOTS:
        pilot(a.case, a.pilot)
    else:
        ft_as_run(a.budget, a.pilot, a.workers, a.pce, a.pce_step, a.seed)


if __name__ == "__main__":
    main()
