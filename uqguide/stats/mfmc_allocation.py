"""Multi-fidelity Monte Carlo: which levels to use and how many runs of each.

PWG16's closed-form optimum for every candidate subset of levels that meets its ordering
condition, refined numerically for the worst of several quantities within the caps, and scored
against plain Monte Carlo at equal cost (:func:`select_allocation`); :func:`sample_sizes` turns
the ratios into runs. Design decisions and measured effects:
docs/multifidelity.md#the-estimator-and-the-allocation-in-detail.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

__all__ = ["Allocation", "mfmc_ratios", "ordering_holds", "select_allocation",
           "sample_sizes", "variance_factor", "variance_ratio"]


@dataclass(frozen=True)
class Allocation:
    """The levels used (estimator order; the first is always 0, the highest fidelity), their run
    ratios ``r_i = m_i / m_0`` (non-decreasing, ``r_0 = 1``) and the worst estimated
    ``Var(MFMC) / Var(MC)`` over the quantities at equal cost (1: plain MC)."""

    levels: tuple[int, ...]
    ratios: np.ndarray

    variance_ratio: float

    @property
    def is_plain_mc(self) -> bool:
        return len(self.levels) == 1


def ordering_holds(rho: np.ndarray, w: np.ndarray) -> bool:
    """PWG16 eq (3.8): ``|rho_0| > |rho_1| > ...`` and
    ``w_{i-1}/w_i > (rho_{i-1}^2 - rho_i^2) / (rho_i^2 - rho_{i+1}^2)`` for ``i >= 1``.

    ``rho (K,)``: correlations of each level with level 0 (``rho[0] = 1``); ``w (K,)``: cost per
    run of each level (any unit, > 0).
    """
    r2 = np.append(np.asarray(rho, float) ** 2, 0.0)
    if np.any(np.diff(r2[:-1]) >= 0):
        return False
    for i in range(1, len(w)):
        if r2[i] - r2[i + 1] <= 0:  # (an uncorrelated last level: no gap to pay for it)
            return False
        if not w[i - 1] / w[i] > (r2[i - 1] - r2[i]) / (r2[i] - r2[i + 1]):
            return False
    return True


def mfmc_ratios(rho: np.ndarray, w: np.ndarray) -> np.ndarray:
    """The optimal ratios ``r_i = m_i/m_0`` ``(K,)`` (PWG16 eq 3.10):
    ``r_i = sqrt(w_0 (rho_i^2 - rho_{i+1}^2) / (w_i (1 - rho_1^2)))``, ``rho_K = 0``;
    :func:`ordering_holds` must hold."""
    r2 = np.append(np.asarray(rho, float) ** 2, 0.0)
    w = np.asarray(w, float)
    if len(w) == 1:
        return np.ones(1)
    return np.sqrt(w[0] * (r2[:-1] - r2[1:]) / (w * (1.0 - r2[1])))


def variance_factor(rho: np.ndarray, ratios: np.ndarray) -> np.ndarray:
    """``g`` in ``Var(MFMC mean) = sigma_0^2 g / m_0`` for a nested allocation with the
    optimal weights ``alpha_i = rho_i sigma_0 / sigma_i`` (PWG16 Lemma 3.3):
    ``g = 1 - sum_{i>=1} (1/r_{i-1} - 1/r_i) rho_i^2``; ``rho (..., K)`` in estimator order.
    """
    rho = np.asarray(rho, float)
    inv = 1.0 / np.asarray(ratios, float)
    return 1.0 - np.sum((inv[:-1] - inv[1:]) * rho[..., 1:] ** 2, axis=-1)


def variance_ratio(rho: np.ndarray, w: np.ndarray, ratios: np.ndarray) -> np.ndarray:
    """``Var(MFMC) / Var(MC)`` at equal cost: ``g * (sum_i w_i r_i) / w_0``.

    At the optimum of :func:`mfmc_ratios` this equals PWG16 eq (3.13)'s
    ``(sum_i sqrt(w_i (rho_i^2 - rho_{i+1}^2)))^2 / w_0``.
    """
    w = np.asarray(w, float)
    return variance_factor(rho, ratios) * float(np.dot(w, ratios)) / w[0]


def select_allocation(rho: np.ndarray, w: np.ndarray, min_gain: float = 1.0,
                      max_step: np.ndarray | None = None) -> Allocation:
    """The allocation with the smallest worst variance ratio over the quantities (module
    docstring), or plain MC of level 0 when no candidate gains more than ``min_gain``
    (``1/variance_ratio``).

    ``rho (Q, K)``: correlation of each quantity at each level with level 0 (column 0 is 1; NaN,
    e.g. a constant quantity, counts as 0); ``w (K,)``: cost per run (> 0); ``max_step (K,)``:
    largest ``m_i / m_prev`` of each level, ``m_prev`` the level before in estimator order
    (default ``inf``: no cap).
    """
    rho = np.nan_to_num(np.atleast_2d(np.asarray(rho, float)))
    rho[:, 0] = 1.0
    w = np.asarray(w, float)
    n_levels = len(w)
    step = np.full(n_levels, np.inf) if max_step is None else np.asarray(max_step, float)
    starts: dict[tuple[int, ...], Allocation] = {}
    for size in range(1, n_levels):
        for subset in combinations(range(1, n_levels), size):
            for q in range(rho.shape[0]):
                order = sorted(subset, key=lambda i: -abs(rho[q, i]))
                levels = (0, *order)
                rq, wq = rho[q, list(levels)], w[list(levels)]
                if not ordering_holds(rq, wq):
                    continue
                ratios = _capped(mfmc_ratios(rq, wq), step[list(levels)])
                worst = float(np.max(variance_ratio(rho[:, list(levels)], wq, ratios)))
                if levels not in starts or worst < starts[levels].variance_ratio:
                    starts[levels] = Allocation(levels, ratios, worst)
    best = Allocation((0,), np.ones(1), 1.0)
    for start in starts.values():
        refined = _refine(start, rho, w, step)
        if refined.variance_ratio < best.variance_ratio:
            best = refined
    if best.is_plain_mc or 1.0 / best.variance_ratio < min_gain:
        return Allocation((0,), np.ones(1), 1.0)
    return best


def _capped(ratios: np.ndarray, step: np.ndarray) -> np.ndarray:
    """``ratios`` with each ``r_i <= step_i r_{i-1}`` (in order, so the caps compound)."""
    r = np.asarray(ratios, float).copy()
    for i in range(1, r.size):
        r[i] = min(r[i], step[i] * r[i - 1])
    return r


def _refine(start: Allocation, rho: np.ndarray, w: np.ndarray, step: np.ndarray
            ) -> Allocation:
    """``start``'s levels with the ratios that minimise the worst variance ratio within the caps
    ``step`` (``start`` when none is better): Nelder-Mead over ``u`` with
    ``r_i = r_{i-1} g_i``, ``g_i = 1 + e^{u_i}`` or capped ``1 + (step_i - 1) / (1 + e^{-u_i})``
    (any ``u`` is feasible and nested), ratios rounded to four digits so any machine agrees."""
    levels = list(start.levels)
    if len(levels) == 1:
        return start
    # (imported here: scipy.optimize takes half a second, and every CLI start-up imports
    # this module through the driver)
    from scipy.optimize import minimize

    rq, wq, cap = rho[:, levels], w[levels], step[levels]
    finite = np.isfinite(cap[1:])

    def ratios(u: np.ndarray) -> np.ndarray:
        with np.errstate(over="ignore"):
            g = np.where(finite, 1 + (np.where(finite, cap[1:], 2.0) - 1) / (1 + np.exp(-u)),
                         1 + np.exp(u))
        return np.cumprod(np.concatenate([[1.0], g]))

    def worst(u: np.ndarray) -> float:
        return float(np.max(variance_ratio(rq, wq, ratios(u))))

    # the start's u: the inverse of ``ratios`` (a logit of the capped steps' share of the cap)
    excess = start.ratios[1:] / start.ratios[:-1] - 1
    share = np.clip(excess / (np.where(finite, cap[1:], 2.0) - 1), 1e-6, 1 - 1e-6)
    u0 = np.where(finite, np.log(share / (1 - share)), np.log(np.maximum(excess, 1e-6)))
    res = minimize(worst, u0, method="Nelder-Mead",
                   options={"xatol": 1e-4, "fatol": 1e-7, "maxiter": 400 * len(u0)})
    # four significant digits: the search's last digits move with round-off, and a gain
    # below 1e-6 is no reason to leave the closed form
    r = np.array([float(f"{v:.4g}") for v in ratios(res.x)])
    r = _capped(np.maximum.accumulate(r), cap)
    vr = float(np.max(variance_ratio(rq, wq, r)))
    if not vr < start.variance_ratio * (1 - 1e-6):
        return start
    return Allocation(start.levels, r, vr)


def sample_sizes(allocation: Allocation, w: np.ndarray, *, budget: float | None = None,
                 m0: float | None = None, at_least: int = 0) -> np.ndarray:
    """Runs per used level, ``m_i = floor(r_i m_0)`` (within a budget), nested, at least
    ``max(at_least, 2)`` (the pilot's runs are part of the estimate).

    ``w (K,)``: cost per run of every level (indexed by level, not estimator order); exactly one
    of ``budget`` (total cost in ``w``'s unit: ``m_0 = budget / sum_i w_i r_i``, PWG16 eq 3.10)
    and ``m0`` (for a target standard error).
    """
    if (budget is None) == (m0 is None):
        raise ValueError("give exactly one of budget and m0")
    if m0 is None:
        assert budget is not None
        wl = np.asarray(w, float)[list(allocation.levels)]
        m0 = budget / float(np.dot(wl, allocation.ratios))
    m = np.maximum(np.floor(allocation.ratios * m0 + 1e-9), at_least).astype(np.int64)
    return np.maximum.accumulate(np.maximum(m, 2))
