"""The pick-freeze part of ``sensitivity_peers.py`` (``--study saltelli``; its docstring says
what is compared and how). Run through that script."""

from __future__ import annotations

import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run

#: (first, total, first_ci, total_ci): (m,), (m,), (2, m), (2, m); None: no interval
Indices = tuple[np.ndarray, np.ndarray, np.ndarray | None, np.ndarray | None]

G_A = [0.0, 1.0, 4.5, 9.0, 99.0, 99.0, 99.0, 99.0]
_U = {"dist": "uniform", "low": 0.0, "high": 1.0}


@dataclass
class Case:
    """A function as a uqguide config, its output, its frozen sets (names) and exact values."""

    name: str
    config: dict[str, Any]
    output: str
    sets: list[str]
    groups: dict[str, list[str]]
    exact: Callable[[], tuple[np.ndarray, np.ndarray]]
    independent: bool = True
    #: Coverage is counted over the indices at least this large (a reference that is not
    #: exact: its own error exceeds the intervals of the near-zero indices).
    cover_floor: float = 0.0


def _g_exact() -> tuple[np.ndarray, np.ndarray]:
    v = 1.0 / (3.0 * (1.0 + np.asarray(G_A)) ** 2)
    var = np.prod(1.0 + v) - 1.0
    total = v * np.prod(1.0 + v) / (1.0 + v) / var
    return v / var, total


def _ishigami_exact() -> tuple[np.ndarray, np.ndarray]:
    from uqguide.models.benchmarks import Ishigami

    e = Ishigami().exact()
    return np.asarray(e["first"]), np.asarray(e["total"])


def _linear_exact() -> tuple[np.ndarray, np.ndarray]:
    # y = x1 + x2 + x3 + x4 / 2: Var = 3.6 (the pair) + 1 + 0.25; additive, first = total
    s = np.array([3.6, 1.0, 0.25]) / 4.85
    return s, s


_BOREHOLE_REF: list[tuple[np.ndarray, np.ndarray]] = []


def _borehole_exact() -> tuple[np.ndarray, np.ndarray]:
    """A degree-5 least-squares PCE's indices (OpenTURNS), computed once. Its germ is standard
    normal for ``rw`` and ``log r`` (Hermite) and uniform for the rest (Legendre): in the unit
    cube the normal inverse CDF is singular at the ends, and the PCE would carry that error
    into the small indices."""
    if _BOREHOLE_REF:
        return _BOREHOLE_REF[0]
    import openturns as ot
    from scipy.special import ndtr

    cfg = validate_config({**CASES["borehole"].config,
                           "methods": [{"name": "monte_carlo", "n_samples": 10}]})
    ot.RandomGenerator.SetSeed(0)
    germ = _joint(ot)([ot.Normal(0.0, 1.0)] * 2 + [ot.Uniform(0.0, 1.0)] * 6)
    z = np.asarray(ot.LHSExperiment(germ, 15000).generate())
    u = np.c_[ndtr(z[:, :2]), z[:, 2:]]
    y = cfg.model.evaluate(cfg.space.from_unit(u), cfg.space.names).scalars["flow"]
    basis = ot.OrthogonalProductPolynomialFactory(
        [ot.HermiteFactory()] * 2 + [ot.LegendreFactory()] * 6)
    size = basis.getEnumerateFunction().getStrataCumulatedCardinal(5)
    algo = ot.FunctionalChaosAlgorithm(ot.Sample(z), ot.Sample(y), germ,
                                       ot.FixedStrategy(basis, size),
                                       ot.LeastSquaresStrategy())
    algo.run()
    sob = ot.FunctionalChaosSobolIndices(algo.getResult())
    ref = (np.array([sob.getSobolIndex(i) for i in range(8)]),
           np.array([sob.getSobolTotalIndex(i) for i in range(8)]))
    _BOREHOLE_REF.append(ref)
    return ref


def _joint(ot: Any) -> Any:
    """OpenTURNS' joint distribution class (``ComposedDistribution`` before 1.24)."""
    return getattr(ot, "JointDistribution", None) or ot.ComposedDistribution


def _inputs(names: list[str], spec: dict[str, Any]) -> list[dict[str, Any]]:
    return [{"name": n, **spec} for n in names]


CASES: dict[str, Case] = {
    "ishigami": Case("ishigami", {
        "model": {"name": "ishigami"},
        "inputs": _inputs(["x1", "x2", "x3"], {"dist": "uniform", "low": -np.pi,
                                               "high": np.pi}),
        "outputs": ["y"]}, "y", ["x1", "x2", "x3"], {}, _ishigami_exact),
    "g-function": Case("g-function", {
        "model": {"name": "sobol_g", "a": G_A},
        "inputs": _inputs([f"x{i + 1}" for i in range(8)], _U),
        "outputs": ["y"]}, "y", [f"x{i + 1}" for i in range(8)], {}, _g_exact),
    "borehole": Case("borehole", {
        "model": {"name": "borehole"},
        "inputs": [{"name": "rw", "dist": "normal", "mean": 0.10, "std": 0.0161812},
                   {"name": "r", "dist": "lognormal", "mu": 7.71, "sigma": 1.0056},
                   {"name": "Tu", "dist": "uniform", "low": 63070, "high": 115600},
                   {"name": "Hu", "dist": "uniform", "low": 990, "high": 1110},
                   {"name": "Tl", "dist": "uniform", "low": 63.1, "high": 116},
                   {"name": "Hl", "dist": "uniform", "low": 700, "high": 820},
                   {"name": "L", "dist": "uniform", "low": 1120, "high": 1680},
                   {"name": "Kw", "dist": "uniform", "low": 9855, "high": 12045}],
        "outputs": ["flow"]}, "flow", ["rw", "r", "Tu", "Hu", "Tl", "Hl", "L", "Kw"], {},
        _borehole_exact, cover_floor=0.001),
    "linear-correlated": Case("linear-correlated", {
        "model": {"name": "linear_gaussian", "coefficients": [[1.0, 1.0, 1.0, 0.5]]},
        "inputs": _inputs(["x1", "x2", "x3", "x4"], {"dist": "normal", "std": 1.0}),
        "correlations": [{"inputs": ["x1", "x2"], "matrix": [[1.0, 0.8], [0.8, 1.0]]}],
        "outputs": ["y"]}, "y", ["x1+x2", "x3", "x4"], {"x1+x2": ["x1", "x2"]},
        _linear_exact, independent=False),
}
FUNCTIONS = list(CASES)


# ---------------------------------------------------------------------------- the methods
def _ours(case: Case, n_base: int, seed: int, sampling: str) -> Indices:
    cfg = {**case.config, "seed": seed,
           "methods": [{"name": "sobol_saltelli", "label": "s", "n_base": n_base,
                        "sampling": sampling}]}
    st = run(validate_config(cfg)).run("s").estimate.stats[case.output]
    names = [i["name"] for i in case.config["inputs"]]
    if case.independent:
        return st.sobol_first[0], st.sobol_total[0], st.sobol_first_ci[:, 0], \
            st.sobol_total_ci[:, 0]
    # the correlated pair's group, then the inputs outside it
    alone = [names.index(n) for n in case.sets[1:]]
    first = np.r_[st.sobol_group_first[0, :1], st.sobol_first[0, alone]]
    total = np.r_[st.sobol_group_total[0, :1], st.sobol_total[0, alone]]
    fci = np.c_[st.sobol_group_first_ci[:, 0, :1], st.sobol_first_ci[:, 0, alone]]
    tci = np.c_[st.sobol_group_total_ci[:, 0, :1], st.sobol_total_ci[:, 0, alone]]
    return first, total, fci, tci


def _evaluate(case: Case, u: np.ndarray) -> np.ndarray:
    cfg = validate_config({**case.config,
                           "methods": [{"name": "monte_carlo", "n_samples": 10}]})
    x = cfg.space.from_unit(np.clip(u, 2.0**-53, 1 - 2.0**-53))
    return cfg.model.evaluate(x, cfg.space.names).scalars[case.output][:, 0]


def _salib(case: Case, n_base: int, seed: int) -> Indices:
    from SALib.analyze import sobol
    from SALib.sample import sobol as sobol_sample

    names = [i["name"] for i in case.config["inputs"]]
    problem: dict[str, Any] = {"num_vars": len(names), "names": names,
                               "bounds": [[0.0, 1.0]] * len(names)}
    if case.groups:
        grouped = {n: g for g, members in case.groups.items() for n in members}
        problem["groups"] = [grouped.get(n, n) for n in names]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # N not a power of two: SALib warns of balance
        u = sobol_sample.sample(problem, n_base, calc_second_order=False, seed=seed)
        r = sobol.analyze(problem, _evaluate(case, u), calc_second_order=False, seed=seed)
    s1, st = np.asarray(r["S1"]), np.asarray(r["ST"])
    c1, ct = np.asarray(r["S1_conf"]), np.asarray(r["ST_conf"])
    return s1, st, np.stack([s1 - c1, s1 + c1]), np.stack([st - ct, st + ct])


def _ot(case: Case, n_base: int, seed: int, algorithm: str) -> Indices:
    import openturns as ot

    d = len(case.config["inputs"])
    ot.RandomGenerator.SetSeed(seed)
    cube = _joint(ot)([ot.Uniform(0.0, 1.0)] * d)
    u = np.asarray(ot.SobolIndicesExperiment(cube, n_base, False).generate())
    y = ot.Sample(_evaluate(case, u)[:, None])
    cls = {"saltelli": ot.SaltelliSensitivityAlgorithm,
           "jansen": ot.JansenSensitivityAlgorithm}[algorithm]
    algo = cls(ot.Sample(u), y, n_base)
    algo.setUseAsymptoticDistribution(True)
    first, total = np.array(algo.getFirstOrderIndices()), np.array(algo.getTotalOrderIndices())
    fi, ti = algo.getFirstOrderIndicesInterval(), algo.getTotalOrderIndicesInterval()
    return first, total, np.array([fi.getLowerBound(), fi.getUpperBound()]), \
        np.array([ti.getLowerBound(), ti.getUpperBound()])


PEERS: dict[str, Callable[[Case, int, int], Indices | None]] = {
    "uqguide": lambda c, n, s: _ours(c, n, s, "sobol"),
    "uqguide-random": lambda c, n, s: _ours(c, n, s, "random"),
    "salib": _salib,
    "ot-saltelli": lambda c, n, s: _ot(c, n, s, "saltelli") if c.independent else None,
    "ot-jansen": lambda c, n, s: _ot(c, n, s, "jansen") if c.independent else None,
}


def study(functions: list[str], methods: list[str], n_base: int, seeds: int) -> None:
    """Print the table of the module docstring (of ``sensitivity_peers.py``)."""
    head = (f"{'function':18s} {'method':15s} {'runs':>6s} {'kind':>4s} {'bias':>7s} "
            f"{'rmse':>7s} {'max|err|':>8s} {'<0.03':>6s} {'cov_min':>7s} {'cov_avg':>7s} "
            f"{'cpu_s':>6s}")
    print(f"pick-freeze designs, N = {n_base} base rows, {seeds} seeds; errors against the "
          f"exact (borehole: reference PCE) indices")
    print(head)
    print("-" * len(head))
    for fname in functions:
        case = CASES[fname]
        first_x, total_x = case.exact()
        m = len(case.sets)
        runs = n_base * (m + 2)
        for meth in methods:
            err = np.full((2, seeds, m), np.nan)
            hit = np.zeros((2, m))
            have_ci = True
            cpu = []
            skipped = False
            for seed in range(seeds):
                t0 = time.process_time()
                got = PEERS[meth](case, n_base, seed)
                cpu.append(time.process_time() - t0)
                if got is None:
                    skipped = True
                    break
                first, total, fci, tci = got
                for k, (est, ci, exact) in enumerate([(first, fci, first_x),
                                                      (total, tci, total_x)]):
                    err[k, seed] = est - exact
                    if ci is None:
                        have_ci = False
                    else:
                        hit[k] += (ci[0] <= exact) & (exact <= ci[1])
            if skipped:
                print(f"{fname:18s} {meth:15s} {'-':>6s}  (no groups: not run)")
                continue
            for k, kind in enumerate(("S", "ST")):
                e = err[k]
                cov = (hit[k] / seeds)[(first_x, total_x)[k] >= case.cover_floor]
                bias = e.mean(axis=0)
                print(f"{fname:18s} {meth:15s} {runs:6d} {kind:>4s} "
                      f"{bias[np.argmax(np.abs(bias))]:7.4f} {np.sqrt(np.mean(e ** 2)):7.4f} "
                      f"{np.abs(e).max():8.4f} {np.mean(np.abs(e) < 0.03):6.1%} "
                      + (f"{cov.min():7.0%} {cov.mean():7.1%} " if have_ci else
                         f"{'-':>7s} {'-':>7s} ")
                      + f"{np.median(cpu):6.3f}")
        if case.cover_floor:
            print(f"{'':18s} coverage over the indices >= {case.cover_floor:g} (the "
                  f"reference's own error exceeds the intervals of the smaller ones)")
        print(f"{'':18s} exact S  {np.round(first_x, 4).tolist()}")
        print(f"{'':18s} exact ST {np.round(total_x, 4).tolist()}")
