"""The multi-fidelity Monte Carlo estimator of mean, std, skewness and kurtosis, with intervals.

Peherstorfer, Willcox & Gunzburger (2016, PWG16), level ``j`` (0 = highest fidelity) on the
first ``m_j`` rows of one input stream, each power 1-4 with its own weights; or (``"blue"``) the
best linear unbiased estimator of the same runs. Intervals: a bootstrap within the independent
groups of rows (:func:`group_bounds`); a failed row is dropped at every level. Formulas and
design decisions: docs/multifidelity.md#the-estimator-and-the-allocation-in-detail.
"""

from __future__ import annotations

from dataclasses import dataclass
from statistics import NormalDist

import numpy as np

from .moments import _nan_safe_percentile, resample_counts, shape_moments

__all__ = ["MfmcStatistics", "mfmc_statistics", "group_bounds"]

_POWERS = 4


@dataclass
class MfmcStatistics:
    """The estimates of :func:`mfmc_statistics`, one column per quantity.

    ``mean``, ``std``, ``skewness``, ``kurtosis``, ``sem (Q,)``; ``ci``: their ``level``
    intervals ``(2, Q)``; ``alpha (K, 4, Q)``: weights per level and power (row 0 is 1);
    ``rho (K, 2, Q)``: correlations with level 0 of ``z`` and ``z^2`` (carriers of mean and
    variance); ``equivalent_mc_runs``: level-0 MC runs with the same sem, ``sigma_0^2 / sem^2``;
    ``se_std``: ``se(var) / (2 std)`` by the same variance formula on the squares, a check on
    the bootstrap interval; ``equivalent_mc_runs_std``: ``Var(z_0^2) / se(var)^2`` (no kurtosis
    estimate enters); ``n_used (K,)``: surviving rows per level.
    """

    mean: np.ndarray
    std: np.ndarray
    skewness: np.ndarray
    kurtosis: np.ndarray
    sem: np.ndarray
    ci: dict[str, np.ndarray]
    alpha: np.ndarray
    rho: np.ndarray
    equivalent_mc_runs: np.ndarray
    n_used: np.ndarray
    se_std: np.ndarray | None = None
    equivalent_mc_runs_std: np.ndarray | None = None


def group_bounds(sizes: np.ndarray) -> list[tuple[int, int]]:
    """The independent groups ``[m_{g-1}, m_g)`` of rows (``m_{-1} = 0``) for non-decreasing
    ``sizes (K,)``."""
    edges = [0, *(int(m) for m in sizes)]
    return [(edges[g], edges[g + 1]) for g in range(len(sizes))]


def _check(levels_y: list[np.ndarray], sizes: np.ndarray, ok: np.ndarray) -> None:
    if len(levels_y) != len(sizes) or not len(sizes):
        raise ValueError("one array of outputs per level is needed")
    if np.any(np.diff(sizes) < 0):
        raise ValueError(f"runs per level must not decrease; got {list(sizes)}")
    for j, (y, m) in enumerate(zip(levels_y, sizes)):
        if y.ndim != 2 or y.shape[0] != m:
            raise ValueError(f"level {j}: outputs of shape {y.shape}, expected ({m}, Q)")
    if ok.shape != (int(sizes[-1]),):
        raise ValueError(f"ok mask of shape {ok.shape}, expected ({int(sizes[-1])},)")


def _group_sums(z: list[np.ndarray], bounds: list[tuple[int, int]], ok: np.ndarray,
                counts: list[np.ndarray] | None) -> tuple[np.ndarray, np.ndarray]:
    """Power sums ``S (B, G, K, 4, Q)`` per group and level (zero where a level did not run
    in a group) and surviving rows ``N (B, G)``; ``counts[g] (B, n_g)`` are resampling
    multiplicities of group ``g``'s surviving rows (None: each row once, ``B = 1``)."""
    n_levels, q = len(z), z[0].shape[1]
    b = 1 if counts is None else counts[0].shape[0]
    s = np.zeros((b, len(bounds), n_levels, _POWERS, q))
    n = np.zeros((b, len(bounds)))
    for g, (a, e) in enumerate(bounds):
        keep = a + np.flatnonzero(ok[a:e])
        c = np.ones((1, keep.size)) if counts is None else counts[g]
        n[:, g] = c.sum(axis=1)
        for j in range(g, n_levels):
            d = z[j][keep]
            p = d.copy()
            for k in range(_POWERS):
                s[:, g, j, k] = c @ p
                p = p * d
    return s, n


def _combine(s: np.ndarray, n: np.ndarray, alpha: np.ndarray) -> np.ndarray:
    """PWG16 eq (2.4) for each power: ``(B, 4, Q)`` estimates of ``E[z^p]``."""
    cum_s = np.cumsum(s, axis=1)  # (B, t, K, 4, Q): sums over the first m_t rows
    cum_n = np.cumsum(n, axis=1)[:, :, None, None]  # (B, t, 1, 1)
    est = cum_s[:, 0, 0] / cum_n[:, 0]
    for j in range(1, s.shape[2]):
        est = est + alpha[j] * (cum_s[:, j, j] / cum_n[:, j] - cum_s[:, j - 1, j] /
                                cum_n[:, j - 1])
    return est


def _central(raw: np.ndarray, shift: np.ndarray) -> tuple[np.ndarray, ...]:
    """mean, std, skewness, kurtosis from ``E[z^p]`` ``(..., 4, Q)``, ``z = y - shift``."""
    m1, m2, m3, m4 = (raw[..., k, :] for k in range(_POWERS))
    mu2 = m2 - m1**2
    mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
    mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
    mean = shift + m1
    with np.errstate(invalid="ignore"):
        std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
        impossible = kurt < 1.0 + skew**2
    std = np.where(mu2 < 0, np.nan, std)
    skew = np.where(impossible, np.nan, skew)
    kurt = np.where(impossible, np.nan, kurt)
    return mean, std, skew, kurt


def _weights(z: list[np.ndarray], rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Optimal weights ``(K, 4, Q)`` and correlations ``(K, 2, Q)`` from the rows every level
    ran; a constant level gets weight 0 and correlation 0 (NaN-free)."""
    n_levels, q = len(z), z[0].shape[1]
    alpha = np.zeros((n_levels, _POWERS, q))
    rho = np.zeros((n_levels, 2, q))
    alpha[0] = 1.0
    rho[0] = 1.0
    powers0 = [z[0][rows] ** (k + 1) for k in range(_POWERS)]
    for j in range(1, n_levels):
        for k in range(_POWERS):
            a, b = powers0[k], z[j][rows] ** (k + 1)
            da, db = a - a.mean(axis=0), b - b.mean(axis=0)
            cov = (da * db).mean(axis=0)
            va, vb = (da * da).mean(axis=0), (db * db).mean(axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                alpha[j, k] = np.where(vb > 0, cov / vb, 0.0)
                if k < 2:
                    rho[j, k] = np.where((va > 0) & (vb > 0), cov / np.sqrt(va * vb), 0.0)
    return alpha, rho


def mfmc_statistics(levels_y: list[np.ndarray], sizes: np.ndarray, ok: np.ndarray | None = None,
                    *, n_resamples: int = 200, seed: int = 0, level: float = 0.95,
                    block: int = 25, estimator: str = "mfmc") -> MfmcStatistics:
    """MFMC estimates of mean, std, skewness, kurtosis per quantity, with intervals.

    ``levels_y``: each used level's values ``(m_j, Q)`` on rows ``[0, m_j)``, in estimator order
    (highest first); ``sizes (K,)``: ``m_j``, non-decreasing; ``ok (m_{K-1},)``: rows usable at
    every level they ran at (module docstring; default all); ``n_resamples``: bootstrap
    resamples (0: only the mean's interval); ``estimator``: PWG16's (``"mfmc"``) or the best
    linear unbiased one of the same runs (``"blue"``); ``block``: resamples summed together
    (memory ``block * m`` floats; fewer when a group has over 80,000 rows).
    """
    sizes = np.asarray(sizes, dtype=np.int64)
    ok = np.ones(int(sizes[-1]), bool) if ok is None else np.asarray(ok, bool)
    levels_y = [np.asarray(y, float) for y in levels_y]
    _check(levels_y, sizes, ok)
    bounds = group_bounds(sizes)
    rows0 = np.flatnonzero(ok[:sizes[0]])
    if rows0.size < 2:
        raise ValueError(f"{rows0.size} usable runs of the highest level; at least 2 needed")
    shifts = [y[rows0].mean(axis=0) for y in levels_y]
    shift = shifts[0]
    z = [y - c for y, c in zip(levels_y, shifts)]
    if estimator not in ("mfmc", "blue"):
        raise ValueError(f"estimator must be 'mfmc' or 'blue', got {estimator!r}")
    alpha, rho = _weights(z, rows0)
    s, n = _group_sums(z, bounds, ok, None)
    used = np.cumsum(n[0])
    squares = [zj[rows0] ** 2 for zj in z]
    if estimator == "blue":
        weights, blue_var = _blue(z, rows0, n[0])
        raw = _combine_blue(s, weights)[0]
        var, var2 = blue_var[0], blue_var[1]
    else:
        weights = None
        raw = _combine(s, n, alpha)[0]
        # PWG16 Lemma 3.3 with the sample moments of the rows every level ran; the same for
        # the squares, centred at the mean: the variance's estimator (to first order)
        var = _lemma33([zj[rows0] for zj in z], alpha[:, 0], rho[:, 0], used)
        var2 = _lemma33(squares, alpha[:, 1], rho[:, 1], used)
    mean, std, skew, kurt = _central(raw, shift)
    sem = np.sqrt(np.maximum(var, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        se_std = np.sqrt(np.maximum(var2, 0.0)) / (2 * std)
        equivalent_std = np.where(var2 > 0, squares[0].var(axis=0) / var2, np.inf)
    zq = NormalDist().inv_cdf(0.5 + level / 2)
    ci = {"mean": np.stack([mean - zq * sem, mean + zq * sem])}
    if n_resamples > 0:
        ci.update(_bootstrap(z, bounds, ok, alpha, shift, n_resamples, seed, level, block,
                             weights))
    with np.errstate(divide="ignore", invalid="ignore"):
        equivalent = np.where(var > 0, z[0][rows0].std(axis=0) ** 2 / var, np.inf)
    return MfmcStatistics(mean=mean, std=std, skewness=skew, kurtosis=kurt, sem=sem, ci=ci,
                          alpha=alpha, rho=rho, equivalent_mc_runs=equivalent,
                          n_used=used.astype(np.int64), se_std=se_std,
                          equivalent_mc_runs_std=equivalent_std)


def _blue(z: list[np.ndarray], rows: np.ndarray, n: np.ndarray
          ) -> tuple[np.ndarray, np.ndarray]:
    """MLBLUE weights ``(G, K, 4, Q)`` of the groups' power sums (zero where a level did not
    run) and the estimator's variance ``(4, Q)`` per power, from the covariance of the levels'
    powers on ``rows`` (every level ran them) and the groups' surviving rows ``n (G,)``."""
    n_levels, q = len(z), z[0].shape[1]
    weights = np.zeros((n_levels, n_levels, _POWERS, q))
    var = np.zeros((_POWERS, q))
    for k in range(_POWERS):
        x = np.stack([zj[rows] ** (k + 1) for zj in z], axis=1)  # (n, K, Q)
        x = x - x.mean(axis=0)
        c = np.einsum("nkq,nlq->qkl", x, x) / max(rows.size, 1)  # (Q, K, K)
        d = np.einsum("qkk->qk", c)
        # any fixed positive definite C keeps the estimate unbiased: regularise, and a
        # quantity constant at every level gets the identity (its plain mean)
        scale = np.where(d.max(axis=1) > 0, d.max(axis=1), 1.0)
        c = c + np.eye(n_levels) * (1e-9 * d + 1e-300 + (d.max(axis=1) == 0)[:, None]
                                    * scale[:, None])[:, :, None]
        inv_g = [np.linalg.inv(c[:, g:, g:]) for g in range(n_levels)]
        psi = np.zeros((q, n_levels, n_levels))
        for g in range(n_levels):
            psi[:, g:, g:] += n[g] * inv_g[g]
        a = np.linalg.inv(psi)  # (Q, K, K): the covariance of the levels' mean estimates
        var[k] = a[:, 0, 0]
        for g in range(n_levels):
            if n[g] > 0:
                weights[g, g:, k] = np.einsum("ql,qlm->mq", a[:, 0, g:], inv_g[g])
    return weights, var


def _combine_blue(s: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """The BLUE of ``E[z_0^p]`` ``(B, 4, Q)`` from the groups' power sums ``(B, G, K, 4, Q)``."""
    return np.einsum("bgkpq,gkpq->bpq", s, weights)


def _lemma33(z: list[np.ndarray], alpha: np.ndarray, rho: np.ndarray, used: np.ndarray
             ) -> np.ndarray:
    """PWG16 Lemma 3.3: the variance ``(Q,)`` of the estimator of ``E[z_0]`` from each level's
    values ``z (n, Q)`` on the rows every level ran, the weights and correlations with level 0
    ``(K, Q)`` and the rows ``m_j`` of each level."""
    sig = np.stack([zj.std(axis=0) for zj in z])
    var = sig[0] ** 2 / used[0]
    for j in range(1, len(z)):
        a = alpha[j]
        var = var + (1 / used[j - 1] - 1 / used[j]) * (a * a * sig[j] ** 2 -
                                                       2 * a * rho[j] * sig[0] * sig[j])
    return var


def _bootstrap(z: list[np.ndarray], bounds: list[tuple[int, int]], ok: np.ndarray,
               alpha: np.ndarray, shift: np.ndarray, n_resamples: int, seed: int, level: float,
               block: int, weights: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Percentile intervals of std, skewness and kurtosis (module docstring)."""
    q = z[0].shape[1]
    draws = {k: np.empty((n_resamples, q)) for k in ("std", "skewness", "kurtosis")}
    sizes = [int(ok[a:e].sum()) for a, e in bounds]
    # a surrogate level's group may hold millions of rows: fewer resamples at a time keep the
    # (block, n) count arrays near 2e6 values (a function of the sizes: the same on any machine)
    block = max(1, min(block, 2_000_000 // max(max(sizes), 1)))
    for blk, r0 in enumerate(range(0, n_resamples, block)):
        b = min(block, n_resamples - r0)
        rng = np.random.default_rng([seed, blk])
        counts = [resample_counts(rng, b, n_g) for n_g in sizes]
        s, n = _group_sums(z, bounds, ok, counts)
        raw = _combine(s, n, alpha) if weights is None else _combine_blue(s, weights)
        _, std, skew, kurt = _central(raw, shift)
        sl = slice(r0, r0 + b)
        draws["std"][sl], draws["skewness"][sl], draws["kurtosis"][sl] = std, skew, kurt
    return {k: _nan_safe_percentile(v, (1.0 - level) / 2) for k, v in draws.items()}
