"""Surface point clouds of a box-built chief: :func:`grid_cloud` (the [W] recipe) and the seeded
:func:`random_cloud` (the [C] recipe); docs/simulators.md#gmm-surface-point-clouds.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from .geometry import ChiefGeometry, Part


def _rectangle_grid(
    lo: np.ndarray, hi: np.ndarray, axes: tuple[int, int], counts: tuple[int, int]
) -> np.ndarray:
    """Grid of ``counts[0] x counts[1]`` points on the rectangle spanning ``axes`` of [lo, hi]."""
    u = np.linspace(lo[axes[0]], hi[axes[0]], counts[0])
    v = np.linspace(lo[axes[1]], hi[axes[1]], counts[1])
    U, W = np.meshgrid(u, v, indexing="ij")
    pts = np.repeat(lo[None, :], U.size, axis=0)
    pts[:, axes[0]] = U.ravel()
    pts[:, axes[1]] = W.ravel()
    return pts


def _solid_faces(part: Part) -> list[tuple[np.ndarray, np.ndarray, tuple[int, int]]]:
    """The six faces of a solid box as degenerate boxes (lo, hi) and their in-plane axes."""
    lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
    faces: list[tuple[np.ndarray, np.ndarray, tuple[int, int]]] = []
    for axis in range(3):
        first, second = (a for a in range(3) if a != axis)
        others = (first, second)
        for value in (hi[axis], lo[axis]):
            flo, fhi = lo.copy(), hi.copy()
            flo[axis] = fhi[axis] = value
            faces.append((flo, fhi, others))
    return faces


def _dedupe(points: np.ndarray) -> np.ndarray:
    # Edge points of adjacent faces are the same linspace values; rounding to 1e-9 m only
    # absorbs the last-bit differences of those values, never merges distinct grid points.
    _, idx = np.unique(np.round(points, 9), axis=0, return_index=True)
    return points[np.sort(idx)]


def grid_cloud(geometry: ChiefGeometry, counts: Mapping[str, tuple[int, ...]]) -> np.ndarray:
    """Regular-grid surface samples (N, 3) [m] of every part, duplicates removed.

    ``counts`` by part name: solid ``(m,)`` points per edge of each face (``m x m`` per face);
    plate ``(m1, m2)`` along its two in-plane axes in increasing axis order; segment ``(m,)``.
    """
    chunks = []
    for part in geometry.parts:
        c = counts[part.name]
        lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
        if part.kind == "solid":
            for flo, fhi, axes in _solid_faces(part):
                chunks.append(_rectangle_grid(flo, fhi, axes, (c[0], c[0])))
        elif part.kind == "plate":
            in_plane = [int(a) for a in np.flatnonzero(~part.thin_axes)]
            chunks.append(_rectangle_grid(lo, hi, (in_plane[0], in_plane[1]), (c[0], c[1])))
        else:
            axis = int(np.flatnonzero(~part.thin_axes)[0])
            pts = np.repeat(lo[None, :], c[0], axis=0)
            pts[:, axis] = np.linspace(lo[axis], hi[axis], c[0])
            chunks.append(pts)
    return _dedupe(np.concatenate(chunks))


def random_cloud(
    geometry: ChiefGeometry, counts: Mapping[str, int], rng: np.random.Generator
) -> np.ndarray:
    """Uniform random surface samples (N, 3) [m]; ``counts`` by part name: points per face of a
    solid, per plate, per segment."""
    chunks = []
    for part in geometry.parts:
        m = int(counts[part.name])
        boxes = (
            [(flo, fhi) for flo, fhi, _ in _solid_faces(part)]
            if part.kind == "solid"
            else [(np.asarray(part.lo, float), np.asarray(part.hi, float))]
        )
        for lo, hi in boxes:
            chunks.append(lo + (hi - lo) * rng.random((m, 3)))
    return np.concatenate(chunks)


WANG2022_GRID_COUNTS: dict[str, tuple[int, ...]] = {
    "body": (200,),
    "panel+y": (283, 141),
    "panel-y": (283, 141),
    "antenna+x": (99_000,),
    "antenna-x": (99_000,),
}
"""The [W] grid (docs/simulators.md#gmm-surface-point-clouds)."""
