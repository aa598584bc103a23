"""Given-data first-order Sobol' indices on Ishigami at equal runs: uqguide beside its peers.

Ishigami ``sin x1 + 7 sin^2 x2 + 0.1 x3^4 sin x1``, ``x ~ U(-pi, pi)^3``: exact first-order
indices (0.3139, 0.4424, 0). For each seed (default 50) one plain Monte Carlo sample of
``--runs`` runs (default 2000, #29's acceptance) is given to every given-data estimator:

- ``uqguide``: :func:`uqguide.stats.sobol_given_data.first_order_indices` (rank bins of
  ``sqrt(n)`` runs, all pairs within a bin; 95% intervals from the influence function);
- ``rank-neighbour``: Gamboa, Klein & Lagnoux (2022): each run paired with its rank neighbour
  only (Chatterjee's xi); no interval;
- ``salib-rbd-fast``: SALib's RBD-FAST on the same sample (``M = 10`` harmonics; its interval:
  SALib's bootstrap);
- ``salib-delta``: SALib's delta-moment method, whose ``S1`` is a given-data first-order index
  (interval: SALib's bootstrap); not run by default (10 CPU-s an analysis: ask for it with
  ``--methods``);

and, at about the same number of runs but its own design:

- ``salib-saltelli``: SALib's Sobol' analysis of a Saltelli design with ``N = runs / (d + 2)``
  base runs, ``calc_second_order=False`` (``N (d + 2)`` runs; first-order interval: SALib's).

The table gives, per method and index, the mean error (bias), its standard deviation over the
seeds, the largest absolute error, how often the error exceeds 0.05, the coverage of the 95%
interval and the median CPU seconds of one analysis (all indices). SALib is optional
(``pip install uqguide[peers]``); without it its rows are skipped.

``--study saltelli`` compares the pick-freeze designs instead (#29, item 2), first-order and
total indices at ``N = --n-base`` base rows (default 1000), equal runs ``N (m + 2)`` for every
method (``m`` frozen sets), on four functions:

- Ishigami (exact indices); the 8-D G-function, ``a = (0, 1, 4.5, 9, 99, 99, 99, 99)`` (exact:
  ``V_i = 1 / (3 (1 + a_i)^2)``); borehole (reference: a degree-5 least-squares PCE of 15000
  Latin-hypercube runs, OpenTURNS' ``FunctionalChaosAlgorithm``: another method, whose
  indices' error is far below the designs'); ``y = x1 + x2 + x3 + x4 / 2`` with ``x1, x2``
  standard normals of correlation 0.8 (exact group index of ``(x1, x2)``: 3.6 / 4.85, and
  0.25 / 4.85 for ``x4``, first = total);
- ``uqguide``: the ``sobol_saltelli`` method run by the driver (scrambled Sobol' points, its
  default; Poisson-bootstrap percentile intervals), ``uqguide-random``: the same on random
  points (its intervals' coverage is then the nominal one's test);
- ``salib``: SALib's Saltelli sampler and ``sobol.analyze`` (``calc_second_order=False``;
  groups for the correlated pair; its bootstrap intervals);
- ``ot-saltelli``, ``ot-jansen``: OpenTURNS' ``SaltelliSensitivityAlgorithm`` and
  ``JansenSensitivityAlgorithm`` on its ``SobolIndicesExperiment`` (random points), asymptotic
  intervals. Not on the correlated model: they have no groups, and an index per column of a
  correlated pair is not an index of either input.

Every method samples the unit cube and maps it through the same config's inputs
(``InputSpace.from_unit``), so all evaluate the same function. Per function, method and kind
(``S`` first, ``ST`` total): the largest mean error over the inputs (bias), the root mean
square error over seeds and inputs, the largest absolute error, the share of
(seed, index) pairs within 0.03 of the exact value, and the coverage of the 95% intervals
(lowest over the inputs, and the mean).

``--study correlated`` (#46, item 6): correlated inputs, ``x1, x2`` standard normals of
correlation 0.8 and ``x3`` independent: ``linear`` ``y = x1 + 2 x2 + 3 x3`` (exact group index
of ``(x1, x2)`` 8.2 / 17.2 = 0.4767, ``x3`` 0.5233) and ``sine`` ``y = sin x1 + 2 x2 + 3 x3``
(``Var(sin Z) = (1 - e^-2) / 2``, ``Cov(sin Z, Z) = e^-1/2``: group 0.4146, ``x3`` 0.5854),
which no polynomial represents. Per seed one config with ``pce_adaptive`` (``--pce-runs``,
default 100), ``monte_carlo`` (``--runs``) and ``sobol_saltelli`` (``--n-base``); per method
the group's and ``x3``'s first-order index: bias, sd, coverage of the 95% interval, its median
width, and whether the PCE refused ``x1`` and ``x2`` alone (NaN) at every seed.

``--study given-data-edges`` (#46, item 6): uqguide's given-data indices where their bias is
largest, ``--runs`` (default 2000) plain Monte Carlo runs a seed: the borehole function (its usual
inputs, as ``--study saltelli``'s; reference indices by quadrature: Gauss nodes in each input,
scrambled Sobol' points over the others) and three series of standard normal ``x1, x2`` whose
dominant input turns over time, ``rotation`` ``y(t) = cos t x1 + sin t x2``,
``rotation-quadratic`` ``y(t) = cos t q(x1) + sin t q(x2)``, ``q(x) = x + (x^2 - 1) / 2``, and
``rotation-step`` ``y(t) = cos t sign(x1) + sin t x2`` (a jump in ``E[y | x1]``), all with
``S_1 = cos^2 t`` and ``S_2 = sin^2 t`` exactly (1 at t = 0, 0.877 at 0.36, then 0.5, 0.099,
0). Per case, index and time: exact, bias, sd, coverage of the 95% interval and its median
width; the verdict line: every index at least 90%.

``--study pce-borehole`` (#46, item 6): the borehole function (``pick_freeze_peers``' config
and reference indices) through ``pce_adaptive`` at its defaults, per seed; per index ``S`` and
``ST`` of every input: the reference, bias, sd and root mean square error over the seeds,
coverage of the 95% interval, its median width, and the median CPU seconds of a run and of
its indices' intervals (bootstrap and cross term). The G-function's and Ishigami's coverage:
``benchmarks/pce_sensitivity.py``.

    python benchmarks/sensitivity_peers.py [--runs 2000] [--seeds 50] [--methods ...]
    python benchmarks/sensitivity_peers.py --study saltelli [--n-base 1000] [--seeds 50]
    python benchmarks/sensitivity_peers.py --study correlated [--seeds 50]
    python benchmarks/sensitivity_peers.py --study given-data-edges [--seeds 50]
    python benchmarks/sensitivity_peers.py --study pce-borehole [--seeds 50]
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from uqguide.config.run_config import validate_config
from uqguide.models.benchmarks import Ishigami
from uqguide.stats.sobol_given_data import first_order_indices

NAMES = ("x1", "x2", "x3")
PROBLEM = {"num_vars": 3, "names": list(NAMES), "bounds": [[-np.pi, np.pi]] * 3}

Estimate = tuple[np.ndarray, np.ndarray | None]  # (first (3,), ci (2, 3) or None)
Sample = Callable[[int], tuple[np.ndarray, np.ndarray]]  # seed -> (x (n, d), lanes (C, n))


def ishigami(x: np.ndarray) -> np.ndarray:
    return Ishigami().evaluate(x, NAMES).scalars["y"][:, 0]


def ours(x: np.ndarray, y: np.ndarray, seed: int) -> Estimate:
    est = first_order_indices(x, y[None, :])
    return est.first[0], est.ci[:, 0]


def rank_neighbour(x: np.ndarray, y: np.ndarray, seed: int) -> Estimate:
    z = (y - y.mean()) / y.std(ddof=1)
    first = []
    for i in range(x.shape[1]):
        zs = z[np.argsort(x[:, i])]
        first.append(np.mean(zs[:-1] * zs[1:]))
    return np.array(first), None


def rbd_fast(x: np.ndarray, y: np.ndarray, seed: int) -> Estimate:
    from SALib.analyze import rbd_fast as rbd

    r = rbd.analyze(PROBLEM, x, y, M=10, seed=seed)
    s1, conf = np.asarray(r["S1"]), np.asarray(r["S1_conf"])
    return s1, np.stack([s1 - conf, s1 + conf])


def delta(x: np.ndarray, y: np.ndarray, seed: int) -> Estimate:
    from SALib.analyze import delta as dm

    r = dm.analyze(PROBLEM, x, y, num_resamples=20, seed=seed)
    s1, conf = np.asarray(r["S1"]), np.asarray(r["S1_conf"])
    return s1, np.stack([s1 - conf, s1 + conf])


GIVEN_DATA: dict[str, Callable[[np.ndarray, np.ndarray, int], Estimate]] = {
    "uqguide": ours, "rank-neighbour": rank_neighbour, "salib-rbd-fast": rbd_fast,
    "salib-delta": delta,
}


def saltelli(runs: int, seed: int) -> tuple[Estimate, int]:
    from SALib.analyze import sobol
    from SALib.sample import sobol as sobol_sample

    n_base = max(2, runs // (len(NAMES) + 2))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # N not a power of two: SALib warns of balance
        x = sobol_sample.sample(PROBLEM, n_base, calc_second_order=False, seed=seed)
    r = sobol.analyze(PROBLEM, ishigami(x), calc_second_order=False, seed=seed)
    s1, conf = np.asarray(r["S1"]), np.asarray(r["S1_conf"])
    return (s1, np.stack([s1 - conf, s1 + conf])), x.shape[0]


#: Exact first-order indices (group (x1, x2), x3) of the correlated cases (module docstring).
_VAR_SIN, _COV_SIN = (1 - np.exp(-2.0)) / 2, np.exp(-0.5)
_SINE_GROUP = _VAR_SIN + 4 + 4 * 0.8 * _COV_SIN


def linear_correlated(x: np.ndarray) -> dict[str, np.ndarray]:
    return {"y": x[:, 0] + 2 * x[:, 1] + 3 * x[:, 2]}


def sine_correlated(x: np.ndarray) -> dict[str, np.ndarray]:
    return {"y": np.sin(x[:, 0]) + 2 * x[:, 1] + 3 * x[:, 2]}


CORRELATED: dict[str, tuple[Callable, tuple[float, float]]] = {
    "linear": (linear_correlated, (8.2 / 17.2, 9 / 17.2)),
    "sine": (sine_correlated, (_SINE_GROUP / (_SINE_GROUP + 9), 9 / (_SINE_GROUP + 9))),
}


def correlated_study(seeds: int, pce_runs: int, runs: int, n_base: int) -> None:
    """The ``--study correlated`` table (module docstring)."""
    import uqguide

    labels = ("apce", "mc", "saltelli")
    head = (f"{'case':7s} {'method':9s} {'index':>8s} {'exact':>6s} {'bias':>8s} {'sd':>7s} "
            f"{'cover95':>8s} {'width':>8s} {'max|err|':>8s}")
    print(f"correlated inputs, {seeds} seeds: pce_adaptive {pce_runs} runs, monte_carlo "
          f"{runs}, sobol_saltelli N = {n_base}")
    print(head)
    print("-" * len(head))
    for case, (function, exact) in CORRELATED.items():
        est = {m: np.full((seeds, 2), np.nan) for m in labels}
        ci = {m: np.full((seeds, 2, 2), np.nan) for m in labels}
        refused = 0
        for seed in range(seeds):
            result = uqguide.run({
                "model": {"name": "callable", "isolate": False,
                          "function": function,
                          "inputs": ["x1", "x2", "x3"], "outputs": ["y"]},
                "inputs": [{"name": n, "dist": "normal", "std": 1.0} for n in ("x1", "x2", "x3")],
                "correlations": [{"inputs": ["x1", "x2"], "matrix": [[1.0, 0.8], [0.8, 1.0]]}],
                "methods": [{"name": "pce_adaptive", "label": "apce", "n_samples": pce_runs},
                            {"name": "monte_carlo", "label": "mc", "n_samples": runs},
                            {"name": "sobol_saltelli", "label": "saltelli", "n_base": n_base}],
                "seed": seed})
            for m in labels:
                st = result.run(m).estimate.stats["y"]
                est[m][seed] = st.sobol_group_first[0, 0], st.sobol_first[0, 2]
                ci[m][seed] = np.stack([st.sobol_group_first_ci[:, 0, 0],
                                        st.sobol_first_ci[:, 0, 2]], axis=1)
                if m == "apce":
                    refused += bool(np.isnan(st.sobol_first[0, :2]).all()
                                    and np.isnan(st.sobol_total[0, :2]).all())
        for m in labels:
            for i, name in enumerate(("x1+x2", "x3")):
                e = est[m][:, i] - exact[i]
                lo, hi = ci[m][:, 0, i], ci[m][:, 1, i]
                cover = np.mean((lo <= exact[i]) & (exact[i] <= hi))
                print(f"{case:7s} {m:9s} {name:>8s} {exact[i]:6.4f} {e.mean():8.4f} "
                      f"{e.std(ddof=1):7.4f} {cover:8.0%} {np.median(hi - lo):8.1e} "
                      f"{np.abs(e).max():8.1e}")
        print(f"{case:7s} apce: x1 and x2 alone refused (NaN first and total) at {refused} of "
              f"{seeds} seeds")


#: Times of the rotation series (module docstring): S_1 = cos^2 t = 1, 0.877, 0.5, 0.099, 0.
ROTATION_TIMES = (0.0, 0.36, np.pi / 4, 1.25, np.pi / 2)


def rotation(x: np.ndarray, shape: str) -> np.ndarray:
    """The rotation series' lanes ``(times, n)``: ``cos t q1(x1) + sin t q2(x2)`` (module
    docstring), ``shape`` ``linear``, ``quadratic`` or ``step``."""
    q = x + (x * x - 1) / 2 if shape == "quadratic" else x.copy()
    if shape == "step":
        q[:, 0] = np.sign(x[:, 0])
    t = np.asarray(ROTATION_TIMES)[:, None]
    return np.cos(t) * q[:, 0] + np.sin(t) * q[:, 1]


def borehole_config() -> Any:
    """The borehole function with its usual inputs (``--study saltelli``'s case)."""
    from pick_freeze_peers import CASES

    return validate_config({**CASES["borehole"].config,
                            "methods": [{"name": "monte_carlo", "n_samples": 10}]})


def borehole_first_order(nodes: int = 16, inner: int = 2**14) -> np.ndarray:
    """The borehole's first-order indices by quadrature: ``E[y | x_i]`` at ``nodes`` Gauss
    nodes of ``x_i`` (Hermite in the normal score of ``rw`` and ``log r``, Legendre for the
    uniform rest), each the mean over ``inner`` scrambled Sobol' points of the other inputs; the
    variance of ``y`` over ``2^20`` such points. At 40 nodes and 2^16 points the indices move by
    less than 1e-6."""
    from scipy.special import ndtr
    from scipy.stats import qmc

    cfg = borehole_config()

    def flow(u: np.ndarray) -> np.ndarray:
        return cfg.model.evaluate(cfg.space.from_unit(u), cfg.space.names).scalars["flow"][:, 0]

    d = cfg.space.dim
    var = flow(qmc.Sobol(d, seed=2).random(2**20)).var()
    pts = qmc.Sobol(d, seed=1).random(inner)
    first = np.empty(d)
    for i in range(d):
        if i < 2:  # rw normal, r lognormal: Gauss-Hermite in the normal score
            z, w = np.polynomial.hermite_e.hermegauss(nodes)
            u = ndtr(z)
        else:
            z, w = np.polynomial.legendre.leggauss(nodes)
            u = (z + 1) / 2
        with np.errstate(invalid="ignore", divide="ignore"):
            g = np.array([flow(np.where(np.arange(d) == i, uk, pts)).mean() for uk in u])
        # the far nodes of rw (6.6 sd, rw < 0: the model fails) weigh below 1e-9: left out
        w, g = w[np.isfinite(g)] / w[np.isfinite(g)].sum(), g[np.isfinite(g)]
        first[i] = np.sum(w * (g - np.sum(w * g)) ** 2) / var
    return first


def edges_study(seeds: int, runs: int) -> bool:
    """The ``--study given-data-edges`` table (module docstring); whether every index held."""
    cfg = borehole_config()
    space = cfg.space

    def borehole(seed: int) -> tuple[np.ndarray, np.ndarray]:
        x = space.from_unit(np.random.default_rng(seed).uniform(size=(runs, space.dim)))
        return x, cfg.model.evaluate(x, space.names).scalars["flow"].T

    cases: list[tuple[str, list[str], list[str], np.ndarray, Sample]] = [
        ("borehole", list(space.names), ["-"], borehole_first_order()[None, :], borehole)]
    times = [f"{t:.2f}" for t in ROTATION_TIMES]
    exact = np.stack([np.cos(ROTATION_TIMES) ** 2, np.sin(ROTATION_TIMES) ** 2], axis=1)
    for name, shape in (("rotation", "linear"), ("rotation-quadratic", "quadratic"),
                        ("rotation-step", "step")):
        def series(seed: int, shape: str = shape) -> tuple[np.ndarray, np.ndarray]:
            x = np.random.default_rng(seed).normal(size=(runs, 2))
            return x, rotation(x, shape)
        cases.append((name, ["x1", "x2"], times, exact, series))
    print(f"given-data first-order indices at the edges: {runs} runs, {seeds} seeds")
    head = (f"{'case':18s} {'index':>5s} {'t':>5s} {'exact':>7s} {'bias':>8s} {'sd':>7s} "
            f"{'cover95':>8s} {'width':>7s}")
    print(head)
    print("-" * len(head))
    worst = 1.0
    for name, names, labels, ex, sample in cases:
        est = np.empty((seeds, *ex.shape))
        ci = np.empty((seeds, 2, *ex.shape))
        for seed in range(seeds):
            x, lanes = sample(seed)
            r = first_order_indices(x, lanes)
            est[seed], ci[seed] = r.first, r.ci
        cover = np.mean((ci[:, 0] <= ex) & (ex <= ci[:, 1]), axis=0)
        width = np.median(ci[:, 1] - ci[:, 0], axis=0)
        err = est - ex
        worst = min(worst, float(cover.min()))
        for i, index in enumerate(names):
            for k, t in enumerate(labels):
                print(f"{name:18s} {index:>5s} {t:>5s} {ex[k, i]:7.4f} {err[:, k, i].mean():8.4f} "
                      f"{err[:, k, i].std(ddof=1):7.4f} {cover[k, i]:8.0%} {width[k, i]:7.4f}")
    held = worst >= 0.9
    print(f"verdict: {'PASS' if held else 'FAIL'}: the lowest coverage of any index is "
          f"{worst:.0%} (at least 90% wanted)")
    return held
def pce_borehole_study(seeds: int) -> None:
    """The ``--study pce-borehole`` table (module docstring)."""
    import logging

    import uqguide.methods.pce_adaptive as apce
    from pick_freeze_peers import CASES
    from uqguide.config.run_config import validate_config
    from uqguide.driver.propagate import run

    case = CASES["borehole"]
    ref = case.exact()
    spent = [0.0]  # CPU of the indices' intervals (bootstrap and cross term) in this run
    timed = {name: getattr(apce, name) for name in ("regression_intervals", "cross_term_band")
             if hasattr(apce, name)}

    def clocked(function: Callable) -> Callable:
        def call(*args, **kwargs):
            t0 = time.process_time()
            out = function(*args, **kwargs)
            spent[0] += time.process_time() - t0
            return out
        return call

    for name, function in timed.items():
        setattr(apce, name, clocked(function))
    boot: list[float] = []
    logging.disable(logging.WARNING)  # the per-seed notes on withheld moments
    est = np.full((seeds, 2, 8), np.nan)
    ci = np.full((seeds, 2, 2, 8), np.nan)
    cpu = []
    try:
        for seed in range(seeds):
            t0, spent[0] = time.process_time(), 0.0
            cfg = {**case.config, "seed": seed,
                   "methods": [{"name": "pce_adaptive", "label": "apce"}]}
            st = run(validate_config(cfg)).run("apce").estimate.stats[case.output]
            cpu.append(time.process_time() - t0)
            boot.append(spent[0])
            est[seed] = st.sobol_first[0], st.sobol_total[0]
            ci[seed] = st.sobol_first_ci[:, 0], st.sobol_total_ci[:, 0]
    finally:
        for name, function in timed.items():
            setattr(apce, name, function)
        logging.disable(logging.NOTSET)
    print(f"borehole, pce_adaptive at its defaults, {seeds} seeds; reference: degree-5 PCE of "
          f"15000 runs (pick_freeze_peers)")
    head = (f"{'index':9s} {'ref':>9s} {'bias':>9s} {'sd':>8s} {'rms':>8s} {'cover95':>8s} "
            f"{'width':>8s}")
    print(head)
    print("-" * len(head))
    for k, kind in enumerate(("S", "ST")):
        for i, name in enumerate(case.sets):
            r = ref[k][i]
            e = est[:, k, i] - r
            lo, hi = ci[:, k, 0, i], ci[:, k, 1, i]
            cover = np.mean((lo <= r) & (r <= hi))
            print(f"{kind + '_' + name:9s} {r:9.6f} {e.mean():9.1e} {e.std(ddof=1):8.1e} "
                  f"{np.sqrt(np.mean(e**2)):8.1e} {cover:8.0%} {np.median(hi - lo):8.1e}")
    print(f"median CPU-s per run {np.median(cpu):.2f}, of which the indices' intervals "
          f"{np.median(boot):.3f}")


def have_salib() -> bool:
    try:
        import SALib  # noqa: F401
    except ImportError:
        return False
    return True


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", choices=("given-data", "saltelli", "correlated",
                                        "given-data-edges", "pce-borehole"),
                    default="given-data")
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--pce-runs", type=int, default=100)
    ap.add_argument("--n-base", type=int, default=1000)
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--methods", nargs="+", default=None)
    ap.add_argument("--functions", nargs="+", default=None)
    args = ap.parse_args()
    if args.study == "given-data-edges":
        raise SystemExit(0 if edges_study(args.seeds, args.runs) else 1)
    if args.study == "pce-borehole":
        pce_borehole_study(args.seeds)
        return
    if args.study == "correlated":
        correlated_study(args.seeds, args.pce_runs, args.runs, args.n_base)
        return
    if args.study == "saltelli":
        from pick_freeze_peers import FUNCTIONS, PEERS, study

        study(args.functions or list(FUNCTIONS), args.methods or list(PEERS), args.n_base,
              args.seeds)
        return
    args.methods = args.methods or ["uqguide", "rank-neighbour", "salib-rbd-fast",
                                    "salib-saltelli"]
    exact = Ishigami().exact()["first"]
    salib = have_salib()
    methods = [m for m in args.methods if salib or not m.startswith("salib")]
    if len(methods) < len(args.methods):
        print("SALib not installed: its rows are skipped (pip install uqguide[peers])")
    err = {m: np.zeros((args.seeds, 3)) for m in methods}
    cover = {m: np.zeros(3) for m in methods}
    has_ci = {m: False for m in methods}
    cpu = {m: [] for m in methods}
    runs_of = {m: args.runs for m in methods}
    for seed in range(args.seeds):
        x = np.random.default_rng(seed).uniform(-np.pi, np.pi, (args.runs, 3))
        y = ishigami(x)
        for m in methods:
            t0 = time.process_time()
            if m == "salib-saltelli":
                (first, ci), runs_of[m] = saltelli(args.runs, seed)
            else:
                first, ci = GIVEN_DATA[m](x, y, seed)
            cpu[m].append(time.process_time() - t0)
            err[m][seed] = first - exact
            if ci is not None:
                has_ci[m] = True
                cover[m] += (ci[0] <= exact) & (exact <= ci[1])
    print(f"Ishigami, exact first-order indices {np.round(exact, 4).tolist()}; "
          f"{args.seeds} seeds; plain Monte Carlo sample of {args.runs} runs "
          f"(salib-saltelli: its own design)")
    head = (f"{'method':16s} {'runs':>5s} {'index':>5s} {'bias':>8s} {'sd':>7s} "
            f"{'max|err|':>8s} {'>0.05':>6s} {'cover95':>8s} {'cpu_s':>7s}")
    print(head)
    print("-" * len(head))
    for m in methods:
        e = err[m]
        for i, name in enumerate(("S1", "S2", "S3")):
            cov = f"{cover[m][i] / args.seeds:8.0%}" if has_ci[m] else f"{'-':>8s}"
            print(f"{m:16s} {runs_of[m]:5d} {name:>5s} {e[:, i].mean():8.4f} "
                  f"{e[:, i].std(ddof=1):7.4f} {np.abs(e[:, i]).max():8.4f} "
                  f"{int(np.sum(np.abs(e[:, i]) > 0.05)):6d} {cov} "
                  f"{np.median(cpu[m]):7.4f}")


if __name__ == "__main__":
    main()
