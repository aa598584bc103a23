"""Least-angle regression with corrected leave-one-out selection (hybrid LARS, spec 4.4).

Blatman & Sudret (2011, J. Comput. Phys. 230(6)): least-angle regression over a candidate basis
gives a nested sequence of active sets (one more polynomial per step); each set is refitted by
ordinary least squares and scored by its corrected leave-one-out error

    ``eps_LOO = mean((r_i / (1 - h_i))^2) / var(y) * T(P, N)``,
    ``T(P, N) = N / (N - P) * (1 + trace((A^T A / N)^-1) / N)``

(``r_i`` the OLS residuals, ``h_i`` the diagonal of the hat matrix, ``A (N, P)`` the active
basis at the N design points). The set of least error is kept.

The path's OLS refits share one incremental QR factorisation (Gram-Schmidt with
re-orthogonalisation, one column per step): residuals, hat diagonal and ``trace((A^T A)^-1) =
||R^-1||_F^2`` all update in ``O(N P)`` per step, so scoring the whole path costs about one QR
of the largest set.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

_DEGENERATE = 1e-10  # relative norm below which a new column adds nothing to the span


@dataclass
class SparseFit:
    """The selected sparse expansion of one output column.

    Attributes
    ----------
    terms : ndarray of int, shape (P,)
        Columns of the candidate basis kept (0, the constant, first).
    coef : ndarray, shape (P,)
        Their OLS coefficients.
    loo : float
        Corrected leave-one-out error (relative to the output's variance).
    """

    terms: np.ndarray
    coef: np.ndarray
    loo: float


def lars_order(psi: np.ndarray, y: np.ndarray, max_steps: int) -> np.ndarray:
    """Candidate columns (excluding the constant column 0) in LARS order of entry.

    LARS runs on the centred, unit-norm columns and the centred output, which is LARS with the
    constant always in the model.
    """
    x = psi[:, 1:] - psi[:, 1:].mean(axis=0)
    norms = np.linalg.norm(x, axis=0)
    usable = np.flatnonzero(norms > _DEGENERATE * np.sqrt(psi.shape[0]))
    if usable.size == 0 or max_steps < 1:
        return np.zeros(0, dtype=int)
    from sklearn.exceptions import ConvergenceWarning  # here: scikit-learn imports scipy.stats
    from sklearn.linear_model import lars_path

    with warnings.catch_warnings():
        # LARS stops early on degenerate or exhausted paths; the LOO score below decides anyway.
        warnings.simplefilter("ignore", ConvergenceWarning)
        # scikit-learn's LAR spends iterations without adding a variable when the design is
        # nearly degenerate (correlated polynomials on a small design): give it twice the steps
        # and keep the first ``max_steps`` variables to enter.
        _, active, _ = lars_path(x[:, usable] / norms[usable], y - y.mean(), method="lar",
                                 max_iter=2 * int(max_steps) + 10, return_path=False)
    return usable[np.asarray(active, dtype=int)[:max_steps]] + 1


def corrected_loo_path(psi: np.ndarray, y: np.ndarray, order: np.ndarray) -> SparseFit:
    """Score the nested sets ``{0} + order[:k]`` by corrected LOO; the best one refitted.

    Parameters
    ----------
    psi : ndarray, shape (N, P_cand)
        Candidate basis at the design points; column 0 is the constant.
    y : ndarray, shape (N,)
    order : ndarray of int
        Candidate columns in order of entry.
    """
    n = y.size
    var = y.var(ddof=1) if n > 1 else 0.0
    mean = y.mean()
    if var <= 0.0:
        return SparseFit(np.zeros(1, dtype=int), np.array([mean]), 0.0)
    kmax = min(order.size, n - 2)
    q = np.empty((n, kmax + 1))
    rinv = np.zeros((kmax + 1, kmax + 1))
    q[:, 0] = 1.0 / np.sqrt(n)
    rinv[0, 0] = 1.0 / np.sqrt(n)
    qty = np.empty(kmax + 1)
    qty[0] = q[:, 0] @ y
    resid = y - q[:, 0] * qty[0]
    hat = np.full(n, 1.0 / n)
    frob = rinv[0, 0] ** 2
    kept = [0]

    def score(p: int) -> float:
        return float(np.mean((resid / (1.0 - hat)) ** 2) / var * n / (n - p) * (1.0 + frob))

    best = (score(1), 1)
    j = 1
    for col in order[:kmax]:
        a = psi[:, col]
        r = q[:, :j].T @ a
        v = a - q[:, :j] @ r
        r2 = q[:, :j].T @ v  # second Gram-Schmidt pass keeps Q orthonormal to round-off
        v -= q[:, :j] @ r2
        r += r2
        rho = np.linalg.norm(v)
        if rho <= _DEGENERATE * np.linalg.norm(a):
            continue
        q[:, j] = v / rho
        rinv[:j, j] = -(rinv[:j, :j] @ r) / rho
        rinv[j, j] = 1.0 / rho
        frob += rinv[: j + 1, j] @ rinv[: j + 1, j]
        qty[j] = q[:, j] @ y
        resid -= q[:, j] * qty[j]
        hat += q[:, j] ** 2
        kept.append(int(col))
        j += 1
        p = j
        if np.any(hat >= 1.0 - 1e-10) or p >= n:
            break
        loo = score(p)
        if loo < best[0]:
            best = (loo, p)
    p = best[1]
    coef = rinv[:p, :p] @ qty[:p]
    return SparseFit(np.array(kept[:p], dtype=int), coef, float(best[0]))


def hybrid_lars(psi: np.ndarray, y: np.ndarray) -> SparseFit:
    """LARS order of the candidates, then the corrected-LOO-best nested set (module docstring)."""
    n, p_cand = psi.shape
    order = lars_order(psi, y, max_steps=min(p_cand - 1, n - 2))
    return corrected_loo_path(psi, y, order)
