"""A series output's adaptive PCE: principal components, one joint sparse fit, the rank.

``y (N, m)`` is decomposed (:func:`uqguide.pce.pca.decompose`); the candidate components are
fitted together on shared least-angle paths (:func:`uqguide.pce.joint_regression.fit_joint`);
the number kept is then chosen by the moments' rule (:mod:`uqguide.pce.pca_rank`), unless the
configuration fixes it by ``n_components`` or ``variance_fraction`` (those fit only what they
keep). The kept components' expansions are those of the joint fit: choosing after fitting
costs one fit, where growing the count and refitting cost one per step.

The joint path is a saving, not a gain in accuracy: with few runs each component's own path
serves it better (on the 30 runs of the ``ft_as_dispersion`` golden study the joint path's LOO
error was 0.15 where the column-by-column search's was 0.037), and a shared path stops at a
degree the slowest component allows: on issue 27's oscillator (2 inputs, 401 steps, 200 runs at
the adaptive PCE's default plan) it reached degree 6 and LOO 0.013, and printed kurtoses up to
53% off at 25 steps its validation runs could not refute, where the column-by-column search
reaches degree 37, LOO 0.0027 and no kurtosis 20% off (``tests/test_pce_support.py``, the
oscillator at defaults, a slow test). So the column-by-column search is used, as for scalar
outputs, wherever it costs at most :data:`COLUMNWISE_WORK` multiply-adds in all (``r N P min(N,
P)`` summed over the q-norms' candidate sets of ``P`` terms): accuracy first, the joint path
only where the search would take minutes.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from . import pca_rank
from .germ import Germ
from . import basis
from .joint_regression import fit_joint
from .pca import Components, decompose
from .sparse_regression import ColumnsFit, candidate_sets, fit_columns

log = logging.getLogger(__name__)

#: Work (multiply-adds) below which the components are searched column by column: about a
#: CPU-minute of least-angle steps (the 200-step, 500-run oscillator is 8e9).
COLUMNWISE_WORK = 1e11


@dataclass
class SeriesFit:
    """The kept components and their expansions.

    Attributes
    ----------
    components : Components
    fit : ColumnsFit
        Expansions of the kept components' scores (``r`` columns).
    rule : str
        How the count was chosen: ``"moments"``, ``"n_components"`` or ``"variance_fraction"``.
    """

    components: Components
    fit: ColumnsFit
    rule: str


def _keep(fit: ColumnsFit, r: int) -> ColumnsFit:
    """The first ``r`` columns of a joint fit, on the terms they use."""
    core = fit.core[:, :r]
    used = np.flatnonzero(np.any(core != 0.0, axis=1))
    used = np.union1d([0], used)
    return ColumnsFit(fit.alpha[used], core[used], fit.degree[:r], fit.q[:r], fit.loo[:r],
                      fit.n_terms[:r], fit.n_candidates)


def _columnwise_work(d: int, n: int, r: int, degree_min: int, degree_max: int | None,
                     q: float | None) -> float:
    _, sets = candidate_sets(d, n, degree_min, degree_max, q)
    return float(sum(r * n * cs.cols.size * min(n, cs.cols.size) for cs in sets))


def _loo_residuals(germ: Germ, xi: np.ndarray, y: np.ndarray, fit: ColumnsFit) -> np.ndarray:
    """Leave-one-out residuals ``(N, r)`` of each column's OLS fit on its own terms."""
    from scipy.linalg import qr

    psi = basis.evaluate(germ, fit.alpha, xi)
    out = np.zeros_like(y)
    for j in range(y.shape[1]):
        terms = np.union1d([0], np.flatnonzero(fit.core[:, j]))
        qm, _ = qr(psi[:, terms], mode="economic", check_finite=False)
        resid = y[:, j] - qm @ (qm.T @ y[:, j])
        with np.errstate(divide="ignore", invalid="ignore"):
            out[:, j] = resid / (1.0 - np.einsum("ij,ij->i", qm, qm))
    return np.where(np.isfinite(out), out, 0.0)


def fit_series(germ: Germ, xi: np.ndarray, y: np.ndarray, *, degree_min: int = 1,
               degree_max: int | None = None, q: float | None = None,
               variance_fraction: float | None = None, n_components: int | None = None
               ) -> SeriesFit:
    """Principal components of ``y (N, m)`` and their sparse PCEs (module docstring).

    Parameters
    ----------
    germ, xi, degree_min, degree_max, q
        As :func:`uqguide.pce.sparse_regression.fit_columns`.
    variance_fraction : float in (0, 1], optional
        Keep the fewest components that hold this fraction of the scaled variance.
    n_components : int, optional
        Keep this many components (at most all there are).
    """
    dec = decompose(y)
    if n_components is not None:
        r, rule = min(n_components, dec.size), "n_components"
    elif variance_fraction is not None:
        r, rule = dec.count_for_fraction(variance_fraction), "variance_fraction"
    else:
        r, rule = pca_rank.candidates(dec, y.shape[0]), "moments"
    comps = dec.components(r)
    if r == 0:
        empty = ColumnsFit(np.zeros((1, germ.dim), dtype=int), np.zeros((1, 0)),
                           np.zeros(0, dtype=int), np.zeros(0), np.zeros(0),
                           np.zeros(0, dtype=int))
        return SeriesFit(comps, empty, rule)
    if _columnwise_work(germ.dim, y.shape[0], r, degree_min, degree_max, q) <= COLUMNWISE_WORK:
        fit = fit_columns(germ, xi, comps.scores, degree_min=degree_min,
                          degree_max=degree_max, q=q)
        if rule != "moments":
            return SeriesFit(comps, fit, rule)
        loo_resid = _loo_residuals(germ, xi, comps.scores, fit)
    else:
        joint = fit_joint(germ, xi, comps.scores, degree_min=degree_min,
                          degree_max=degree_max, q=q)
        fit, loo_resid = joint.fit, joint.loo_resid
        if rule != "moments":
            return SeriesFit(comps, fit, rule)
    kept = pca_rank.choose(dec, y, loo_resid)
    log.debug("series: %d of %d candidate components kept by the moments' rule", kept, r)
    return SeriesFit(dec.components(kept), _keep(fit, kept), rule)
