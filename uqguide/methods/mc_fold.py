"""The driver's merge of Monte Carlo chunk sums, all outputs at once.

A chunk's summary holds about fifteen groups of moment sums (per output: the plain sums with
comoments and the orders 5-8 of the interval columns; the stacked scalars). Merged group by
group, each merge is some forty small NumPy operations: 1.5 ms a chunk, 0.2 CPU-s of a
1e6-run FTCAPN study, taken by the driver from the cores its pool's workers run on. The groups
of one chunk share their run count and Chan's formulas are elementwise, so groups of the same
fields are laid side by side in flat arrays and merged as one: the same operations on the same
numbers, bit for bit, one merge per kind of group a chunk (:meth:`MomentSums.merge` itself,
with the comoments' outer products gathered by index, ``delta[I] * delta[J]``: the products
``einsum`` forms).

Sums with per-resample counts (the Poisson bootstrap's) are merged group by group as before.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..stats.moments import MomentSums

Key = tuple[str, str]


@dataclass
class _Pack:
    """Groups with the same fields (comoments or not, orders 5-8 or not), merged as one."""

    keys: list[Key]
    shapes: list[tuple[int, ...]]
    sums: MomentSums  # flat fields, ``high`` (orders, total), comoments flat
    outer: tuple[np.ndarray, np.ndarray] | None  # a comoment is delta[I] * delta[J]

    @classmethod
    def of(cls, groups: list[tuple[Key, MomentSums]], accumulates: bool = True) -> _Pack:
        """The groups joined; ``accumulates``: this pack takes the later chunks (it keeps the
        comoments' gather index, made once)."""
        keys = [k for k, _ in groups]
        shapes = [s.mean.shape for _, s in groups]
        first = groups[0][1]

        def joined(field: str) -> np.ndarray:
            return np.concatenate([getattr(s, field).ravel() for _, s in groups])

        high = None
        if first.high is not None:
            rows = len(first.high)
            high = np.concatenate([np.asarray(s.high).reshape(rows, -1) for _, s in groups],
                                  axis=1)
        cm = joined("cm") if first.cm is not None else None
        flat = MomentSums(first.n, joined("mean"), joined("m2"), joined("m3"), joined("m4"),
                          cm, high)
        outer = _outer_index(shapes) if cm is not None and accumulates else None
        return cls(keys, shapes, flat, outer)

    def matches(self, groups: list[tuple[Key, MomentSums]]) -> bool:
        return [k for k, _ in groups] == self.keys and \
            [s.mean.shape for _, s in groups] == self.shapes

    def merge(self, other: _Pack) -> None:
        """Merge ``other`` (the next chunk's groups, same layout) into this one: exactly
        :meth:`MomentSums.merge` of each group."""
        gather = None
        if self.outer is not None:
            i, j = self.outer

            def gather(delta: np.ndarray) -> np.ndarray:
                return delta[i] * delta[j]
        self.sums = self.sums.merge(other.sums, outer=gather)

    def groups(self) -> dict[Key, MomentSums]:
        out, at, cm_at = {}, 0, 0
        s = self.sums
        for key, shape in zip(self.keys, self.shapes, strict=True):
            size = int(np.prod(shape))
            sl = slice(at, at + size)
            cm = None
            if s.cm is not None:
                k = shape[-1] if shape else 1
                cm = s.cm[cm_at:cm_at + size * k].reshape(shape + (k,))
                cm_at += size * k
            out[key] = MomentSums(
                s.n, s.mean[sl].reshape(shape), s.m2[sl].reshape(shape),
                s.m3[sl].reshape(shape), s.m4[sl].reshape(shape), cm,
                s.high[:, sl].reshape((len(s.high),) + shape) if s.high is not None else None)
            at += size
        return out


def _outer_index(shapes: list[tuple[int, ...]]) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices ``I, J`` into the groups' joined means such that the joined comoments'
    element is ``delta[I] * delta[J]`` (each group's ``(..., k, k)`` outer product)."""
    rows, cols, at = [], [], 0
    for shape in shapes:
        k = shape[-1] if shape else 1
        lead = int(np.prod(shape[:-1])) if shape else 1
        base = at + np.arange(lead)[:, None, None] * k
        rows.append(np.broadcast_to(base + np.arange(k)[None, :, None], (lead, k, k)).ravel())
        cols.append(np.broadcast_to(base + np.arange(k)[None, None, :], (lead, k, k)).ravel())
        at += lead * k
    return np.concatenate(rows), np.concatenate(cols)


class FoldedSums:
    """The merged sums of the chunks so far, groups of the same fields merged as one.

    ``add`` merges a chunk's groups (in chunk order); ``groups`` gives every group's
    :class:`MomentSums` in the order the groups first came, equal bit for bit to merging each
    group on its own.
    """

    def __init__(self) -> None:
        self._packs: dict[tuple[bool, bool], _Pack] = {}
        self._apart: dict[Key, MomentSums] = {}
        self._unpacked: set[tuple[bool, bool]] = set()
        self._order: dict[Key, None] = {}

    def add(self, groups: dict[Key, MomentSums]) -> None:
        kinds: dict[tuple[bool, bool], list[tuple[Key, MomentSums]]] = {}
        for key, s in groups.items():
            self._order.setdefault(key)
            if np.ndim(s.n) == 0:
                kinds.setdefault((s.cm is not None, s.high is not None), []).append((key, s))
            else:  # per-resample counts
                self._merge_apart(key, s)
        for kind, members in kinds.items():
            pack = self._packs.get(kind)
            if pack is not None and not pack.matches(members):
                # a chunk laid out otherwise (not seen in practice): group by group from now on
                self._apart.update(self._packs.pop(kind).groups())
                self._unpacked.add(kind)
                pack = None
            if kind in self._unpacked:
                for key, s in members:
                    self._merge_apart(key, s)
            elif pack is None:
                self._packs[kind] = _Pack.of(members)
            else:
                pack.merge(_Pack.of(members, accumulates=False))

    def _merge_apart(self, key: Key, s: MomentSums) -> None:
        self._apart[key] = self._apart[key].merge(s) if key in self._apart else s

    def groups(self) -> dict[Key, MomentSums]:
        out = dict(self._apart)
        for pack in self._packs.values():
            out.update(pack.groups())
        return {k: out[k] for k in self._order}
