"""The surrogate's leave-one-out values at its own fit runs: a second sample of its errors.

Each fit run is predicted by the expansion's retained terms refitted without it (the closed form
``e_i = r_i / (1 - h_i)`` of least squares; the selection of terms held fixed), a series through
its components' scores mapped back (:func:`loo_values`). A validation set may miss the few places
a sparse PCE errs most; these out-of-sample errors of the same expansion floor the variance the
validation runs give (:func:`uqguide.pce.validation.stratified_se`), never move the estimate.

Why, with the cases that needed it:
docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import qr

from . import basis
from .expansion import Expansion


def loo_values(expansion: Expansion, xi: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """Leave-one-out surrogate values ``(N, m)`` at the fit runs.

    Parameters
    ----------
    expansion : Expansion
        The fitted expansion; each column of its core is an OLS fit on its own non-zero terms.
    xi : ndarray, shape (N, d)
        The fit runs' germ points.
    targets : ndarray, shape (N, r')
        What the core's columns were fitted to (a scalar's components, a series' scores); a
        core column beyond them (a series' mean row) is not fitted and has no residual.

    Returns
    -------
    ndarray, shape (N, m)
        ``expansion.evaluate(xi)`` with every fitted column's value replaced by its
        leave-one-out prediction. A run of leverage 1 (its own term) keeps its fitted value.
    """
    psi = basis.evaluate(expansion.germ, expansion.alpha, xi)
    fitted = psi @ expansion.core
    shift = np.zeros_like(fitted)
    for j in range(min(targets.shape[1], expansion.core.shape[1])):
        terms = np.union1d([0], np.flatnonzero(expansion.core[:, j]))
        if terms.size >= xi.shape[0]:
            continue
        qm, _ = qr(psi[:, terms], mode="economic", check_finite=False)
        resid = targets[:, j] - fitted[:, j]
        hat = np.einsum("ij,ij->i", qm, qm)
        with np.errstate(divide="ignore", invalid="ignore"):
            # fitted - loo prediction = r h / (1 - h)
            move = resid * hat / (1.0 - hat)
        shift[:, j] = np.where(np.isfinite(move) & (hat < 1.0 - 1e-10), move, 0.0)
    return expansion.mixed(fitted - shift)


@dataclass(frozen=True)
class FitRuns:
    """The fit runs as a second sample of the model-minus-surrogate differences.

    Attributes
    ----------
    y : ndarray, shape (N, ...)
        The model's values at the successful fit runs.
    s_loo : ndarray, shape (N, ...)
        The surrogate's leave-one-out values there (:mod:`uqguide.pce.loo_values`).
    stratum : ndarray of int, shape (N,)
        Each run's stratum of the validation design.
    ratio : ndarray, shape (N,)
        Each run's importance ratio to the validation pool's density.
    input_share : ndarray, shape (K,)
        Each stratum's probability under the input distribution.
    """

    y: np.ndarray
    s_loo: np.ndarray
    stratum: np.ndarray
    ratio: np.ndarray
    input_share: np.ndarray


@dataclass(frozen=True)
class FitFloor:
    """A statistic's per-run values at the fit runs (:func:`stratified_se`'s floor).

    Attributes
    ----------
    influence : ndarray, shape (N, m)
        The values, from the surrogate's leave-one-out predictions at the fit runs.
    stratum : ndarray of int, shape (N,)
        Each fit run's stratum of the validation design.
    ratio : ndarray, shape (N,)
        Each fit run's importance ratio ``1 / q(u)`` to the validation pool's density.
    input_share : ndarray, shape (K,)
        Each stratum's probability under the input distribution (the fit runs' own).
    """

    influence: np.ndarray
    stratum: np.ndarray
    ratio: np.ndarray
    input_share: np.ndarray

    def variance(self, k: int, share: float) -> np.ndarray:
        """``Var_q(r f | k)`` from the fit runs in stratum ``k`` (``share``: its pool
        probability ``Q_k``); 0 with fewer than two of them.

        The fit runs are draws of the input distribution ``p``: with ``c = P_k / Q_k``,
        ``E_q[r^2 f^2 | k] = c E_p[r f^2 | k]`` and ``E_q[r f | k] = c E_p[f | k]``.
        """
        rows = self.stratum == k
        nk = int(rows.sum())
        if nk < 2 or share <= 0:
            return np.zeros(self.influence.shape[1])
        f, r = self.influence[rows], self.ratio[rows]
        c = self.input_share[k] / share
        v = c * np.mean(r[:, None] * f * f, axis=0) - (c * f.mean(axis=0)) ** 2
        return np.maximum(v, 0.0) * nk / (nk - 1)
