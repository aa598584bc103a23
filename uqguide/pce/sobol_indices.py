"""Sobol' indices of a PCE, in closed form (sums of squared coefficients over sets of terms,
:func:`term_sets`), with their 95% intervals: a wild bootstrap of a regression
(:func:`regression_intervals`), joined with the first-order term of the surrogate's error
measured on runs it did not fit (:func:`uqguide.pce.index_check.cross_term_band`), widened by
the bound of the error's own share (:func:`truncation_error_intervals`).

Derivation of the bounds, why this bootstrap, cost and measured coverage:
docs/error-budget.md#pce-indices and docs/pce.md#the-index-error-identity.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from threadpoolctl import threadpool_limits

from ..core.inputs import InputSpace, split_groups
from ..core.types import OutputStats
from ..stats.moments import column_blocks
from .expansion import Expansion

#: Bootstrap replicates behind a regression PCE's intervals (the 2.5% and 97.5% points of 200
#: replicates are within about 0.1 standard deviation of those of infinitely many).
N_BOOTSTRAP = 200
#: Stream of the bootstrap weights (``uqguide.pce.design.stream``; 0-2 are taken there).
BOOTSTRAP_STREAM = 3
#: The least half-width of a bootstrap interval: the round-off of indices from a least-squares
#: fit (about 1e-10 on Ishigami, which the expansion represents exactly).
ROUND_OFF = 1e-8
_CHUNK_FLOATS = 2**22  # replicates x columns x (terms or index sets) held at once (32 MB)


@dataclass
class PCEIndices:
    """Indices of every column of an expansion: ``first``, ``total (m, d)``, ``group_first``,
    ``group_total (m, G)``; NaN where the column has no variance."""

    first: np.ndarray
    total: np.ndarray
    group_first: np.ndarray
    group_total: np.ndarray


def term_sets(alpha: np.ndarray, groups: Sequence[Sequence[int]] = ()) -> np.ndarray:
    """Which terms each index sums: ``(P, 2 d + 2 G)`` booleans, columns first-order of each
    input, total of each input, closed index of each group, total of each group (the constant
    term in none); ``groups``: each group's input columns."""
    support = np.asarray(alpha) > 0
    n_in = support.sum(axis=1)
    first = support & (n_in == 1)[:, None]
    sets = [first, support]
    if groups:
        inside = np.zeros((support.shape[0], len(groups)), dtype=bool)
        touch = np.zeros_like(inside)
        for g, cols in enumerate(groups):
            in_g = np.zeros(support.shape[1], dtype=bool)
            in_g[list(cols)] = True
            touch[:, g] = support[:, in_g].any(axis=1)
            inside[:, g] = touch[:, g] & ~support[:, ~in_g].any(axis=1)
        sets += [inside, touch]
    return np.concatenate(sets, axis=1)


def ratios(coef: np.ndarray, sets: np.ndarray) -> np.ndarray:
    """Partial variances over total variance, ``(..., m, S)`` for coefficients ``(..., P, m)``;
    NaN for a column without variance."""
    c2 = coef[..., 1:, :] ** 2
    var = c2.sum(axis=-2)                                  # (..., m)
    part = np.swapaxes(c2, -1, -2) @ sets[1:].astype(float)  # (..., m, S)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where((var > 0)[..., None], part / np.where(var > 0, var, 1.0)[..., None],
                        np.nan)


def _split(values: np.ndarray, d: int, n_groups: int) -> PCEIndices:
    return PCEIndices(values[..., :d], values[..., d:2 * d],
                      values[..., 2 * d:2 * d + n_groups], values[..., 2 * d + n_groups:])


def expansion_indices(exp: Expansion, groups: Sequence[Sequence[int]] = ()) -> PCEIndices:
    """The indices of every column of ``exp``, ``(m, ...)``; NaN for :func:`refused_sets`."""
    values = ratios(exp.coef, term_sets(exp.alpha, groups))
    return _split(np.where(refused_sets(exp.germ.space, groups), np.nan, values),
                  exp.alpha.shape[1], len(groups))


def bootstrap_cores(exp: Expansion, psi: np.ndarray, targets: np.ndarray,
                    seed: np.random.SeedSequence | int, n_boot: int = N_BOOTSTRAP
                    ) -> np.ndarray:
    """Refits of the expansion's selected terms to wild-bootstrap replicates of its runs:
    ``(n_boot, P, r_core)``. ``targets (n, r)``: what the core's first ``r`` columns were fitted
    to (the rest are kept); ``psi (n, P)``: ``exp.alpha`` at the runs.
    """
    core = exp.core
    n, r = targets.shape
    supports: dict[tuple[int, ...], list[int]] = {}
    for c in range(r):
        s = np.flatnonzero(core[:, c])
        supports.setdefault(tuple(np.union1d([0], s).tolist()), []).append(c)
    # one Rademacher sign per run and replicate, shared by every column: the columns'
    # errors at a run stay together, as the runs' would in a resample
    signs = np.random.default_rng(seed).choice([-1.0, 1.0], size=(n_boot, n))
    out = np.repeat(core[None], n_boot, axis=0)
    # One BLAS thread, as the fit (docs/pce.md#one-blas-thread).
    with threadpool_limits(limits=1, user_api="blas"):
        for sup, cols in supports.items():
            rows = list(sup)
            q, rr = np.linalg.qr(psi[:, rows])
            lev = np.einsum("ij,ij->i", q, q)                    # leverages h_i
            y = targets[:, cols]
            fitted = q @ (q.T @ y)
            loo = (y - fitted) / np.clip(1.0 - lev, 1e-3, None)[:, None]
            solve = np.linalg.solve(rr, q.T)                     # (s, n): y -> coefficients
            base = solve @ fitted                                # (s, c)
            for b in range(n_boot):
                out[b][np.ix_(rows, cols)] = base + solve @ (signs[b][:, None] * loo)
    return out


def bootstrap_intervals(exp: Expansion, cores: np.ndarray, sets: np.ndarray) -> np.ndarray:
    """The basic bootstrap intervals of the indices, ``(2, m, S)``: ``2 S - q_975`` to
    ``2 S - q_025`` of the replicates' 2.5% and 97.5% points ``q``, within [0, 1], widened
    by :data:`ROUND_OFF` either way (docs/pce.md#the-basic-bootstrap-interval).
    """
    m = exp.n_columns
    n_boot = cores.shape[0]
    out = np.full((2, m, sets.shape[1]), np.nan)
    # the replicates' coefficients (B, P, columns) are the largest array, not the indices
    step = max(1, _CHUNK_FLOATS // max(1, n_boot * max(sets.shape[1], cores.shape[1])))
    point = ratios(exp.coef, sets)                          # (m, S)
    for cols in column_blocks(m, step):
        coef = cores if exp.mix is None else cores @ exp.mix[:, cols]
        if exp.mix is None:
            coef = coef[:, :, cols]
        vals = ratios(coef, sets)                           # (B, mb, S)
        ok = np.isfinite(vals).all(axis=0) & np.isfinite(point[cols])
        q = np.quantile(np.where(np.isfinite(vals), vals, 0.0), [0.025, 0.975], axis=0)
        basic = np.stack([2 * point[cols] - q[1] - ROUND_OFF, 2 * point[cols] - q[0] + ROUND_OFF])
        out[:, cols] = np.where(ok, np.clip(basic, 0.0, 1.0), np.nan)
    return out


def truncation_bounds(values: np.ndarray, eps: np.ndarray, orthogonal: bool = True,
                      cross: bool = False) -> np.ndarray:
    """``(2, ...)``: how far below and above an index ``S`` the model's may be for a surrogate
    of relative error ``eps`` (broadcast to ``values``): ``[-eps S, eps (1 - S)]`` when the error
    is orthogonal to the expansion's terms or its cross term was measured apart, widened by
    ``2 sqrt(S (1 - S) eps) (1 + sqrt(eps))`` either way when ``cross`` (the cross term bounded,
    not measured: docs/pce.md#the-index-error-identity); else (any error, ``orthogonal``
    False) ``(sqrt(S) -+ rho)^2 / (1 +- rho)^2 - S`` with ``rho = sqrt(eps) / (1 - sqrt(eps))``,
    within [0, 1]."""
    eps = np.clip(np.asarray(eps, dtype=float), 0.0, 1.0)
    if orthogonal:
        reach = 0.0
        if cross:
            s = np.clip(values, 0.0, 1.0)
            reach = 2.0 * np.sqrt(s * (1.0 - s) * eps) * (1.0 + np.sqrt(eps))
        return np.stack([-eps * values - reach, eps * (1.0 - values) + reach])
    root = np.sqrt(eps)
    rho = root / np.maximum(1.0 - root, 1e-300)
    s = np.sqrt(np.clip(values, 0.0, None))
    # an error as large as the variance (eps -> 1) makes rho overflow: the bound is then
    # [0, 1], which the clipping below gives
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        low = np.clip(s - rho, 0.0, None) ** 2 / (1.0 + rho) ** 2
        high = np.where(rho < 1.0, (s + rho) ** 2 / np.maximum(1.0 - rho, 1e-300) ** 2, 1.0)
    return np.stack([np.minimum(low, 1.0) - values, np.minimum(high, 1.0) - values])


def refused_sets(space: InputSpace, groups: Sequence[Sequence[int]] = ()) -> np.ndarray:
    """Which of the indices (:func:`term_sets`' columns: each input's first-order and total,
    each group's) a PCE does not give: those of a set holding part of a correlated group. The
    germ of a group is its members decorrelated in order, so one member's terms are an
    order-dependent mix of the group's inputs, not an index of that input
    (docs/error-budget.md#correlated-inputs)."""
    corr = [g.index for g in space.groups]
    alone = [bool(split_groups(corr, (j,))) for j in range(space.dim)]
    split = [bool(split_groups(corr, cols)) for cols in groups]
    return np.array(alone * 2 + split * 2, dtype=bool)


def _with_indices(st: OutputStats, free: np.ndarray, n_columns: int) -> np.ndarray:
    """Which of ``st``'s columns have indices (not of zero variance, not withheld): read from
    the inputs' indices the PCE gives (``free``), else (every input in a correlated group)
    from the std, by :func:`uqguide.stats.moments.shape_moments`' round-off test."""
    if st.sobol_first is None:
        return np.ones(n_columns, dtype=bool)
    first = np.asarray(st.sobol_first, dtype=float).reshape(n_columns, -1)
    if free.any():
        return np.isfinite(first[:, free]).all(axis=1)
    mean = np.asarray(st.mean, dtype=float).reshape(-1)
    std = np.asarray(st.std, dtype=float).reshape(-1)
    with np.errstate(invalid="ignore"):
        return std > (np.abs(mean) + 1e-300) * 1e-12


def set_indices(st: OutputStats, exp: Expansion, groups: Sequence[tuple[str, Sequence[int]]],
                band: np.ndarray | None = None) -> None:
    """Store the expansion's indices (and the ``(2, m, S)`` ``band``, if any) in ``st``, shaped
    like the output: ``(..., k, d)`` and ``(..., k, G)``; NaN where ``st`` has no indices (a
    column of zero variance) and for the sets :func:`refused_sets` names."""
    d, n_g = exp.alpha.shape[1], len(groups)
    refused = refused_sets(exp.germ.space, [cols for _, cols in groups])
    est = expansion_indices(exp, [cols for _, cols in groups])
    if band is not None:
        band = np.where(refused, np.nan, band)
    shape = exp.shape
    keep = _with_indices(st, ~refused[:d], exp.n_columns)

    def shaped(v: np.ndarray, width: int, lead: tuple[int, ...] = ()) -> np.ndarray:
        v = np.where(keep[:, None], v, np.nan)
        return v.reshape(lead + shape + (width,))

    st.sobol_first, st.sobol_total = shaped(est.first, d), shaped(est.total, d)
    st.sobol_estimator = "pce"
    if n_g:
        st.sobol_groups = tuple(name for name, _ in groups)
        st.sobol_group_first = shaped(est.group_first, n_g)
        st.sobol_group_total = shaped(est.group_total, n_g)
    if band is None:
        return
    b = _split(band, d, n_g)
    st.sobol_first_ci = np.stack([shaped(x, d) for x in b.first])
    st.sobol_total_ci = np.stack([shaped(x, d) for x in b.total])
    if n_g:
        st.sobol_group_first_ci = np.stack([shaped(x, n_g) for x in b.group_first])
        st.sobol_group_total_ci = np.stack([shaped(x, n_g) for x in b.group_total])


def widen_by_truncation(st: OutputStats, eps: np.ndarray | float | None,
                        orthogonal: bool = True, cross: bool = False) -> None:
    """Widen (or, without intervals, set) ``st``'s index intervals by the truncation bound of a
    surrogate of relative error ``eps`` (per column ``(..., k)``, or one figure); where an
    index is NaN (withheld: no usable surrogate) its interval is NaN too. ``eps`` None leaves
    the intervals as they are (NaN where none)."""
    for name in ("sobol_first", "sobol_total", "sobol_group_first", "sobol_group_total"):
        v = getattr(st, name)
        if v is None:
            continue
        v = np.asarray(v, dtype=float)
        ci = getattr(st, f"{name}_ci")
        ci = np.stack([v, v]) if ci is None and eps is not None else \
            (np.full((2,) + v.shape, np.nan) if ci is None else np.array(ci, dtype=float))
        if eps is not None:
            e = np.asarray(eps, dtype=float)
            e = e[..., None] if e.ndim else e  # per column: broadcast over inputs
            # the model's index is in [0, 1] too
            ci = np.clip(ci + truncation_bounds(v, e, orthogonal, cross), 0.0, 1.0)
        ci[:, ~np.isfinite(v)] = np.nan
        setattr(st, f"{name}_ci", ci)


def regression_intervals(stats: Mapping[str, OutputStats], fitted: Mapping[str, tuple[
        Expansion, np.ndarray, np.ndarray]], groups: Sequence[tuple[str, Sequence[int]]],
        seed: np.random.SeedSequence | int, n_boot: int = N_BOOTSTRAP,
        joined: Mapping[str, np.ndarray] | None = None) -> None:
    """Indices and intervals of every fitted output of a regression PCE, in place: the
    bootstrap's, joined (the hull of the two) with the output's band ``(2, m, S)`` in
    ``joined``, if any (:func:`uqguide.pce.index_check.cross_term_band`).

    ``fitted``: per output, its expansion, its basis ``psi (n, P)`` at the fit's runs and the
    columns fitted ``targets (n, r)``. Each output draws its bootstrap weights from ``seed`` by
    position, so the intervals depend only on the config and the seed.
    """
    ss = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    children = ss.spawn(len(fitted))
    cols = [c for _, c in groups]
    for (name, (exp, psi, targets)), child in zip(fitted.items(), children):
        if name not in stats:
            continue
        cores = bootstrap_cores(exp, psi, targets, child, n_boot)
        band = bootstrap_intervals(exp, cores, term_sets(exp.alpha, cols))
        cross = (joined or {}).get(name)
        if cross is not None:
            # either interval holds under its own assumptions; their hull holds when one does
            band = np.stack([np.fmin(band[0], cross[0]), np.fmax(band[1], cross[1])])
            band = np.where(np.isfinite(band), np.clip(band, 0.0, 1.0), np.nan)
        set_indices(stats[name], exp, groups, band)


def truncation_error_intervals(stats: Mapping[str, OutputStats],
                               loo: Mapping[str, float] | None = None,
                               orthogonal: bool = True) -> None:
    """Widen every PCE index interval in ``stats`` by its truncation bound, in place, once the
    surrogate is validated: ``eps`` is an output's validation error (per column) where it has
    one (whose runs measured the cross term: :func:`uqguide.pce.index_check.cross_term_band`),
    else its LOO error in ``loo`` with the cross term bounded (``cross``), else none (the
    intervals stay as they are); ``orthogonal``: which bound (:func:`truncation_bounds`).
    Withheld indices (NaN, groups' too: :func:`uqguide.pce.validation.withhold_all`) get no
    interval.
    """
    for name, st in stats.items():
        if st.sobol_first is None or st.sobol_estimator != "pce":
            continue
        if st.validation_error is not None:
            widen_by_truncation(st, st.validation_error, orthogonal)
        else:
            widen_by_truncation(st, (loo or {}).get(name), orthogonal, cross=True)
