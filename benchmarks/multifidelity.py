"""Multi-fidelity Monte Carlo against plain Monte Carlo at equal CPU (issue 30, item 5).

Cases (``--case``):

- ``analytic``: ``y_0 = x + 0.2 x^2``, levels ``y_j = y_0 + s_j e_j`` with known correlations
  and costs 1 : 0.05 : 0.01: the allocation against PWG16's closed form (eq 3.10, 3.13), and
  over ``--seeds`` seeds at equal cost the standard errors of mean and std of MFMC and MC, and
  the coverage of MFMC's 95% intervals of the exact mean and std (0.2, sqrt(1.08));
- ``uncorrelated``: a cheap level uncorrelated with the expensive one (a user's callable at
  two "fidelities"): plain MC, its standard error and its cost against the budget;
- ``euler``: the ``euler_decay`` model at dt = 0.01 / 0.1 / 0.4 through the ``mfmc`` method
  (pinned costs), coverage of the highest level's exact mean over seeds; with ``--pce 1`` the
  levels are dt = 0.01 and a PCE of dt = 0.1 (``pce_tensor``, 25 runs; its cost pinned at
  1e-7 s per run, its fit outside the budget);
- ``pendulum``: the ``mfmc`` method at its defaults on a three-level explicit-Euler pendulum
  ``callable`` (``benchmarks/pendulum_levels.py``, its calls in a guard process) for
  ``--budget`` CPU-s (default 4) over ``--seeds`` seeds from ``--seed`` (default 0): the process
  tree's CPU against the budget (psutil over every process below this one), the MSE of mean
  and std against ``monte_carlo``'s at the same measured CPU (a bootstrap interval over the
  seeds), the coverage of the exact mean and std (Gauss-Legendre quadrature);
- ``ftcapn``, ``gmm_ftc``, ``ft_as``: a pilot of ``--pilot`` runs at each step of the model's
  dispersion config: measured CPU seconds per run (``time.process_time``, one thread), the
  correlation of each level with the highest per output, the allocation the ``mfmc`` method
  would make for the outputs together, and the CPU plain MC would need for the same standard
  error of the mean (and of the variance) against MFMC's;
- ``ft_as-run`` (and ``ftcapn-run``, ``gmm_ftc-run``): the ``mfmc`` method on FT-AS Case 2
  (configs/ft_as_dispersion.yaml with ``controller: case2``; the other two on their pilot
  configs and levels) for ``--budget`` CPU seconds, serial or on ``--workers``; with
  ``--pce N`` a PCE level too (``pce_adaptive`` on N runs at ``--pce-step``, listed before
  ``mfmc``), its runs and fit charged to the saving. Printed: the h = 0.01 s plain-MC runs
  that would give the standard errors reached for the mean and for the variance of the worst
  output (the estimator's variance formula), the CPU saving, and per output the mean +- its
  standard error and the std with its bootstrap interval.

With ``--peer-python PATH`` (an interpreter that has MXMCPy; ``benchmarks/mfmc_mxmcpy.py``)
the ``analytic`` case and the simulator pilots also print, per quantity, the variance ratio
against plain MC at equal cost of uqguide's allocation beside MXMCPy's MFMC, MLMC and ACV
optimisers (ACV-MF, ACV-IS, GRD-MR) for the same costs and covariance.

Every figure is printed in a table; nothing is asserted (the tests do that on small cases).

    python benchmarks/multifidelity.py --case analytic [--seeds 50]
    python benchmarks/multifidelity.py --case pendulum [--seeds 50] [--budget 4]
    python benchmarks/multifidelity.py --case ft_as --pilot 60
    python benchmarks/multifidelity.py --case analytic --peer-python /tmp/mx/bin/python
"""

from __future__ import annotations

import argparse
import json
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from pendulum_levels import PENDULUM_STEPS, PENDULUM_T, pendulum_fine

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


# ---------------------------------------------------------------------------------- peers
def peers(costs: np.ndarray, covs: dict[str, np.ndarray], python: str | None) -> None:
    """uqguide's allocation for each quantity alone beside MXMCPy's (module docstring): the
    variance ratio against plain MC of level 0 at equal cost (lower is better)."""
    if not python:
        return
    with tempfile.NamedTemporaryFile("w", suffix=".json", delete=False) as f:
        json.dump({"costs": [float(c) for c in costs],
                   "quantities": {k: np.asarray(v).tolist() for k, v in covs.items()}}, f)
    proc = subprocess.run([python, str(ROOT / "benchmarks" / "mfmc_mxmcpy.py"), f.name],
                          capture_output=True, text=True)
    Path(f.name).unlink()
    if proc.returncode:
        print(f"  peer failed: {proc.stderr.strip().splitlines()[-1:]}")
        return
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    algs = list(dict.fromkeys(r["algorithm"] for r in rows))
    print("\n  variance ratio vs plain MC at equal cost, one quantity at a time (MXMCPy 1.0 "
          "with its model selection; uqguide with its own)")
    print(f"  {'quantity':>22} {'uqguide mfmc':>13} " + " ".join(f"{a:>13}" for a in algs))
    for name, cov in covs.items():
        sd = np.sqrt(np.diag(cov))
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = np.nan_to_num(cov[0] / (sd[0] * sd))
        ours = select_allocation(rho[None, :], costs).variance_ratio
        cells = []
        for a in algs:
            r = next(r for r in rows if r["quantity"] == name and r["algorithm"] == a)
            cells.append(f"{r['variance_ratio']:13.4f}" if "variance_ratio" in r else
                         f"{'error':>13}")
        print(f"  {name:>22} {ours:13.4f} " + " ".join(cells))
    errors = {r["algorithm"]: r["error"] for r in rows if "error" in r}
    for a, e in errors.items():
        print(f"  {a}: {e}")


# ---------------------------------------------------------------------------------- pilot
def pilot(case: str, n: int, seed: int = 1, peer_python: str | None = None) -> None:
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
    covs = {}
    for k, c in keep:
        ys = np.stack([r[k][ok, c] for r in rows], axis=1)
        covs[f"{k}[{c}]"] = np.cov(ys, rowvar=False)
        sq = (ys - ys.mean(axis=0)) ** 2
        covs[f"({k}[{c}] - mean)^2"] = np.cov(sq, rowvar=False)
    peers(w, covs, peer_python)
    print(f"  worst over the outputs: {1 / alloc.variance_ratio:.3g}x")


# ---------------------------------------------------------------------------------- analytic
NOISE = np.array([0.0, 0.3, 1.0])
COST = np.array([1.0, 0.05, 0.01])


def analytic(seeds: int, budget: float, peer_python: str | None = None) -> None:
    """Closed-form allocation, then MFMC against MC at equal cost over seeds."""
    # y_0 = x + 0.2 x^2 has variance 1.08; y_j adds s_j e_j: rho_j = sqrt(1.08 / (1.08 + s_j^2))
    rho = np.sqrt(1.08 / (1.08 + NOISE**2))
    # (the levels share y_0 and add independent noise: cov_ij = 1.08 + s_i^2 [i = j])
    peers(COST, {"y_0 = x + 0.2 x^2": 1.08 + np.diag(NOISE**2)}, peer_python)
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
    est: dict[str, list[tuple[float, float]]] = {"mfmc": [], "blue": [], "mc": []}
    hits = {(e, k): 0 for e in ("mfmc", "blue") for k in ("mean", "std")}
    t_cpu = time.process_time()
    for s in range(seeds):
        rng = np.random.default_rng([s, 30])
        n = int(sizes[-1])
        x = rng.standard_normal(max(n, n_mc))
        y0 = x + 0.2 * x**2
        lv = [(y0 + NOISE[i] * rng.standard_normal(y0.size))[:sizes[j], None]
              for j, i in enumerate(alloc.levels)]
        _both_estimators(lv, sizes, s, 0.2, np.sqrt(1.08), est, hits)
        mc = y0[:n_mc]
        est["mc"].append((mc.mean(), mc.std()))
    print(f"  over {seeds} seeds ({time.process_time() - t_cpu:.1f} CPU-s):")
    _print_spread_and_coverage(est, hits, seeds, 0.2, np.sqrt(1.08))


def _both_estimators(lv: list[np.ndarray], sizes: np.ndarray, seed: int, mean: float,
                     std: float, est: dict[str, list[tuple[float, float]]],
                     hits: dict[tuple[str, str], int]) -> None:
    """One seed's MFMC and BLUE estimates of mean and std, and whether their 95% intervals
    hold the exact values, added to ``est`` and ``hits``."""
    for e in ("mfmc", "blue"):
        st = mfmc_statistics(lv, sizes, n_resamples=200, seed=seed, estimator=e)
        est[e].append((st.mean[0], st.std[0]))
        hits[e, "mean"] += bool(st.ci["mean"][0, 0] <= mean <= st.ci["mean"][1, 0])
        hits[e, "std"] += bool(st.ci["std"][0, 0] <= std <= st.ci["std"][1, 0])


def _print_spread_and_coverage(est: dict[str, list[tuple[float, float]]],
                               hits: dict[tuple[str, str], int], seeds: int, mean: float,
                               std: float) -> None:
    """The estimates' spread and bias over the seeds, and the intervals' coverage."""
    print(f"  {'':>6} {'s.e. mean':>10} {'s.e. std':>10} {'bias mean':>10} {'bias std':>10}")
    for k, v in est.items():
        a = np.array(v)
        print(f"  {k:>6} {a[:, 0].std(ddof=1):10.5f} {a[:, 1].std(ddof=1):10.5f} "
              f"{a[:, 0].mean() - mean:+10.5f} {a[:, 1].mean() - std:+10.5f}")
    for (e, k), h in hits.items():
        lo, hi = _wilson(h, seeds)
        print(f"  {e}: coverage of the exact {k}: {h}/{seeds} = {h / seeds:.2f} "
              f"(95% Wilson [{lo:.2f}, {hi:.2f}])")


# ---------------------------------------------------------------------------------- jumps
#: rare jumps the cheap levels miss (FT-AS's settling times: one row in 400 settles 34 s later
#: at h = 0.01 s than at 0.02 s): size and probability
JUMP, P_JUMP = 10.0, 0.005
JUMP_COST = np.array([1.0, 0.5, 0.001])


def _jump_levels(rng: np.random.Generator, n: int, jump: float, p: float) -> list[np.ndarray]:
    x, u = rng.standard_normal(n), rng.random(n)
    smooth = x + 0.2 * x**2
    return [smooth + jump * (u < p), smooth + 0.05 * rng.standard_normal(n),
            x + 0.3 * rng.standard_normal(n)]


def jumps(seeds: int, budget: float, n_pilot: int, jump: float = JUMP,
          p: float = P_JUMP) -> None:
    """A non-smooth case: level 0 jumps by JUMP with probability P_JUMP, level 1 follows it
    closely but never jumps, level 2 is cheap and rougher. Per seed: a pilot of ``n_pilot``
    rows, the method's allocation from it, both estimators; coverage of the exact mean
    ``0.2 + JUMP p`` and std ``sqrt(1.08 + JUMP^2 p (1 - p))``, and the s.e. against plain MC of
    level 0 at equal cost."""
    mean = 0.2 + jump * p
    std = np.sqrt(1.08 + jump**2 * p * (1 - p))
    n_mc = int(budget / JUMP_COST[0])
    est: dict[str, list[tuple[float, float]]] = {"mfmc": [], "blue": [], "mc": []}
    hits = {(e, k): 0 for e in ("mfmc", "blue") for k in ("mean", "std")}
    runs = []
    for s in range(seeds):
        rng = np.random.default_rng([s, 32])
        pool = _jump_levels(rng, 400_000, jump, p)
        pilot = [y[:n_pilot] for y in pool]
        rows = [np.concatenate([p - p.mean(), (p - p.mean()) ** 2]) for p in pilot]
        rho = np.array([[np.corrcoef(rows[0][:n_pilot], r[:n_pilot])[0, 1] for r in rows],
                        [np.corrcoef(rows[0][n_pilot:], r[n_pilot:])[0, 1] for r in rows]])
        alloc = select_allocation(rho, JUMP_COST, 1.1)
        spent = float(np.dot(JUMP_COST, np.full(3, n_pilot))) - \
            float(np.sum(JUMP_COST[list(alloc.levels)])) * n_pilot
        sizes = sample_sizes(alloc, JUMP_COST, budget=budget - spent, at_least=n_pilot)
        runs.append(sizes.tolist())
        lv = [pool[i][:sizes[j], None] for j, i in enumerate(alloc.levels)]
        _both_estimators(lv, sizes, s, mean, std, est, hits)
        mc = pool[0][:n_mc]
        est["mc"].append((mc.mean(), mc.std()))
    print(f"jumps: level 0 jumps by {jump:g} with p = {p:g}, costs {JUMP_COST.tolist()}, "
          f"budget {budget:g}, pilot {n_pilot}; exact mean {mean:.4f}, std {std:.4f}; "
          f"runs per level (first 3 seeds) {runs[:3]}, plain MC {n_mc}")
    _print_spread_and_coverage(est, hits, seeds, mean, std)


# ---------------------------------------------------------------------------------- euler
EULER_LEVELS = [0.01, 0.1, 0.4]
EULER_COSTS = [1e-4, 1e-5, 2.5e-6]


def _euler_exact(dt: float, power: int, a: float = 0.5, b: float = 1.5) -> float:
    """``E[(1 - k dt)^(power n)]``, ``k ~ U(a, b)``, ``n = 2 / dt``."""
    n = power * round(2.0 / dt)
    return ((1 - a * dt) ** (n + 1) - (1 - b * dt) ** (n + 1)) / ((n + 1) * dt * (b - a))


def euler(seeds: int, budget: float, pce: bool = False, estimator: str = "blue") -> None:
    """The ``mfmc`` method on ``euler_decay`` against plain MC of dt = 0.01 at equal (pinned)
    cost, over seeds: standard errors and coverage of the exact mean and std."""
    from uqguide.driver.execution import SerialExecutor
    from uqguide.driver.propagate import propagate, run

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
        if pce:
            mf = validate_config({**base, "model": {"name": "euler_decay", "dt": 0.1},
                                  "seed": s, "methods": [
                {"name": "pce_tensor", "label": "tpce", "m": 5},
                {"name": "mfmc", "fidelities": [{"dt": 0.01}, {"surrogate": "tpce"}],
                 "costs": [EULER_COSTS[0], 1e-7], "budget_cpu_s": budget, "n_pilot": 50,
                 "chunk_size": 1024, "estimator": estimator}]})
            a = run(mf, SerialExecutor(4096)).runs[-1]
        else:
            mf = validate_config({**base, "seed": s, "methods": [{
                "name": "mfmc", "fidelities": [{"dt": h} for h in EULER_LEVELS],
                "costs": EULER_COSTS, "budget_cpu_s": budget, "n_pilot": 50,
                "chunk_size": 1024, "estimator": estimator}]})
            a = propagate(mf.methods[0], mf.model, mf.space, mf.outputs, s,
                          SerialExecutor(4096))
        mc = validate_config({**base, "seed": s, "methods": [{
            "name": "monte_carlo", "n_samples": n_mc, "sensitivity": "off"}]})
        b = propagate(mc.methods[0], mc.model, mc.space, mc.outputs, s, SerialExecutor(4096))
        st, sb = a.estimate.stats["y_end"], b.estimate.stats["y_end"]
        rows["mfmc"].append((st.mean[0], st.std[0]))
        rows["mc"].append((sb.mean[0], sb.std[0]))
        hits["mean"] += st.ci["mean"][0, 0] <= mean <= st.ci["mean"][1, 0]
        hits["std"] += st.ci["std"][0, 0] <= std <= st.ci["std"][1, 0]
        diag = a.estimate.diagnostics
    levels = "dt = 0.01 and a PCE of dt = 0.1" if pce else f"dt = {EULER_LEVELS}"
    print(f"euler_decay {levels}, estimator {estimator}, pinned costs "
          f"{diag['cost_per_run']} s per run, budget {budget:g} s: MFMC runs "
          f"{list(diag['runs_per_level'])}, plain MC {n_mc} runs; "
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


# ---------------------------------------------------------------------------------- pendulum
PENDULUM_INPUTS = [{"name": "theta0", "dist": "uniform", "low": 0.3, "high": 1.2},
                   {"name": "length", "dist": "uniform", "low": 0.8, "high": 1.2},
                   {"name": "damping", "dist": "uniform", "low": 0.1, "high": 0.3}]


def _pendulum_config(method: dict[str, Any], seed: int) -> dict[str, Any]:
    """The pendulum as a ``callable`` at its defaults (a guard process), with ``method``."""
    return {"model": {"name": "callable", "function": "pendulum_levels:pendulum_fine",
                      "inputs": ["theta0", "length", "damping"], "outputs": ["theta"],
                      "module_dir": str(Path(__file__).resolve().parent)},
            "inputs": PENDULUM_INPUTS, "methods": [method], "seed": seed}


def _pendulum_exact(nodes: int) -> tuple[float, float, float]:
    """Mean, std and 4th central moment of the highest level by Gauss-Legendre quadrature over
    the three uniform inputs, ``nodes`` per input (the angle is smooth in each)."""
    g, w = np.polynomial.legendre.leggauss(nodes)
    lows = np.array([i["low"] for i in PENDULUM_INPUTS])
    highs = np.array([i["high"] for i in PENDULUM_INPUTS])
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    weight = np.einsum("i,j,k->ijk", w, w, w).reshape(-1) / 8.0
    y = pendulum_fine(lows + (highs - lows) * (grid + 1) / 2)
    mean = float(weight @ y)
    d = y - mean
    return mean, float(np.sqrt(weight @ d**2)), float(weight @ d**4)


def _tree_cpu() -> dict[int, float]:
    """CPU seconds so far of this process and of every live process below it, each with the
    children it has reaped (a guard's, reaped by the fork server, counts there)."""
    import psutil

    me = psutil.Process()
    out = {}
    for p in [me, *me.children(recursive=True)]:
        try:
            t = p.cpu_times()
            out[p.pid] = t.user + t.system + t.children_user + t.children_system
        except psutil.NoSuchProcess:
            pass
    return out


def _tree_spent(before: dict[int, float]) -> float:
    """CPU seconds the process tree spent since ``before`` (:func:`_tree_cpu`)."""
    return sum(v - before.get(pid, 0.0) for pid, v in _tree_cpu().items())


def _measured_run(cfg: dict[str, Any]) -> tuple[Any, float]:
    """``uqguide.run`` of ``cfg`` as a user's script makes it, its guard stopped after, and the
    process tree's CPU seconds for it."""
    import uqguide
    from uqguide.driver.execution.guard import close_guards

    before = _tree_cpu()
    try:
        result = uqguide.run(cfg)
    finally:
        close_guards()
    return result, _tree_spent(before)


def pendulum(seeds: int, budget: float, first_seed: int = 0) -> None:
    """``mfmc`` at its defaults on the three-level pendulum ``callable`` for ``budget`` CPU-s
    over seeds: the process tree's CPU against the budget, the MSE of mean and std against
    ``monte_carlo``'s at the same measured CPU (its runs per CPU-s measured here, its MSE
    ``sigma^2 / n`` from the exact moments), and the coverage of the intervals."""
    t0 = time.process_time()
    mean, std, mu4 = _pendulum_exact(32)
    coarse = _pendulum_exact(24)
    print(f"pendulum: theta at {PENDULUM_T:g} s, explicit Euler with {PENDULUM_STEPS} steps; "
          f"exact highest level (Gauss-Legendre 32^3; 24^3 differs by "
          f"{abs(coarse[0] - mean):.1e} in the mean, {abs(coarse[1] - std):.1e} in the std): "
          f"mean {mean:.6f}, std {std:.6f} ({time.process_time() - t0:.1f} CPU-s)", flush=True)
    levels = [{}, {"function": "pendulum_levels:pendulum_mid"},
              {"function": "pendulum_levels:pendulum_coarse"}]
    mf = {"name": "mfmc", "fidelities": levels, "budget_cpu_s": budget}
    # monte_carlo's runs per CPU-s of its process tree, at about the budget's size
    rates = []
    for s in range(3):
        n_mc = int(budget / 60e-6)
        r, cpu = _measured_run(_pendulum_config(
            {"name": "monte_carlo", "n_samples": n_mc}, 10_000 + s))
        rates.append(n_mc / cpu)
    rate = float(np.median(rates))
    print(f"  monte_carlo at its defaults: {rate:.0f} runs per CPU-s of the process tree "
          f"(3 runs of {int(budget / 60e-6)}: {', '.join(f'{v:.0f}' for v in rates)})",
          flush=True)
    # a fallback to plain MC: its CPU per highest-level run against monte_carlo's
    fallback = {"name": "mfmc", "budget_cpu_s": budget,
                "fidelities": [{}, {"function": "pendulum_levels:pendulum_unrelated"}]}
    r, cpu = _measured_run(_pendulum_config(fallback, 0))
    d = r.runs[0].estimate.diagnostics
    m0 = int(d["runs_per_level"][0])
    print(f"  a level uncorrelated with it: plain MC {bool(d['plain_mc'])}, {m0} runs of the "
          f"highest level, {m0 / cpu:.0f} per CPU-s of the tree (monte_carlo {rate:.0f}), "
          f"tree CPU {cpu / budget:.2f} x budget, cpu_saving {d['cpu_saving']:.3f}",
          flush=True)
    tree, err_mean, err_std, hit_mean, hit_std, plain, saving = [], [], [], 0, 0, 0, []
    for s in range(first_seed, first_seed + seeds):
        hits = (hit_mean, hit_std)
        r, cpu = _measured_run(_pendulum_config(mf, s))
        run = r.runs[0]
        st, d = run.estimate.stats["theta"], run.estimate.diagnostics
        tree.append(cpu / budget)
        err_mean.append(float(st.mean[0]) - mean)
        err_std.append(float(st.std[0]) - std)
        hit_mean += bool(st.ci["mean"][0, 0] <= mean <= st.ci["mean"][1, 0])
        hit_std += bool(st.ci["std"][0, 0] <= std <= st.ci["std"][1, 0])
        plain += bool(d["plain_mc"])
        saving.append(float(d["cpu_saving"]))
        print(f"  seed {s}: tree CPU {cpu:.2f} s ({cpu / budget:.2f} x budget), runs "
              f"{[int(v) for v in d['runs_per_level']]}, levels used {d['levels_used']}, "
              f"cpu_saving {d['cpu_saving']:.2f}, error of the mean {err_mean[-1]:+.2e} "
              f"(held {hit_mean - hits[0]}), of the std {err_std[-1]:+.2e} (held "
              f"{hit_std - hits[1]}), estimate {d['estimate_cpu_s']:.2f} CPU-s; "
              f"CPU per level {np.round(d['cpu_per_level'], 2).tolist()}, pilot s/run "
              f"{np.round(d['pilot_seconds_per_run'] * 1e6, 1).tolist()} us, all runs "
              f"{np.round(d['cpu_per_level'] / d['runs_per_level'] * 1e6, 1).tolist()} us",
              flush=True)
    n = len(tree)
    t = np.array(tree)
    # monte_carlo at each seed's measured CPU: sigma^2 / n and, for the std, (mu4 - sigma^4) /
    # (4 sigma^2 n) (the delta method), n its runs in that CPU
    n_mc = rate * t * budget
    mse_mc = np.array([std**2 / n_mc, (mu4 - std**4) / (4 * std**2 * n_mc)])
    err = np.array([err_mean, err_std]) ** 2
    ratio = mse_mc.mean(axis=1) / err.mean(axis=1)
    rng = np.random.default_rng(0)
    boot = []
    for _ in range(2000):
        i = rng.integers(0, n, n)
        boot.append(mse_mc[:, i].mean(axis=1) / err[:, i].mean(axis=1))
    lo, hi = np.quantile(np.array(boot), [0.025, 0.975], axis=0)
    print(f"\n  {'seeds':>5} {'tree CPU / budget: min':>24} {'median':>7} {'max':>6} "
          f"{'MSE ratio vs MC, mean [95%]':>30} {'std [95%]':>20} {'coverage mean':>14} "
          f"{'std':>6}")
    print(f"  {n:>5} {t.min():24.2f} {np.median(t):7.2f} {t.max():6.2f} "
          f"{ratio[0]:>12.2f} [{lo[0]:.2f}, {hi[0]:.2f}]{'':>6} {ratio[1]:>8.2f} "
          f"[{lo[1]:.2f}, {hi[1]:.2f}] {hit_mean:>8}/{n:<5} {hit_std:>3}/{n}")
    print(f"  plain-MC fallbacks {plain}/{n}; cpu_saving min {min(saving):.2f}, median "
          f"{np.median(saving):.2f}, max {max(saving):.2f}; coverage 95% Wilson: mean "
          f"[{_wilson(hit_mean, n)[0]:.2f}, {_wilson(hit_mean, n)[1]:.2f}], std "
          f"[{_wilson(hit_std, n)[0]:.2f}, {_wilson(hit_std, n)[1]:.2f}]; "
          f"{time.process_time() - t0:.0f} CPU-s in this process")


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
        assert st.sem is not None
        ratios.append(st.sem[0] / (st.std[0] / np.sqrt(budget / costs[0])))
    print(f"uncorrelated cheap level, {seeds} seeds, budget {budget:g} s at pinned costs "
          f"{costs}: plain MC chosen {plain}/{seeds}; cost / budget {min(spent):.4f} to "
          f"{max(spent):.4f}; s.e. of the mean / plain MC's at the budget {min(ratios):.4f} "
          f"to {max(ratios):.4f}")


# ---------------------------------------------------------------------------------- paired
def _blue_variance(c: np.ndarray, sizes: np.ndarray) -> float:
    """The BLUE's variance of level 0's mean for nested runs ``sizes`` (estimator order) and
    the levels' covariance ``c`` (:mod:`uqguide.stats.mfmc_estimator`)."""
    k = len(sizes)
    groups = np.diff(np.concatenate([[0.0], sizes]))
    psi = np.zeros((k, k))
    for g in range(k):
        psi[g:, g:] += groups[g] * np.linalg.inv(c[g:, g:])
    return float(np.linalg.inv(psi)[0, 0])


def _acv_variance(c: np.ndarray, sizes: np.ndarray, parent: tuple[int, ...]) -> float:
    """Variance of level 0's mean by an ACV estimator of nested runs ``sizes`` in which level
    ``i`` is compared between the rows of level ``parent[i]`` and its own, with the jointly
    optimal weights (Gorodetsky et al. 2020; ``parent = (0, 0, ...)`` is ACV-MF, ``(0, 0, 1,
    2, ...)`` is MFMC). Nested means: ``cov(mean_a y_i, mean_b y_j) = c_ij / max(a, b)``."""
    k = len(sizes)

    def inv(a: int, b: int) -> float:
        return 1.0 / max(sizes[a], sizes[b])

    g = np.array([c[0, i] * (inv(0, parent[i]) - inv(0, i)) for i in range(1, k)])
    big = np.array([[c[i, j] * (inv(parent[i], parent[j]) - inv(parent[i], j) -
                                inv(i, parent[j]) + inv(i, j)) for j in range(1, k)]
                    for i in range(1, k)])
    return float(c[0, 0] / sizes[0] - g @ np.linalg.solve(big, g))


def _best_acv(covs: list[np.ndarray], w: np.ndarray, parent: tuple[int, ...], cap: float
              ) -> float:
    """The worst quantity's CPU saving of the best ratios for ``parent`` (Nelder-Mead from
    several starts), levels only, the last level at most ``cap`` times the one before."""
    from scipy.optimize import minimize

    def worst(u: np.ndarray) -> float:
        r = np.cumprod(np.concatenate([[1.0], 1 + np.exp(u)]))
        if r[-1] > cap * r[-2]:
            return 1e9
        m = r / float(np.dot(w, r))  # unit budget
        return max(_acv_variance(c, m, parent) / (c[0, 0] * w[0]) for c in covs)

    best = min(minimize(worst, np.full(len(w) - 1, s), method="Nelder-Mead",
                        options={"maxiter": 4000, "xatol": 1e-5, "fatol": 1e-9}).fun
               for s in (0.0, 1.0, 2.0, 3.0))
    return 1.0 / best


def paired(rows: int, budget: float, pce_runs: int, workers: int, draws: int,
           score: list[Any]) -> None:
    """FT-AS Case 2: ``rows`` paired runs at h = 0.01 / 0.02 / 0.05 s and a PCE learnt on
    ``pce_runs`` runs at h = 0.02 s (its own seed), as the truth allocations are scored
    against: each level's ``1 - rho^2`` with h = 0.01 s, the best allocation and its CPU
    saving at ``budget`` CPU-s with the PCE's CPU added, the savings of the allocations made
    from ``draws`` pilots of 100 and 200 of those rows, and of the allocations in ``score``
    (``[label, levels, runs per level, CPU in all, CPU per run at h = 0.01 s]``, levels as the
    ``ft_as-run`` config's: 0-3 the steps, 4 the PCE; the plain-MC CPU at the run's own cost
    per run, so that a run on a busier machine is compared at its own prices)."""
    from uqguide.driver.execution import ProcessExecutor, SerialExecutor
    from uqguide.driver.propagate import run

    path, param, steps, outputs, overrides = PILOTS["ft_as"]
    raw = load_yaml(ROOT / path)
    raw["model"].update(overrides)
    for key in ("reference", "quantiles", "events"):
        raw.pop(key, None)
    raw["outputs"] = outputs
    ex = ProcessExecutor(workers, batch_size=20) if workers > 1 else SerialExecutor(20)
    t0 = time.process_time()
    levels, cost, failed = [], [], []
    x = np.empty(0)
    try:
        for h in steps[:3]:
            cfg = validate_config({**raw, "model": {**raw["model"], param: h}, "seed": 7,
                                   "methods": [{"name": "monte_carlo", "label": "mc",
                                                "n_samples": rows, "sampling": "random",
                                                "sensitivity": "off"}]})
            r = run(cfg, ex).runs[0]
            x = np.asarray(r.x)
            levels.append(np.column_stack([r.scalars[k].reshape(rows, -1) for k in outputs]))
            names = [f"{k}[{c}]" for k in outputs for c in range(r.scalars[k].reshape(rows, -1)
                                                                   .shape[1])]
            failed.append(r.failed)
            cost.append(r.model_seconds / rows)
        cfg = validate_config({**raw, "model": {**raw["model"], param: steps[1]}, "seed": 8,
                               "methods": [{"name": "pce_adaptive", "label": "apce",
                                            "n_samples": pce_runs, "max_runs": pce_runs}]})
        result = run(cfg, ex)
    finally:
        ex.close()
    fixed = result.runs[0].model_seconds + result.runs[0].fit_seconds
    sur = result.surrogate("apce")
    t1 = time.process_time()
    p = sur(x, outputs)
    cost.append((time.process_time() - t1) / rows)
    levels.append(np.column_stack([p[k].reshape(rows, -1) for k in outputs]))
    ok = ~np.any(failed, axis=0)
    lv = [v[ok] for v in levels]
    w = np.array(cost)

    def covariances(sub: np.ndarray) -> list[np.ndarray]:
        """Each quantity's and its (centred) square's covariance over the levels."""
        out = []
        for q in range(lv[0].shape[1]):
            ys = np.column_stack([v[sub, q] for v in lv])
            out += [np.cov(ys, rowvar=False), np.cov((ys - ys.mean(axis=0)) ** 2, rowvar=False)]
        return out

    def correlations(cs: list[np.ndarray]) -> np.ndarray:
        return np.nan_to_num(np.array([c[0] / np.sqrt(c[0, 0] * np.diag(c)) for c in cs]))

    n_ok = lv[0].shape[0]
    covs = covariances(np.arange(n_ok))
    rho = correlations(covs)
    names = [f"{c}{s}" for c in names for s in ("", "^2")]
    print(f"FT-AS Case 2: {int(ok.sum())} paired runs at {param} = {steps[:3]} and a PCE of "
          f"{pce_runs} runs at {steps[1]:g} ({fixed:.1f} CPU-s with its fit); seconds per run "
          f"{np.round(w, 7).tolist()}; {time.process_time() - t0:.0f} CPU-s in this process")
    print(f"  1 - rho^2 with {param} = {steps[0]:g}, per level "
          f"({', '.join(f'{h:g}' for h in steps[1:3])}, PCE):")
    for n, r in zip(names, rho):
        print(f"    {n:>16} " + " ".join(f"{1 - v**2:9.2e}" for v in r[1:]))
    cap = np.array([np.inf, np.inf, np.inf, 100.0])

    def saving(levels_used: tuple[int, ...], sizes: np.ndarray, cpu: float,
               c0: float | None = None) -> float:
        """Plain-MC CPU for the same standard errors (BLUE), at ``c0`` per run (default:
        measured here), over ``cpu``; the worst quantity."""
        worst = np.inf
        for c in covs:
            cl = c[np.ix_(levels_used, levels_used)]
            runs = cl[0, 0] / _blue_variance(cl, sizes)
            worst = min(worst, runs * (w[0] if c0 is None else c0) / cpu)
        return worst

    def at_budget(a: Any) -> float:
        sizes = a.ratios * budget / float(np.dot(w[list(a.levels)], a.ratios))
        return saving(a.levels, sizes, budget + fixed)

    for subset in ((0, 1, 3), (0, 2, 3), (0, 1, 2, 3)):
        a = select_allocation(rho[:, subset], w[list(subset)], 1.0, max_step=cap[list(subset)])
        used = tuple(subset[i] for i in a.levels)
        best = select_allocation(rho[:, used], w[list(used)], 1.0, max_step=cap[list(used)])
        print(f"  best allocation of levels {subset} (3 = the PCE): {used}, ratios "
              f"{np.round(best.ratios, 1).tolist()}, CPU saving {1 / best.variance_ratio:.2f}x "
              f"(MFMC, levels only), {at_budget(type(best)(used, best.ratios, 0.0)):.2f}x "
              f"(BLUE, at {budget:g} CPU-s with the PCE's {fixed:.0f} s)")
    for parent, what in (((0, 0, 1, 2), "MFMC's"), ((0, 0, 0, 0), "ACV-MF's")):
        print(f"  {what} pattern of all four levels, jointly optimal weights, best ratios: CPU "
              f"saving {_best_acv(covs, w, parent, 100.0):.2f}x (levels only)")
    rng = np.random.default_rng(0)
    for n_pilot in (100, 200):
        if 2 * n_pilot > n_ok:  # (pilots must be a small part of the truth they are scored on)
            continue
        got = []
        for _ in range(draws):
            sub = rng.choice(n_ok, n_pilot, replace=False)
            a = select_allocation(correlations(covariances(sub)), w, 1.1, max_step=cap)
            got.append(at_budget(a) if not a.is_plain_mc else budget / (budget + fixed))
        g = np.array(got)
        print(f"  allocations from {draws} pilots of {n_pilot}: CPU saving median "
              f"{np.median(g):.2f}x, 10% below {np.quantile(g, 0.1):.2f}x, "
              f"{np.mean(g >= 5):.0%} at 5x or more")
    index = {0: 0, 1: 1, 2: 2, 4: 3}
    for label, used, runs, cpu, c0 in score:
        scored = saving(tuple(index[i] for i in used), np.array(runs, float), cpu, c0)
        print(f"  {label}: levels {used}, runs {runs}, {cpu:g} CPU-s: CPU saving against the "
              f"paired runs {scored:.2f}x")


# ---------------------------------------------------------------------------------- FT-AS run
#: rows per chunk of ``*-run``: a few seconds of the slow simulators, more of the fast one
CHUNK = {"ft_as": 20, "gmm_ftc": 64, "ftcapn": 1024}


def method_run(case: str, budget: float, n_pilot: int, workers: int, pce: int = 0,
               pce_step: float | None = None, seed: int | None = None,
               estimator: str = "blue") -> None:
    """The ``mfmc`` method on the levels of :data:`PILOTS` ``case`` for ``budget`` CPU s."""
    from uqguide.driver.execution import ProcessExecutor, SerialExecutor
    from uqguide.driver.propagate import run

    path, param, steps, outputs, overrides = PILOTS[case]
    raw = load_yaml(ROOT / path)
    raw["model"].update(overrides)
    for key in ("reference", "quantiles", "events"):
        raw.pop(key, None)
    raw["outputs"] = outputs
    levels: list[dict[str, Any]] = [{param: h} for h in steps]
    raw["methods"] = []
    if pce:
        # the fidelity the PCE learns (default: the second level's)
        raw["model"][param] = steps[1] if pce_step is None else pce_step
        raw["methods"].append({"name": "pce_adaptive", "label": "apce", "n_samples": pce,
                               "max_runs": pce})
        levels.append({"surrogate": "apce"})
    raw["methods"].append({"name": "mfmc", "fidelities": levels, "budget_cpu_s": budget,
                           "n_pilot": n_pilot, "chunk_size": CHUNK[case],
                           "estimator": estimator})
    if seed is not None:
        raw["seed"] = seed
    cfg = validate_config(raw, source=str(ROOT / path))
    ex = ProcessExecutor(workers, batch_size=20) if workers > 1 else SerialExecutor(20)
    t0 = time.process_time()
    try:
        result = run(cfg, ex)
    finally:
        ex.close()
    r = result.runs[-1]
    d = r.estimate.diagnostics
    spent = float(np.sum(d["cpu_per_level"])) + float(d.get("surrogate_cpu_s", 0.0))
    learnt = f"on {pce} runs at {param} = {raw['model'][param]:g}" if pce else "none"
    print(f"{case} mfmc ({estimator}), budget {budget:g} CPU-s, pilot {n_pilot}, "
          f"{workers} worker(s), PCE level {learnt}: "
          f"this process {time.process_time() - t0:.1f} CPU-s, model {r.model_seconds:.1f} s")
    for k in ("levels", "levels_used", "runs_per_level", "cpu_per_level", "cost_per_run",
              "surrogate_cpu_s", "estimated_variance_reduction", "equivalent_mc_runs",
              "equivalent_mc_runs_std", "equivalent_mc_cpu_s", "cpu_saving", "note"):
        print(f"  {k}: {d.get(k)}")
    for k in sorted(d):
        if k.startswith("equivalent_mc_runs") and "." in k:
            print(f"  {k}: {d[k]:.0f}")
    c0 = float(d["cost_per_run"][0])
    print(f"  all CPU (levels + the PCE's runs and fit): {spent:.1f} s; {param} = {steps[0]:g} "
          f"costs {c0:.3g} s per run")
    for name, st in r.estimate.stats.items():
        assert st.sem is not None and st.ci is not None
        for c in range(st.mean.shape[-1]):
            print(f"  {name}[{c}]: mean {st.mean[c]:.6g} +- {st.sem[c]:.3g} | std "
                  f"{st.std[c]:.6g} [{st.ci['std'][0, c]:.6g}, {st.ci['std'][1, c]:.6g}]")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", default="analytic",
                    choices=["analytic", "jumps", "euler", "uncorrelated", "pendulum",
                             "ft_as-paired", *PILOTS,
                             *(f"{c}-run" for c in PILOTS)])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--pilot", type=int, default=200)
    ap.add_argument("--budget", type=float, default=None, dest="budget_given",
                    help="cost units (analytic), CPU seconds (euler, *-run; default 100; "
                         "pendulum: default 4)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--pce", type=int, default=0,
                    help="*-run: add a PCE level fitted on this many runs (0: none); "
                         "euler: 1 for a PCE level")
    ap.add_argument("--pce-step", type=float, default=None,
                    help="*-run: the step of the runs the PCE learns [s] (default: the "
                         "second level's)")
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--rows", type=int, default=1200, help="ft_as-paired: paired runs")
    ap.add_argument("--score", default="[]",
                    help="ft_as-paired: JSON [[label, levels, runs per level, CPU s, CPU s "
                         "per run at the highest level], ...]")
    ap.add_argument("--jump", type=float, default=JUMP, help="jumps: the jump's size")
    ap.add_argument("--p-jump", type=float, default=P_JUMP, help="jumps: its probability")
    ap.add_argument("--estimator", choices=["blue", "mfmc"], default="blue",
                    help="euler, *-run: how the method combines the runs")
    ap.add_argument("--peer-python", default=None,
                    help="an interpreter with MXMCPy: its allocations beside uqguide's")
    a = ap.parse_args()
    a.budget = 100.0 if a.budget_given is None else a.budget_given
    if a.case == "analytic":
        analytic(a.seeds, a.budget, a.peer_python)
    elif a.case == "ft_as-paired":
        paired(a.rows, a.budget, a.pce or 300, a.workers, a.seeds, json.loads(a.score))
    elif a.case == "jumps":
        jumps(a.seeds, a.budget, a.pilot, a.jump, a.p_jump)
    elif a.case == "uncorrelated":
        uncorrelated(a.seeds, a.budget)
    elif a.case == "euler":
        euler(a.seeds, a.budget, bool(a.pce), a.estimator)
    elif a.case == "pendulum":
        pendulum(a.seeds, 4.0 if a.budget_given is None else a.budget_given, a.seed or 0)
    elif a.case in PILOTS:
        pilot(a.case, a.pilot, peer_python=a.peer_python)
    else:
        method_run(a.case.removesuffix("-run"), a.budget, a.pilot, a.workers, a.pce,
                   a.pce_step, a.seed, a.estimator)


if __name__ == "__main__":
    main()
