"""Derived outputs: non-smooth functions of smooth outputs, through the surrogate.

A PCE method fits the carriers, draws their surrogates jointly and applies the map to every draw
(:func:`map_derived`, :func:`derived_statistics`): :data:`REPLICATES` scrambled Sobol' sequences,
whose spread gives the standard error. No Sobol' indices; non-finite draws are left out.

Why, and the measured gain of the replicates: docs/methods.md#derived-outputs.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

import numpy as np

from ..core.types import STAT_NAMES, DerivedOutput, OutputStats
from ..stats.moments import shape_moments
from .design import surrogate_draws
from .expansion import Expansion
from .germ import Germ
from .moments import central_from_raw

_CHUNK_FLOATS = 2**22  # draws per chunk x values per draw: about 32 MB per array
#: Independently scrambled Sobol' sequences behind a derived output's moments (their spread
#: is the sampling error: 16 gives it to within about 18%).
REPLICATES = 16


@dataclass
class _Sums:
    """Shifted power sums of one output's draws (shift: the first chunk's mean)."""

    shift: np.ndarray
    s: list[np.ndarray]
    cross: np.ndarray
    n: int = 0


def derived_statistics(
    germ: Germ, expansions: Mapping[str, Expansion], derived: Mapping[str, DerivedOutput], *,
    scalar_order: list[str], n_draws: int, seed: int | np.random.SeedSequence, n_runs: int,
    sampling: str = "random",
) -> tuple[dict[str, OutputStats], tuple[np.ndarray, np.ndarray] | None, int]:
    """Statistics of the derived outputs by sampling their carriers' surrogates.

    ``scalar_order`` names the scalar outputs (fitted or derived) in the order of the stacked
    vector; when a derived output is among them, their joint mean ``(s,)`` and covariance
    ``(s, s)`` are sampled too (else None). ``n_draws`` are split over :data:`REPLICATES`
    scrambled Sobol' sequences keyed by ``seed``; ``n_runs`` is ``n_used``; ``sampling`` is
    ignored (derived moments are always randomised quasi-Monte Carlo). Also returns the number
    of draws left out because a derived value was not finite.
    """
    d = germ.dim
    joint_wanted = any(nm in derived for nm in scalar_order)
    sums: dict[str, list[_Sums]] = {}
    shapes: dict[str, tuple[int, ...]] = {}
    n_invalid = 0
    width = sum(e.n_columns for e in expansions.values()) + sum(
        expansions[c].n_columns for dv in derived.values() for c in dv.carriers)
    chunk = max(256, _CHUNK_FLOATS // max(width, 1))
    per = max(1, -(-n_draws // REPLICATES))
    for r, u in _replicate_draws(d, per, seed, chunk):
        xi = germ.from_unit(u)
        needed = {c for dv in derived.values() for c in dv.carriers}
        if joint_wanted:
            needed |= {nm for nm in scalar_order if nm not in derived}
        values = {name: expansions[name].values(xi) for name in needed}
        map_derived(germ, xi, derived, derived, values)
        ok = np.ones(xi.shape[0], dtype=bool)
        for name in derived:
            ok &= np.isfinite(values[name].reshape(xi.shape[0], -1)).all(axis=1)
        n_invalid += int((~ok).sum())
        groups = {name: values[name][ok] for name in derived}
        if joint_wanted:
            groups["\0joint"] = np.concatenate(
                [values[nm][ok].reshape(int(ok.sum()), -1) for nm in scalar_order], axis=1)
        for name, y in groups.items():
            shapes.setdefault(name, y.shape[1:])
            _accumulate(sums, name, r, y)
    stats = {}
    for name in derived:
        reps = [_stats(acc, shapes[name], n_runs) for acc in sums[name] if acc.n]
        st = _stats(_pooled(sums[name]), shapes[name], n_runs)
        if len(reps) > 1:
            st.sampling_se = {k: np.std([rep.stat(k) for rep in reps], axis=0, ddof=1)
                              / np.sqrt(len(reps)) for k in STAT_NAMES}
        stats[name] = st
    joint = None
    if joint_wanted:
        j = _pooled(sums["\0joint"])
        mean = j.shift + j.s[0] / j.n
        dev = j.s[0] / j.n
        joint = (mean, j.cross / j.n - np.outer(dev, dev))
    return stats, joint, n_invalid


def map_derived(germ: Germ, xi: np.ndarray, derived: Mapping[str, DerivedOutput],
                names: Iterable[str], values: dict[str, np.ndarray]) -> None:
    """Add to ``values`` (the carriers' values ``(n, ...)`` at germ points ``xi (n, d)``) the
    derived outputs ``names``, each ``(n, ...)`` of at least two dimensions."""
    x = germ.to_physical(xi)
    inputs = {nm: x[:, j] for j, nm in enumerate(germ.space.names)}
    for name in names:
        dv = derived[name]
        y = np.asarray(dv.function({c: values[c] for c in dv.carriers}, inputs), float)
        values[name] = y if y.ndim > 1 else y[:, None]


def _replicate_draws(d: int, per: int, seed: int | np.random.SeedSequence, chunk: int
                     ) -> Iterator[tuple[int, np.ndarray]]:
    """``(replicate, points)`` chunks of :data:`REPLICATES` independently scrambled Sobol'
    sequences of ``per`` points each (rounded up to a power of two)."""
    base = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    for r in range(REPLICATES):
        ss = np.random.SeedSequence(base.entropy, spawn_key=tuple(base.spawn_key) + (r,))
        for u in surrogate_draws(d, per, ss, chunk, "sobol"):
            yield r, u


def _pooled(reps: list[_Sums]) -> _Sums:
    """The replicates' sums added (they share one shift)."""
    first = reps[0]
    return _Sums(first.shift, [np.sum([a.s[i] for a in reps], axis=0) for i in range(4)],
                 np.sum([a.cross for a in reps], axis=0), sum(a.n for a in reps))


def _accumulate(sums: dict[str, list[_Sums]], name: str, r: int, y: np.ndarray) -> None:
    """Add draws ``y (n, ..., k)`` of replicate ``r`` to its shifted power sums and per-step
    cross products (one shift, the first chunk's mean, for every replicate)."""
    if name not in sums:
        shift = y.mean(axis=0) if y.shape[0] else np.zeros(y.shape[1:])
        k = y.shape[-1]
        sums[name] = [_Sums(shift, [np.zeros(y.shape[1:]) for _ in range(4)],
                            np.zeros(y.shape[1:] + (k,))) for _ in range(REPLICATES)]
    acc = sums[name][r]
    z = y - acc.shift
    z2 = z * z
    for i, p in enumerate((z, z2, z2 * z, z2 * z2)):
        acc.s[i] += p.sum(axis=0)
    acc.cross += np.einsum("n...i,n...j->...ij", z, z)
    acc.n += y.shape[0]


def _stats(acc: _Sums, shape: tuple[int, ...], n_runs: int) -> OutputStats:
    n = max(acc.n, 1)
    s1, s2, s3, s4 = (s / n for s in acc.s)
    mean = acc.shift + s1
    mu2, mu3, mu4 = central_from_raw(s1, s2, s3, s4)
    std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
    cov = acc.cross / n - np.einsum("...i,...j->...ij", s1, s1)
    return OutputStats(mean=mean.reshape(shape), std=std.reshape(shape),
                       skewness=skew.reshape(shape), kurtosis=kurt.reshape(shape), cov=cov,
                       n_used=int(n_runs), moments_method="surrogate-sampling")
