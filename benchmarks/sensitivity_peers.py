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

``--study pce-borehole`` (#46, item 6): the borehole function (``pick_freeze_peers``' config
and reference indices) through ``pce_adaptive`` at its defaults, per seed; per index ``S`` and
``ST`` of every input: the reference, bias, sd and root mean square error over the seeds,
coverage of the 95% interval, its median width, and the median CPU seconds of a run and of
its indices' intervals (bootstrap and cross term). The G-function's and Ishigami's coverage:
``benchmarks/pce_sensitivity.py``.

    python benchmarks/sensitivity_peers.py [--runs 2000] [--seeds 50] [--methods ...]
    python benchmarks/sensitivity_peers.py --study saltelli [--n-base 1000] [--seeds 50]
    python benchmarks/sensitivity_peers.py --study correlated [--seeds 50]
    python benchmarks/sensitivity_peers.py --study pce-borehole [--seeds 50]
"""

from __future__ import annotations

import argparse
import time
import warnings
from collections.abc import Callable

import numpy as np

from uqguide.models.benchmarks import Ishigami
from uqguide.stats.sobol_given_data import first_order_indices

NAMES = ("x1", "x2", "x3")
PROBLEM = {"num_vars": 3, "names": list(NAMES), "bounds": [[-np.pi, np.pi]] * 3}

Estimate = tuple[np.ndarray, np.ndarray | None]  # (first (3,), ci (2, 3) or None)


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
                                        "pce-borehole"),
                    default="given-data")
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--pce-runs", type=int, default=100)
    ap.add_argument("--n-base", type=int, default=1000)
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--methods", nargs="+", default=None)
    ap.add_argument("--functions", nargs="+", default=None)
    args = ap.parse_args()
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
