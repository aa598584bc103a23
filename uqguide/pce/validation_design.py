"""Where a PCE's validation runs go: plain random (:func:`random_validation`), or stratified by
the surrogate's own value (:func:`stratified_validation`), each run weighted by
``ratio x share / runs`` of its stratum so that weighted means stay unbiased.

The algorithm step by step: docs/methods.md#the-validation-design-step-by-step; why the pool
leans to the faces, with the measured coverage:
docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from scipy.special import betaln

from .design import _U_EPS, VALIDATION_STREAM, stream

#: Upper edges of the strata as pool-rank fractions of the tail score (the last is 1).
STRATA = (0.5, 0.8, 0.95, 0.99, 0.999, 1.0)
#: Smallest number of runs a stratum gets (a within-stratum variance needs two).
MIN_PER_STRATUM = 2
#: Pool points per validation run, and the pool's bounds.
POOL_PER_RUN, POOL_MIN, POOL_MAX = 200, 20_000, 1_000_000
#: Pool points whose surrogate values standardise the score (a fixed, deterministic choice:
#: any score gives unbiased estimates; a good one gives short intervals).
SCALE_POINTS = 10_000
#: The most inputs the pool leans to the faces of (the arcsine density); with more curved
#: inputs the pool is uniform.
ARCSINE_INPUTS = 2


@dataclass(frozen=True)
class ValidationDesign:
    """The validation runs' inputs and how they were drawn.

    ``u (n, d)``: inputs on the open unit cube; ``weight (n,)``: ``r W_k / n_k`` (summing to 1:
    weighted sums estimate means over the input distribution); ``stratum (n,)``: 0 the bulk (all
    0 for a random design); ``share (K,)``: ``W_k``; ``pool``: size of the pool the strata were
    cut from (0: none); ``ratio (n,)``: importance ratio ``r`` from the pool's density to the
    input distribution (None: all 1); ``ratio_range (K, 2)``: least and largest ratio over each
    stratum's pool points, which bound the ratio-weighted mean of a bounded quantity
    (:mod:`uqguide.pce.tails`; None: all 1); ``sorter``: finds any point's stratum, for the fit
    runs' LOO floor (None for a random design).
    """

    u: np.ndarray
    weight: np.ndarray
    stratum: np.ndarray
    share: np.ndarray
    pool: int = 0
    ratio: np.ndarray | None = None
    ratio_range: np.ndarray | None = None
    sorter: StratumSorter | None = None

    @property
    def n(self) -> int:
        """Number of validation runs."""
        return int(self.u.shape[0])

    @property
    def stratified(self) -> bool:
        """Whether the runs were stratified (more than one stratum)."""
        return self.share.size > 1

    def to_data(self) -> dict[str, Any]:
        """The design as entries of a method's ``Design.data``."""
        data = {"u_validation": self.u, "w_validation": self.weight,
                "stratum_validation": self.stratum, "share_validation": self.share,
                "pool_validation": self.pool}
        if self.ratio is not None:
            data["ratio_validation"] = self.ratio
            data["ratio_range_validation"] = self.ratio_range
        if self.sorter is not None:
            data["sorter_validation"] = self.sorter
        return data

    def ratios(self) -> np.ndarray:
        """Each run's importance ratio, shape ``(n,)`` (ones for a uniform pool)."""
        return np.ones(self.n) if self.ratio is None else self.ratio

    def ratio_bounds(self) -> np.ndarray:
        """The least and largest pool ratio of each stratum, shape ``(K, 2)``."""
        if self.ratio_range is None:
            return np.ones((self.share.size, 2))
        return self.ratio_range

    @classmethod
    def from_data(cls, data: dict[str, Any]) -> ValidationDesign | None:
        """The design stored by :meth:`to_data` (None when there is none); a design with
        inputs alone is a random one."""
        u = data.get("u_validation")
        if u is None:
            return None
        if "w_validation" not in data:
            return random_design_of(np.asarray(u))
        return cls(u=np.asarray(u), weight=np.asarray(data["w_validation"], dtype=float),
                   stratum=np.asarray(data["stratum_validation"], dtype=int),
                   share=np.asarray(data["share_validation"], dtype=float),
                   pool=int(data.get("pool_validation", 0)),
                   ratio=_optional(data.get("ratio_validation")),
                   ratio_range=_optional(data.get("ratio_range_validation")),
                   sorter=data.get("sorter_validation"))

    def successful(self, ok: np.ndarray) -> ValidationDesign:
        """The design restricted to the runs that succeeded, weights renormalised within each
        stratum; a stratum left with no successful run gives its share to the next one towards
        the bulk (a bias only as large as that share)."""
        ok = np.asarray(ok, dtype=bool)
        stratum = self.stratum[ok]
        share = self.share.copy()
        counts = np.bincount(stratum, minlength=share.size)
        for k in range(share.size - 1, 0, -1):
            if counts[k] == 0:
                share[k - 1] += share[k]
                share[k] = 0.0
        if counts[0] == 0 and share.size > 1:
            k = int(np.flatnonzero(counts)[0]) if counts.any() else 0
            share[k] += share[0]
            share[0] = 0.0 if k else share[0]
        ratio = None if self.ratio is None else self.ratio[ok]
        with np.errstate(divide="ignore", invalid="ignore"):
            w = np.where(counts[stratum] > 0, share[stratum] / np.maximum(counts[stratum], 1),
                         0.0)
        if ratio is not None:
            w = w * ratio
        return ValidationDesign(u=self.u[ok], weight=w, stratum=stratum, share=share,
                                pool=self.pool, ratio=ratio, ratio_range=self.ratio_range,
                                sorter=None if (share != self.share).any() else self.sorter)

    def conditional(self, ok: np.ndarray) -> ValidationDesign:
        """The design restricted to the runs that succeeded, weighted to estimate means
        conditional on success: each run keeps its weight, renormalised over all the
        successful runs, so a stratum's share shrinks with its failed runs (where
        :meth:`successful` keeps every stratum's share, the mean over the whole input space
        of each stratum's successful runs)."""
        ok = np.asarray(ok, dtype=bool)
        stratum = self.stratum[ok]
        w = self.weight[ok] / np.sum(self.weight[ok])
        share = np.bincount(stratum, weights=w, minlength=self.share.size)
        return ValidationDesign(u=self.u[ok], weight=w, stratum=stratum, share=share,
                                pool=self.pool,
                                ratio=None if self.ratio is None else self.ratio[ok],
                                ratio_range=self.ratio_range, sorter=None)


@dataclass(frozen=True)
class StratumSorter:
    """Which stratum of a stratified design any point falls in, and its importance ratio (for
    the fit runs in :func:`uqguide.pce.validation.stratified_se`).

    ``scale``: the tail score's column means and stds per output (:func:`tail_score`);
    ``edges (K - 1,)``: scores at the strata's upper rank edges in the pool (a point of score
    ``z`` is in the first stratum whose edge is at least ``z``); ``curved (d,)``: inputs the pool
    leaned to the faces in (None: uniform pool); ``input_share (K,)``: each stratum's
    probability under the input distribution, ``E_q[r 1_k]`` over the pool.
    """

    scale: dict[str, tuple[np.ndarray, np.ndarray]]
    edges: np.ndarray
    curved: np.ndarray | None
    input_share: np.ndarray

    def strata(self, values: dict[str, np.ndarray]) -> np.ndarray:
        """Strata ``(n,)`` of points whose surrogate values per output are ``values``."""
        score = tail_score({k: values[k] for k in self.scale}, self.scale)
        return np.searchsorted(self.edges, score, side="left")

    def ratios(self, u: np.ndarray) -> np.ndarray:
        """Importance ratios ``1 / q(u)``, shape ``(n,)``, of unit-cube points ``u (n, d)``."""
        if self.curved is None:
            return np.ones(u.shape[0])
        return np.exp(-pool_log_density(np.clip(u, _U_EPS, 1 - _U_EPS), self.curved))


def _optional(v: Any) -> np.ndarray | None:
    return None if v is None else np.asarray(v, dtype=float)


def random_design_of(u: np.ndarray) -> ValidationDesign:
    """``u (n, d)`` as a plain random design: one stratum, weights ``1 / n``."""
    n = u.shape[0]
    return ValidationDesign(u=u, weight=np.full(n, 1.0 / max(n, 1)),
                            stratum=np.zeros(n, dtype=int), share=np.ones(1))


def random_validation(seed: int, label: str, n: int, d: int) -> ValidationDesign:
    """``n`` independent uniform points from the method's validation stream (keyed by its
    label), away from the cube's faces."""
    rng = np.random.default_rng(stream(seed, label, VALIDATION_STREAM))
    return random_design_of(np.clip(rng.random((n, d)), _U_EPS, 1 - _U_EPS))


def strata_edges(n: int) -> tuple[float, ...]:
    """The strata's upper rank edges for ``n`` runs: :data:`STRATA`, with the outermost merged
    until every stratum can have :data:`MIN_PER_STRATUM` runs."""
    k = max(1, min(len(STRATA), n // MIN_PER_STRATUM))
    return STRATA[:k - 1] + (1.0,)


def neyman_allocation(share: np.ndarray, spread: np.ndarray, n: int) -> np.ndarray:
    """Runs per stratum: ``n_k`` proportional to ``share_k spread_k``, at least
    :data:`MIN_PER_STRATUM`, summing to ``n`` (largest remainders)."""
    k = share.size
    want = share * np.maximum(spread, 1e-300)
    alloc = np.full(k, MIN_PER_STRATUM)
    free = n - alloc.sum()
    if free > 0:
        ideal = free * want / want.sum()
        extra = np.floor(ideal).astype(int)
        rest = free - extra.sum()
        extra[np.argsort(-(ideal - extra), kind="stable")[:rest]] += 1
        alloc = alloc + extra
    return alloc


def tail_score(values: dict[str, np.ndarray], scale: dict[str, tuple[np.ndarray, np.ndarray]]
               ) -> np.ndarray:
    """``max_j |s_j - m_j| / sd_j`` ``(m,)`` over every column of every output's surrogate
    values ``(m, ...)``; ``scale`` leaves out columns that do not vary."""
    score: np.ndarray | None = None
    for name, v in values.items():
        m, sd = scale[name]
        v = v.reshape(v.shape[0], -1)
        live = sd.reshape(-1) > 0
        if not live.any():
            continue
        z = np.abs(v[:, live] - m.reshape(-1)[live]) / sd.reshape(-1)[live]
        zmax = z.max(axis=1)
        score = zmax if score is None else np.maximum(score, zmax)
    if score is None:
        any_v = next(iter(values.values()))
        return np.zeros(any_v.shape[0])
    return score


def stratified_validation(surrogate: Callable[[np.ndarray], dict[str, np.ndarray]], seed: int,
                          label: str, n: int, d: int, *, chunk: int = 10_000,
                          curved: np.ndarray | None = None) -> ValidationDesign:
    """``n`` validation points stratified by the surrogate's tail score.

    ``surrogate``: ``f(u (m, d)) -> {output: values (m, ...)}`` on the unit cube; ``seed`` and
    ``label`` key the validation stream; ``chunk``: pool points evaluated at a time (bounds the
    memory of long series); ``curved (d,)``: inputs the pool leans to the faces in
    (:func:`curved_inputs`; default all).
    """
    edges = strata_edges(n)
    if len(edges) == 1:
        return random_validation(seed, label, n, d)
    pool = int(min(POOL_MAX, max(POOL_MIN, POOL_PER_RUN * n)))
    rng = np.random.default_rng(stream(seed, label, VALIDATION_STREAM))
    u, ratio = pool_points(rng, pool, d, curved)
    first = surrogate(u[:min(SCALE_POINTS, pool)])
    scale = {k: (v.mean(axis=0), v.std(axis=0)) for k, v in first.items()}
    score = np.concatenate([tail_score(first, scale)] + [
        tail_score(surrogate(u[a:a + chunk]), scale)
        for a in range(SCALE_POINTS, pool, chunk)])
    order = np.argsort(score, kind="stable")
    bounds = np.concatenate([[0], np.round(np.asarray(edges) * pool).astype(int)])
    members = [order[bounds[k]:bounds[k + 1]] for k in range(len(edges))]
    share = np.array([m.size / pool for m in members])
    spread = np.array([np.sqrt(np.mean((ratio[m] * (1.0 + score[m] ** 3)) ** 2))
                       for m in members])
    alloc = np.minimum(neyman_allocation(share, spread, n), [m.size for m in members])
    picks = [np.sort(rng.choice(m, size=a, replace=False)) for m, a in zip(members, alloc)]
    rows = np.concatenate(picks)
    stratum = np.concatenate([np.full(a, k) for k, a in enumerate(alloc)])
    weight = np.concatenate([np.full(a, share[k] / a) for k, a in enumerate(alloc)])
    uniform = bool(np.all(ratio == 1.0))
    sorter = StratumSorter(
        scale=scale, edges=np.array([score[order[b - 1]] for b in bounds[1:-1]]),
        curved=None if uniform else _curved_mask(curved, d),
        input_share=share if uniform else np.array([ratio[m].sum() / pool for m in members]))
    if uniform:  # a uniform pool: plain stratified sampling
        return ValidationDesign(u=u[rows], weight=weight, stratum=stratum, share=share,
                                pool=pool, sorter=sorter)
    bounds_r = np.array([[ratio[m].min(), ratio[m].max()] for m in members])
    return ValidationDesign(u=u[rows], weight=weight * ratio[rows], stratum=stratum,
                            share=share, pool=pool, ratio=ratio[rows], ratio_range=bounds_r,
                            sorter=sorter)


def ratio_moment() -> float:
    """``E_q[r^2]`` per leaning input: ``B(1/2, 1/2) B(3/2, 3/2) = pi^2 / 8``."""
    return float(np.exp(betaln(0.5, 0.5) + betaln(1.5, 1.5)))


def pool_points(rng: np.random.Generator, m: int, d: int, curved: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """``m`` pool points ``(m, d)``, away from the cube's faces, and their importance ratios
    ``1 / q(u)``, shape ``(m,)``: the arcsine density ``Beta(1/2, 1/2)`` in the ``curved``
    inputs (all by default) when there are at most :data:`ARCSINE_INPUTS` of them, uniform
    elsewhere and otherwise."""
    curved = _curved_mask(curved, d)
    k = int(curved.sum())
    if k == 0 or k > ARCSINE_INPUTS:
        return np.clip(rng.random((m, d)), _U_EPS, 1 - _U_EPS), np.ones(m)
    u = np.empty((m, d))
    u[:, curved] = rng.beta(0.5, 0.5, size=(m, k))
    u[:, ~curved] = rng.random((m, d - k))
    u = np.clip(u, _U_EPS, 1 - _U_EPS)
    return u, np.exp(-pool_log_density(u, curved))


def _curved_mask(curved: np.ndarray | None, d: int) -> np.ndarray:
    return np.ones(d, dtype=bool) if curved is None else np.asarray(curved, dtype=bool)


def pool_log_density(u: np.ndarray, curved: np.ndarray) -> np.ndarray:
    """The log of the arcsine pool's density ``q(u)``, shape ``(n,)``, at points ``u (n, d)``
    inside the cube: ``Beta(1/2, 1/2)`` in the ``curved`` inputs, uniform in the others."""
    uc = u[:, curved]
    k = int(curved.sum())
    return -0.5 * (np.log(uc) + np.log1p(-uc)).sum(axis=1) - k * betaln(0.5, 0.5)


def curved_inputs(alphas: list[np.ndarray], d: int) -> np.ndarray:
    """The inputs in which a surrogate is curved: some retained term of the expansions'
    multi-indices ``alphas`` (each ``(P, d)``) has degree 2 or more in that input. Shape
    ``(d,)``; all True when no expansion is given (nothing known: the safe side)."""
    if not alphas:
        return np.ones(d, dtype=bool)
    return np.any([a.max(axis=0, initial=0) >= 2 for a in alphas], axis=0)
