"""Statistics of a PCE (:func:`output_statistics`): mean and covariance from the coefficients
(eqs 21-22), skewness and kurtosis by the cheaper exact rule (:func:`exact_rule`) where one is
affordable, else from surrogate draws; Sobol' indices from the coefficients.

The rules and their costs: docs/methods.md#exact-skewness-and-kurtosis and
docs/methods.md#pce-statistics.
"""

from __future__ import annotations

import numpy as np

from ..stats.moments import shape_moments
from ..core.types import OutputStats
from . import basis, linearisation
from .design import surrogate_draws
from .expansion import Expansion
from .quadrature import gauss_rule
from .sobol_indices import ratios, refused_sets, term_sets

_CHUNK_FLOATS = 2**22  # rows per chunk x (terms + columns) stay near 32 MB

EXACT, SAMPLED = "exact", "surrogate-sampling"


def mean_and_cov(exp: Expansion) -> tuple[np.ndarray, np.ndarray]:
    """Exact mean ``shape`` and covariance ``shape[:-1] + (k, k)`` (eqs 21, 22)."""
    c = exp.coef
    mean = c[0].reshape(exp.shape)
    dev = c[1:].reshape((-1,) + exp.shape)
    cov = np.einsum("p...i,p...j->...ij", dev, dev)
    return mean, cov


def _chunk_rows(exp: Expansion) -> int:
    width = exp.alpha.shape[0] + exp.core.shape[1] + exp.n_columns
    return max(1024, _CHUNK_FLOATS // width)


def _accumulate(exp: Expansion, xi: np.ndarray, w: np.ndarray | None, sums: list[np.ndarray]):
    """Add weighted power sums 1..4 of the centred surrogate at ``xi`` to ``sums``."""
    psi = basis.evaluate(exp.germ, exp.alpha[1:], xi)  # constant dropped: centred at the mean
    z = exp.mixed(psi @ exp.core[1:])
    z2 = z * z
    for i, p in enumerate((z, z2, z2 * z, z2 * z2)):
        sums[i] += p.sum(axis=0) if w is None else w @ p


def exact_grid_size(exp: Expansion) -> int:
    """Nodes of the tensor Gauss grid that integrates the fourth power of ``exp`` exactly."""
    degrees = exp.trimmed().alpha.max(axis=0)
    return int(np.prod(2 * degrees + 1, dtype=float))


def exact_rule(exp: Expansion, max_exact_points: int = 250_000) -> str | None:
    """The cheaper usable exact rule for ``exp`` (``"grid"`` or ``"linearisation"``, costs in
    multiply-adds), or None."""
    trimmed = exp.trimmed()
    nodes = exact_grid_size(trimmed)
    terms = linearisation.product_terms(trimmed)
    r = trimmed.core.shape[1]
    m = trimmed.n_columns
    costs = {}
    if nodes <= max_exact_points:
        costs["grid"] = nodes * (trimmed.alpha.shape[0] * (1 + r) + (r + 4) * m)
    if terms <= linearisation.MAX_PRODUCT_TERMS:
        costs["linearisation"] = terms * (40 + m)
    return min(costs, key=costs.__getitem__) if costs else None


def central_moments_exact(exp: Expansion) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central moments 2-4 ``(m,)`` of the surrogate by a tensor Gauss rule, exactly."""
    exp = exp.trimmed()
    d = exp.alpha.shape[1]
    degrees = exp.alpha.max(axis=0)
    active = np.flatnonzero(degrees)
    rules = [gauss_rule(exp.germ.kind(int(j)), int(2 * degrees[j] + 1)) for j in active]
    sizes = tuple(r[0].size for r in rules)
    n = int(np.prod(sizes, dtype=np.int64)) if sizes else 1
    sums = [np.zeros(exp.n_columns) for _ in range(4)]
    step = _chunk_rows(exp)
    for start in range(0, n, step):
        flat = np.arange(start, min(n, start + step))
        idx = np.unravel_index(flat, sizes) if sizes else ()
        xi = np.zeros((flat.size, d))
        w = np.ones(flat.size)
        for a, (j, (nodes, weights)) in enumerate(zip(active, rules)):
            xi[:, j] = nodes[idx[a]]
            w *= weights[idx[a]]
        _accumulate(exp, xi, w, sums)
    return sums[1], sums[2], sums[3]


def central_moments_sampled(
    exp: Expansion, n_draws: int, seed: int | np.random.SeedSequence, sampling: str = "random"
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central moments 2-4 ``(m,)`` of the surrogate at ``n_draws`` fixed-seed germ draws
    (``sampling``: :func:`uqguide.pce.design.surrogate_draws`'s)."""
    exp = exp.trimmed()
    d = exp.alpha.shape[1]
    sums = [np.zeros(exp.n_columns) for _ in range(4)]
    n = 0
    for u in surrogate_draws(d, n_draws, seed, _chunk_rows(exp), sampling):
        _accumulate(exp, exp.germ.from_unit(u), None, sums)
        n += u.shape[0]
    return central_from_raw(*(s / n for s in sums))


def central_from_raw(m1: np.ndarray, m2: np.ndarray, m3: np.ndarray, m4: np.ndarray
                     ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Central moments 2-4 from the raw moments 1-4 about any centre."""
    return (m2 - m1**2, m3 - 3 * m1 * m2 + 2 * m1**3,
            m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4)


def sobol_indices(exp: Expansion) -> tuple[np.ndarray, np.ndarray]:
    """First-order and total Sobol' indices, shape ``shape + (d,)``; NaN where the variance is 0
    and for an input of a correlated group (:func:`uqguide.pce.sobol_indices.refused_sets`)."""
    d = exp.alpha.shape[1]
    sets = term_sets(exp.alpha)
    alone = refused_sets(exp.germ.space)[:d]
    # First-order and total each their own product: one product of both rounds otherwise.
    first, total = (np.where(alone, np.nan, ratios(exp.coef, s)).reshape(exp.shape + (d,))
                    for s in (sets[:, :d], sets[:, d:]))
    return first, total


def output_statistics(
    exp: Expansion, *, n_runs: int, n_draws: int = 1_000_000,
    seed: int | np.random.SeedSequence = 0, max_exact_points: int = 250_000,
    moments: str = "auto", sampling: str = "random",
) -> OutputStats:
    """The :class:`OutputStats` of an expansion fitted on ``n_runs`` (``n_used``).

    ``moments``: ``"auto"`` is exact where the Gauss grid is at most ``max_exact_points`` nodes,
    else ``n_draws`` surrogate draws of kind ``sampling``
    (:func:`uqguide.pce.design.surrogate_draws`).
    """
    mean, cov = mean_and_cov(exp)
    var = (exp.coef[1:] ** 2).sum(axis=0)
    rule = exact_rule(exp, max_exact_points) if moments in ("auto", EXACT) else None
    if moments == "auto":
        moments = SAMPLED if rule is None else EXACT
    if moments == EXACT:
        if rule == "linearisation":
            mu2, mu3, mu4 = linearisation.central_moments_linearised(exp)
        else:
            mu2, mu3, mu4 = central_moments_exact(exp)
    else:
        mu2, mu3, mu4 = central_moments_sampled(exp, n_draws, seed, sampling)
    # The reported std is the exact one, and it decides which columns have zero variance (with
    # the threshold of uqguide.stats.moments, so PCE and Monte Carlo agree on what is "zero").
    zeros = np.zeros_like(var)
    std, flag, _ = shape_moments(mean.ravel(), var, zeros, zeros)
    zero = np.isnan(flag)
    _, skew, kurt = shape_moments(mean.ravel(), mu2, mu3, mu4)
    skew = np.where(zero, np.nan, skew)
    kurt = np.where(zero, np.nan, kurt)
    first, total = sobol_indices(exp)
    # A round-off variance below that threshold gives no meaningful indices either.
    zero_k = zero.reshape(exp.shape)[..., None]
    first, total = np.where(zero_k, np.nan, first), np.where(zero_k, np.nan, total)
    return OutputStats(
        mean=mean, std=std.reshape(exp.shape), skewness=skew.reshape(exp.shape),
        kurtosis=kurt.reshape(exp.shape), cov=cov, n_used=int(n_runs), moments_method=moments,
        sobol_first=first, sobol_total=total, sobol_estimator="pce",
    )
