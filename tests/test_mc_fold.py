"""Merging all outputs' chunk sums at once (uqguide.methods.monte_carlo.FoldedSums) gives
each group's MomentSums.merge bit for bit."""

from __future__ import annotations

import numpy as np

from uqguide.methods.monte_carlo import FoldedSums
from uqguide.stats.moments import MomentSums


def _chunk(rng: np.random.Generator, n: int, boot: bool = True) -> dict:
    """A chunk's groups as the Monte Carlo reducer makes them: series (T, k) and scalar
    outputs with comoments, orders 5-8 at interval columns, stacked scalars, and Poisson
    bootstrap sums with per-resample counts."""
    series = rng.standard_normal((n, 5, 3)) * [1.0, 1e3, 1e-6] + 7.0
    other = rng.lognormal(size=(n, 4, 1))
    scalar = rng.standard_normal((n, 2))
    g = {("m", "s"): MomentSums.of(series), ("h", "s"): MomentSums.of(series[:, [0, 4]],
                                                                     comoments=False, high=True),
         ("m", "o"): MomentSums.of(other), ("h", "o"): MomentSums.of(other, comoments=False,
                                                                     high=True),
         ("m", "y"): MomentSums.of(scalar), ("h", "y"): MomentSums.of(scalar, comoments=False,
                                                                     high=True),
         ("j", ""): MomentSums.of(np.concatenate([scalar, other[:, 0]], axis=1))}
    if boot:
        w = rng.poisson(1.0, (6, n)).astype(float)
        g[("b", "y")] = MomentSums.weighted(scalar, w)
    return g


def _one_by_one(chunks: list[dict]) -> dict:
    acc: dict = {}
    for c in chunks:
        for k, s in c.items():
            acc[k] = acc[k].merge(s) if k in acc else s
    return acc


def _assert_bitwise(a: dict, b: dict) -> None:
    assert list(a) == list(b)
    for k in a:
        for f in ("n", "mean", "m2", "m3", "m4", "cm", "high"):
            u, v = getattr(a[k], f), getattr(b[k], f)
            assert (u is None) == (v is None), (k, f)
            if u is not None:
                assert np.asarray(u).shape == np.asarray(v).shape, (k, f)
                assert np.array_equal(u, v), (k, f)


def test_merged_as_one_equals_each_group_merged_on_its_own():
    rng = np.random.default_rng(7)
    # uneven chunk sizes and an empty one (every run failed), as a real run has
    chunks = [_chunk(rng, n) for n in (300, 1, 257, 0, 64, 300)]
    folded = FoldedSums()
    for c in chunks:
        folded.add(c)
    _assert_bitwise(folded.groups(), _one_by_one(chunks))


def test_a_chunk_laid_out_otherwise_falls_back_to_group_by_group_and_stays_exact():
    rng = np.random.default_rng(8)
    chunks = [_chunk(rng, n, boot=False) for n in (100, 90, 50, 80)]
    for k in (("m", "o"), ("h", "o")):  # a chunk without one output's groups
        del chunks[2][k]
    folded = FoldedSums()
    for c in chunks:
        folded.add(c)
    _assert_bitwise(folded.groups(), _one_by_one(chunks))
