"""Sparse regression of output columns on a candidate basis chosen from the data.

Per output column, the expansion of least corrected leave-one-out error over hyperbolic
candidate sets ``||alpha||_q <= p`` (the q-norms :data:`Q_GRID` or the config's, every degree
whose set has at most :func:`candidate_cap` terms, or up to ``degree_max``); :func:`select` is
the rule. :func:`fit_columns` is the entry point; ``joint=True`` shares one path per q-norm.

The grid, the rule and how the search stays cheap:
docs/methods.md#sparse-regression-the-candidate-grid-lars-and-leave-one-out.
"""
from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits

from . import basis
from .germ import Germ
from .lars import LarsBasis, LarsPath
from .loo import LooPath, SparseFit, score_path
from .pca import constant_columns

log = logging.getLogger(__name__)

#: q-norms tried when the configuration does not fix one.
Q_GRID = (0.5, 0.75, 1.0)
#: Highest degree tried when the configuration does not fix one.
MAX_DEGREE = 40
#: Largest candidate set the default (data-driven) grid builds.
CANDIDATES_CAP = 3000
#: Largest candidate set (terms) whatever the runs; bounds the basis matrix's memory.
MAX_CANDIDATES = 20_000
#: Terms past twice the best set's size a corrected-LOO path goes on scoring.
PATIENCE = 20
_FIRST_STEPS = 64  # LARS steps scored first
#: LARS steps every q-norm gets before only the close rivals of the best go on.
FIRST_PASS = 256
#: A degree whose path was cut short gets its own LARS when its error is within this factor
#: of the best degree's.
RIVAL = 10.0
#: Work (multiply-adds) of a degree's own LARS that is always affordable.
OWN_LARS_WORK = 1e8
#: A degree whose shared-path error is within this factor of the least gets its own LARS
#: wherever that is cheap (:meth:`_QSearch.own_lars`).
CLOSE = 2.0
#: Degrees per q-norm scored directly; more are searched on a coarse grid, then refined.
FULL_DEGREES = 5


def candidate_cap(n_runs: int) -> int:
    """Largest candidate set for ``n_runs`` runs: ``5 n_runs`` terms, between 100 and
    :data:`CANDIDATES_CAP` (docs/pce.md#the-candidate-cap)."""
    return int(min(CANDIDATES_CAP, max(100, 5 * n_runs)))


@dataclass
class ColumnsFit:
    """Sparse expansions of several columns on one shared multi-index set.

    ``alpha (P, d)``: union of the columns' retained terms, constant first; ``core (P, r)``: zero
    where a column does not use a term; per column ``(r,)``: selected ``degree``, ``q``-norm,
    corrected ``loo`` error (relative to its variance; 0 for a constant) and ``n_terms``
    (constant included); ``n_candidates``: size of the candidate basis; ``loo_resid (N, r)``:
    LOO residuals ``y_i - y_hat_(-i)`` kept by the shared-path search (None from the
    column-by-column search: :func:`uqguide.pce.loo.loo_residuals` computes them).
    """

    alpha: np.ndarray
    core: np.ndarray
    degree: np.ndarray
    q: np.ndarray
    loo: np.ndarray
    n_terms: np.ndarray
    n_candidates: int = 0
    loo_resid: np.ndarray | None = None


def q_norms(alpha: np.ndarray, q: float) -> np.ndarray:
    """``||alpha||_q`` of each multi-index ``(P,)``."""
    return (alpha.astype(float) ** q).sum(axis=1) ** (1.0 / q)


def top_degree(d: int, q: float, cap: int, degree_min: int, degree_max: int | None) -> int:
    """Largest degree in ``[degree_min, degree_max or MAX_DEGREE]`` whose set has <= ``cap``
    terms (``degree_min`` at least)."""
    hi = MAX_DEGREE if degree_max is None else degree_max
    p = degree_min
    while p < hi and basis.hyperbolic_indices(d, p + 1, q).shape[0] <= cap:
        p += 1
    return p


@dataclass
class Candidates:
    """One q-norm's candidate set: columns of the evaluated basis and their q-norms."""

    q: float
    top: int
    cols: np.ndarray
    norms: np.ndarray

    def of_degree(self, p: int) -> np.ndarray:
        """Which candidates degree ``p``'s set holds (a mask)."""
        return self.norms <= p * (1 + 1e-12)

    def count(self, p: int) -> int:
        """The size of degree ``p``'s set."""
        return int(np.count_nonzero(self.of_degree(p)))

    def restrict(self, order: np.ndarray, p: int) -> np.ndarray:
        """A LARS order (positions in the set) restricted to degree ``p``'s candidates."""
        return order[self.of_degree(p)[order]]


class Scored(NamedTuple):
    """One (q-norm, degree)'s best fit of a column: its error, its candidate set's size, the
    fit (terms as columns of the evaluated basis), the q-norm, the degree and, from the
    shared-path search, the fit's leave-one-out residuals."""

    loo: float
    size: int
    fit: SparseFit
    q: float
    degree: int
    resid: np.ndarray | None = None


def scored(cs: Candidates, p: int, fit: SparseFit, resid: np.ndarray | None = None) -> Scored:
    """``fit`` (terms as positions in ``cs``) of degree ``p`` as a :class:`Scored`."""
    return Scored(fit.loo, cs.count(p), SparseFit(cs.cols[fit.terms], fit.coef, fit.loo,
                                                  fit.loo_se), cs.q, p, resid)


def select(candidates: list[Scored]) -> Scored:
    """The selection rule: among the fits within 1% of the least error, the one of the smallest
    candidate set (then of least error, then the first)."""
    least = min(s.loo for s in candidates)
    near = [s for s in candidates if s.loo <= least * 1.01 or s.loo == least]
    return min(near, key=lambda s: (s.size, s.loo))


class _SharedBasis:
    """One q-norm's candidate basis prepared once for LARS (:class:`LarsBasis`), and the
    smaller degrees' own sets when they need a LARS of their own: shared by every output
    column fitted together (the principal components of a series, the entries of a vector)."""

    def __init__(self, psi: np.ndarray, cs: Candidates) -> None:
        self.cs = cs
        self.top = LarsBasis(psi[:, cs.cols])
        self._own: dict[int, tuple[np.ndarray, LarsBasis]] = {}

    def own(self, p: int) -> tuple[np.ndarray, LarsBasis]:
        """Degree ``p``'s candidates (positions in the q-norm's set) and their basis."""
        if p not in self._own:
            own = np.flatnonzero(self.cs.of_degree(p))
            self._own[p] = (own, LarsBasis(self.top.psi[:, own]))
        return self._own[p]


def candidate_sets(d: int, n_runs: int, degree_min: int, degree_max: int | None,
                    q: float | None) -> tuple[np.ndarray, list[Candidates]]:
    """The union of the q-norms' largest candidate sets (constant first), and each set in it."""
    cap = candidate_cap(n_runs) if degree_max is None else MAX_CANDIDATES
    sets = []
    for qq in (Q_GRID if q is None else (q,)):
        top = top_degree(d, qq, cap, degree_min, degree_max)
        if degree_max is not None and top < degree_max:
            log.warning("adaptive PCE: candidate basis (q = %g) capped at degree %d of the "
                        "requested %d", qq, top, degree_max)
        sets.append((qq, top, basis.hyperbolic_indices(d, top, qq)))
    union = basis.graded(np.unique(np.concatenate([s[2] for s in sets]), axis=0))
    lookup = basis.index_lookup(union)
    out = [Candidates(qq, top, np.array([lookup[tuple(int(v) for v in a)] for a in al]),
                       q_norms(al, qq)) for qq, top, al in sets]
    return union, out


def degree_grid(lo: int, hi: int) -> list[int]:
    """Degrees scored in ``[lo, hi]``: all of them up to :data:`FULL_DEGREES`, else a coarse grid
    of that many (both ends included), refined around the best afterwards."""
    if hi - lo + 1 <= FULL_DEGREES:
        return list(range(lo, hi + 1))
    return sorted({int(round(v)) for v in np.linspace(lo, hi, FULL_DEGREES)})


class _QSearch:
    """The degree search of one q-norm for one column: a LARS path on the q-norm's largest set,
    scored at every degree of the grid by restricting it to the degree's candidates."""

    def __init__(self, shared: _SharedBasis, y: np.ndarray, degree_min: int):
        cs = shared.cs
        self.shared, self.y, self.cs, self.degree_min = shared, y, cs, degree_min
        self.n = y.size
        self.sub = shared.top.psi
        self.limit = min(cs.cols.size - 1, self.n - 2)
        self.lars = LarsPath(shared.top, y)
        self.steps = 0
        self.fits: dict[int, SparseFit] = {}
        self.lengths: dict[int, int] = {}
        # Each degree's path only grows as LARS goes on: its scores are extended, not redone.
        self.paths: dict[int, LooPath] = {}

    def _path_fit(self, p: int, path: np.ndarray, hint: int) -> SparseFit:
        if p not in self.paths:
            self.paths[p] = LooPath(self.sub, self.y)
        return score_path(self.sub, self.y, path, patience=PATIENCE, hint=hint,
                          state=self.paths[p]).fit()

    @property
    def best(self) -> float:
        return min(f.loo for f in self.fits.values())

    def unfinished(self, p: int) -> bool:
        """Whether degree ``p``'s path (the LARS order restricted to its candidates, shorter
        than the order) ran out while still improving: its best set near its end, candidates
        left."""
        return (self.lengths[p] < min(self.cs.count(p) - 1, self.n - 2)
                and 3 * self.fits[p].terms.size // 2 + PATIENCE > self.lengths[p])

    def run(self, max_steps: int) -> None:
        """Advance LARS (doubling its steps, up to ``max_steps``) while the best degree's path
        is unfinished, and score the grid at each length."""
        steps = min(self.limit, max(self.steps, _FIRST_STEPS))
        while True:
            self._score(steps)
            p_best = min(self.fits, key=lambda p: self.fits[p].loo)
            if (steps >= min(self.limit, max_steps) or self.lars.done
                    or not self.unfinished(p_best)):
                break
            want = 3 * self.fits[p_best].terms.size // 2 + PATIENCE + 1
            steps = min(self.limit, max_steps, max(steps + steps // 2, want))
        # Every degree still cut short is scored once more on the final order (the longer
        # orders above rescored only the best degree and its neighbours).
        order = self.lars.order(self.steps)
        for p in [p for p in self.fits if self.unfinished(p)]:
            self._rescore(p, order)

    def _rescore(self, p: int, order: np.ndarray) -> None:
        path = self.cs.restrict(order, p)
        if path.size > self.lengths[p]:
            self.fits[p] = self._path_fit(p, path, self.fits[p].terms.size)
            self.lengths[p] = path.size

    def _score(self, steps: int) -> None:
        """Score the degree grid on the first ``steps`` of the LARS order; once the grid has
        been scored, longer orders rescore only the best degree and its neighbours."""
        if steps == self.steps:
            return
        self.steps = steps
        order = self.lars.order(steps)
        cs = self.cs
        if self.fits:
            p_best = min(self.fits, key=lambda p: self.fits[p].loo)
            for p in (p_best - 1, p_best, p_best + 1):
                if p in self.fits:
                    self._rescore(p, order)
            return
        fits: dict[int, SparseFit] = {}
        lengths: dict[int, int] = {}

        def score(p: int) -> None:
            if p not in fits and self.degree_min <= p <= cs.top:
                path = cs.restrict(order, p)
                hint = max((f.terms.size for f in fits.values()), default=0)
                fits[p] = self._path_fit(p, path, hint)
                lengths[p] = path.size

        for p in degree_grid(self.degree_min, cs.top):
            score(p)
        coarse = sorted(fits)
        i = min(range(len(coarse)), key=lambda k: fits[coarse[k]].loo)
        for p in range(coarse[max(i - 1, 0)] + 1, coarse[min(i + 1, len(coarse) - 1)]):
            score(p)
        self.fits, self.lengths = fits, lengths

    def own_lars(self, least: float) -> None:
        """Give a degree a LARS of its own where its error is within :data:`CLOSE` of ``least`` and
        that costs at most :data:`OWN_LARS_WORK`, or within :data:`RIVAL` with its path cut short
        and its LARS cheap or its set at most half the largest (docs/pce.md#a-degrees-own-lars)."""
        def wanted(p: int) -> bool:
            c, loo = self.cs.count(p), self.fits[p].loo
            if c >= self.cs.cols.size or loo > RIVAL * least:
                return False  # the largest set's own LARS is the shared path
            cheap = self.n * c * min(c, self.n) <= OWN_LARS_WORK
            if cheap and loo <= CLOSE * least:
                return True
            return self.unfinished(p) and (cheap or 2 * c <= self.cs.cols.size)

        for p in [p for p in self.fits if wanted(p)]:
            own, lb = self.shared.own(p)
            fit = score_path(lb.psi, self.y, LarsPath(lb, self.y), patience=PATIENCE,
                             hint=self.fits[p].terms.size).fit()
            if fit.loo < self.fits[p].loo:
                self.fits[p] = SparseFit(own[fit.terms], fit.coef, fit.loo, fit.loo_se)


def _column_scores(shared: list[_SharedBasis], y: np.ndarray, degree_min: int) -> list[Scored]:
    """Every (q, degree) fit of one column the search scored, for :func:`select`: each
    q-norm's LARS runs :data:`FIRST_PASS` steps, then only those within :data:`RIVAL` of the
    best go on to the runs' limit."""
    searches = [_QSearch(sb, y, degree_min) for sb in shared]
    for qs in searches:
        qs.run(FIRST_PASS)
    least = min(qs.best for qs in searches)
    for qs in searches:
        if qs.best <= RIVAL * least:
            qs.run(y.size)
    least = min(qs.best for qs in searches)
    for qs in searches:
        qs.own_lars(least)
    return [scored(qs.cs, p, fit) for qs in searches for p, fit in qs.fits.items()]


def _joint_search(sb: _SharedBasis, y: np.ndarray, degree_min: int) -> dict[int, LooPath]:
    """One q-norm's multiresponse path for all the columns of ``y (N, r)``, scored at the
    degrees of the grid and refined around every column's best degree, coarse to fine."""
    cs, lb = sb.cs, sb.top
    n, r = y.shape
    order = LarsPath(lb, y).order(min(cs.cols.size - 1, n - 2))
    paths: dict[int, LooPath] = {}

    def score(p: int) -> None:
        if p not in paths and degree_min <= p <= cs.top:
            paths[p] = score_path(lb.psi, y, cs.restrict(order, p), PATIENCE)

    for p in degree_grid(degree_min, cs.top):
        score(p)
    # At most five more degrees per level, not every degree between the neighbours (with
    # many components, their best degrees spread over the grid).
    for j in range(r):
        lo, hi = degree_min, cs.top
        while True:
            done = sorted(p for p in paths if lo <= p <= hi)
            i = min(range(len(done)), key=lambda k: paths[done[k]].best_loo[j])
            lo, hi = done[max(i - 1, 0)], done[min(i + 1, len(done) - 1)]
            if hi - lo <= 2 or all(p in paths for p in range(lo + 1, hi)):
                for p in range(lo + 1, hi):
                    score(p)
                break
            for p in degree_grid(lo + 1, hi - 1):
                score(p)
    return paths


def fit_columns(germ: Germ, xi: np.ndarray, y: np.ndarray, *, degree_min: int = 1,
                degree_max: int | None = None, q: float | None = None,
                joint: bool = False) -> ColumnsFit:
    """Sparse PCE of every column of ``y (N, r)`` at design points ``xi (N, d)``.

    ``degree_max`` None: the largest the runs support; ``q`` None: the best of :data:`Q_GRID`.
    ``joint``: one least-angle path per q-norm shared by all columns (each still takes its own
    q-norm, degree and terms; the fit keeps its LOO residuals); no column may then be constant.
    """
    # One BLAS thread: threads do not speed up this matrix-vector work, and a threaded
    # reduction's round-off would depend on the thread count (docs/pce.md#one-blas-thread).
    with threadpool_limits(limits=1, user_api="blas"):
        union, sets = candidate_sets(germ.dim, xi.shape[0], degree_min, degree_max, q)
        psi = basis.evaluate(germ, union, xi)
        shared = [_SharedBasis(psi, cs) for cs in sets]
        del psi  # each q-norm's set keeps its own copy, laid out for LARS
        r = y.shape[1]
        if not joint:
            constant = constant_columns(y)
            return _chosen_fit(union, [None if constant[c] else
                                       select(_column_scores(shared, y[:, c], degree_min))
                                       for c in range(r)], y)
        scores: list[list[Scored]] = [[] for _ in range(r)]
        for sb in shared:
            for p, path in _joint_search(sb, y, degree_min).items():
                for j in range(r):
                    scores[j].append(scored(sb.cs, p, path.fit(column=j),
                                            path.best_resid[:, j].copy()))
        chosen = [select(s) for s in scores]
        fit = _chosen_fit(union, chosen, y)
        fit.loo_resid = np.zeros(y.shape)
        for j, c in enumerate(chosen):
            fit.loo_resid[:, j] = c.resid
        return fit


def _chosen_fit(union: np.ndarray, chosen: Sequence[Scored | None], y: np.ndarray
                ) -> ColumnsFit:
    """The columns' chosen fits (None: all the column's runs agree, the constant exactly) on
    the union of the terms they use (rows of ``union``), constant first."""
    r = len(chosen)
    fits, degree, qs, loo = [], np.zeros(r, dtype=int), np.zeros(r), np.zeros(r)
    for c, pick in enumerate(chosen):
        if pick is None:  # no variance to regress on
            fits.append(SparseFit(np.zeros(1, dtype=int), y[:1, c].copy(), 0.0))
            continue
        fits.append(pick.fit)
        qs[c], degree[c], loo[c] = pick.q, pick.degree, pick.fit.loo
    used = np.unique(np.concatenate([[0]] + [f.terms for f in fits]))
    pos = {t: i for i, t in enumerate(used)}
    core = np.zeros((used.size, len(fits)))
    for c, f in enumerate(fits):
        core[[pos[t] for t in f.terms], c] = f.coef
    n_terms = np.array([f.terms.size for f in fits], dtype=int)
    return ColumnsFit(union[used], core, degree, qs, loo, n_terms, int(union.shape[0]))
