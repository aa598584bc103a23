"""The complex-shaped chief (body, solar panels, antennas) drawn once, for both GMM papers.

The [W] chief (:mod:`uqguide.papers.gmm_proximity`) and the [C] target
(:mod:`uqguide.papers.gmm_ftc`) are both a :class:`~uqguide.models.gmm.geometry.ChiefGeometry`
of axis-aligned parts; their figures draw them with these two functions: translucent boxes in
3-D, outlines in the x-y plane (rotated into another frame for a spinning target's snapshots).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from mpl_toolkits.mplot3d.art3d import Poly3DCollection

from ..models.gmm.geometry import ChiefGeometry, Part

PART_COLORS = {"solid": "0.55", "plate": "tab:cyan", "segment": "k"}
"""Colour of each kind of part (body, panel, antenna)."""

_LINE_WIDTH = {"solid": 1.0, "plate": 2.5, "segment": 2.5}
_SNAPSHOT_WIDTH = {"solid": 1.0, "plate": 1.0, "segment": 2.0}  # many overlaid: thinner
_BODY_FILL = "0.85"


def box_faces(lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """The non-degenerate faces of the box ``[lo, hi]`` (each (3,), m) as (4, 3) corner arrays."""
    faces = []
    for a in range(3):
        b, c = [k for k in range(3) if k != a]
        if lo[b] == hi[b] or lo[c] == hi[c]:
            continue
        for v in {lo[a], hi[a]}:
            quad = np.empty((4, 3))
            quad[:, a] = v
            quad[:, b] = [lo[b], hi[b], hi[b], lo[b]]
            quad[:, c] = [lo[c], lo[c], hi[c], hi[c]]
            faces.append(quad)
    return faces


def draw_chief_3d(ax: Any, geometry: ChiefGeometry) -> None:
    """Every part on a 3-D axes: translucent boxes and plates, antennas as thick lines; the
    parts in the frame the axes show [m]."""
    for part in geometry.parts:
        lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
        if part.kind == "segment":
            ax.plot(*np.stack([lo, hi]).T, color=PART_COLORS["segment"], lw=3)
            continue
        alpha = 0.25 if part.kind == "solid" else 0.45
        ax.add_collection3d(Poly3DCollection(box_faces(lo, hi), facecolor=PART_COLORS[part.kind],
                                             edgecolor="0.3", lw=0.5, alpha=alpha))


def outline_xy(part: Part, rotation: np.ndarray | None = None) -> np.ndarray:
    """The closed outline (5, 2) [m] of a part's projection on the x-y plane; ``rotation``
    (3, 3), e.g. a body-to-LVLH attitude, turns the corners (in the part's z = 0 plane) first."""
    lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
    xy = np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]],
                   [lo[0], lo[1]]])
    if rotation is not None:
        xy = (np.c_[xy, np.zeros(len(xy))] @ np.asarray(rotation).T)[:, :2]
    return xy


def draw_chief_xy(ax: Any, geometry: ChiefGeometry, rotation: np.ndarray | None = None,
                  color: Any = None) -> None:
    """Every part projected on the x-y plane: the body filled, panels and antennas as outlines.

    ``rotation`` as in :func:`outline_xy`; ``color``: one colour for every part, unfilled
    (snapshots coloured by time), instead of one per kind.
    """
    for part in geometry.parts:
        xy = outline_xy(part, rotation)
        if color is None and part.kind == "solid":
            ax.fill(xy[:, 0], xy[:, 1], facecolor=_BODY_FILL, edgecolor="0.3", lw=1.0)
            continue
        width = _LINE_WIDTH if color is None else _SNAPSHOT_WIDTH
        ax.plot(xy[:, 0], xy[:, 1], color=PART_COLORS[part.kind] if color is None else color,
                lw=width[part.kind], solid_capstyle="butt")
