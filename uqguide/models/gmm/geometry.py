"""Chief geometry as axis-aligned boxes (a solid body, plates, segments), clearance and
swept-segment collision checks, vectorised over points, segments and parts; the deputy is a
point. Clearance is the distance to each part's zero-thickness skeleton (0 inside), so any
thickness can be applied afterwards; a collision (A8) is a segment between consecutive positions
meeting a part's collision box (thin parts inflated by their half-thickness plus the deputy's
radius, the body shrunk by a penetration tolerance, because the [W] goal lies on its -x face).
Placement and thicknesses (A7, A8): docs/papers.md#the-gmm-papers-ambiguities-as-settled.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Literal

import numpy as np

PartKind = Literal["solid", "plate", "segment"]


@dataclass(frozen=True)
class Part:
    """One axis-aligned part of the chief (``name``: ``"body"``, ``"panel-y"``, ...): a
    ``"solid"`` box, a ``"plate"`` (one zero-extent axis) or a ``"segment"`` (two), between the
    corners ``lo``, ``hi`` [m] in the chief frame (equal on the zero-extent axes);
    ``half_thickness`` [m] of a plate, or half-width of a segment's square section."""

    name: str
    kind: PartKind
    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    half_thickness: float = 0.0

    def __post_init__(self) -> None:
        extent = np.subtract(self.hi, self.lo)
        if np.any(extent < 0):
            raise ValueError(
                f"part {self.name!r}: hi must not be below lo, got {self.lo}, {self.hi}"
            )
        n_thin = int(np.sum(extent == 0))
        expected = {"solid": 0, "plate": 1, "segment": 2}[self.kind]
        if n_thin != expected:
            raise ValueError(
                f"part {self.name!r}: a {self.kind} has {expected} zero-extent axes, got {n_thin}"
            )
        if self.half_thickness < 0:
            raise ValueError(f"part {self.name!r}: the half-thickness must be >= 0")

    @property
    def thin_axes(self) -> np.ndarray:
        """Boolean mask (3,) of the zero-extent axes."""
        return np.asarray(self.hi) == np.asarray(self.lo)


@dataclass(frozen=True)
class ChiefGeometry:
    """The chief's parts (the first the solid body) and the collision tolerances (A8):
    ``body_tolerance`` [m], the penetration of the body allowed before it counts as a collision,
    and ``deputy_radius`` [m] (0: a point, as in both papers)."""

    parts: tuple[Part, ...]
    body_tolerance: float = 0.01
    deputy_radius: float = 0.0
    skeleton_lo: np.ndarray = field(init=False, repr=False)
    skeleton_hi: np.ndarray = field(init=False, repr=False)
    collision_lo: np.ndarray = field(init=False, repr=False)
    collision_hi: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        lo = np.array([p.lo for p in self.parts], dtype=float)
        hi = np.array([p.hi for p in self.parts], dtype=float)
        grow = np.zeros_like(lo)
        for i, p in enumerate(self.parts):
            if p.kind == "solid":
                grow[i] = self.deputy_radius - self.body_tolerance
            else:
                grow[i] = self.deputy_radius + p.half_thickness * p.thin_axes
        object.__setattr__(self, "skeleton_lo", lo)
        object.__setattr__(self, "skeleton_hi", hi)
        object.__setattr__(self, "collision_lo", lo - grow)
        object.__setattr__(self, "collision_hi", hi + grow)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parts)

    def solid_index(self) -> np.ndarray:
        """Indices of the solid parts."""
        return np.array([i for i, p in enumerate(self.parts) if p.kind == "solid"], dtype=int)

    def clearance(self, points: np.ndarray) -> np.ndarray:
        """Distance [m] from each point to each part's skeleton, shape (..., n_parts)."""
        return point_box_distance(points, self.skeleton_lo, self.skeleton_hi)

    def body_penetration(self, points: np.ndarray) -> np.ndarray:
        """Depth [m] of each point inside the solid parts (0 outside), shape (...,)."""
        idx = self.solid_index()
        depth = penetration_depth(points, self.skeleton_lo[idx], self.skeleton_hi[idx])
        return depth.max(axis=-1)

    def segment_hits(self, p0: np.ndarray, p1: np.ndarray) -> np.ndarray:
        """Whether the segments ``p0 -> p1`` (..., 3) cross each collision box, (..., n_parts)."""
        return segment_box_hits(p0, p1, self.collision_lo, self.collision_hi)


def point_box_distance(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Euclidean distance (..., P) from points (..., 3) to axis-aligned boxes (P, 3) (0 inside)."""
    p = np.asarray(points, dtype=float)[..., None, :]
    gap = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    return np.sqrt(np.sum(gap * gap, axis=-1))


def penetration_depth(points: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Distance from points inside boxes to the nearest face (0 outside), shape (..., P)."""
    p = np.asarray(points, dtype=float)[..., None, :]
    depth = np.minimum(p - lo, hi - p).min(axis=-1)
    return np.maximum(depth, 0.0)


def segment_box_hits(p0: np.ndarray, p1: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Slab test: does the closed segment ``p0 -> p1`` (..., 3) meet the closed box ``[lo, hi]``
    (P, 3)? Booleans (..., P).

    Per axis ``t_{1,2} = (lo - p0) / d, (hi - p0) / d``; the segment hits iff
    ``max_i min(t1, t2) <= min_i max(t1, t2)`` and the interval meets ``[0, 1]``. An axis with
    ``d_i = 0`` constrains nothing when ``lo_i <= p0_i <= hi_i`` and excludes the box otherwise.
    """
    a = np.asarray(p0, dtype=float)[..., None, :]
    d = np.asarray(p1, dtype=float)[..., None, :] - a
    moving = d != 0.0
    safe_d = np.where(moving, d, 1.0)
    t1 = (lo - a) / safe_d
    t2 = (hi - a) / safe_d
    inside = (lo <= a) & (a <= hi)
    t_lo = np.where(moving, np.minimum(t1, t2), np.where(inside, -np.inf, np.inf))
    t_hi = np.where(moving, np.maximum(t1, t2), np.where(inside, np.inf, -np.inf))
    t_enter = t_lo.max(axis=-1)
    t_exit = t_hi.min(axis=-1)
    return (t_enter <= t_exit) & (t_exit >= 0.0) & (t_enter <= 1.0)


def wang2022_chief(
    panel_half_thickness: float = 0.05,
    antenna_half_width: float = 0.10,
    body_tolerance: float = 0.01,
    deputy_radius: float = 0.0,
) -> ChiefGeometry:
    """The chief of [W] (Table 1; placement from the App. A4 GMM, A7).

    Cube of side 10 m centred at the origin; solar panels 10 m x 5 m in the plane ``x = 0``,
    ``y`` in +-[5, 15], ``z`` in [-2.5, 2.5]; antennas 5 m long on the ``x`` axis,
    ``x`` in +-[5, 10]. Thicknesses are not published (A7).
    """
    return ChiefGeometry(
        parts=(
            Part("body", "solid", (-5.0, -5.0, -5.0), (5.0, 5.0, 5.0)),
            Part("panel+y", "plate", (0.0, 5.0, -2.5), (0.0, 15.0, 2.5), panel_half_thickness),
            Part("panel-y", "plate", (0.0, -15.0, -2.5), (0.0, -5.0, 2.5), panel_half_thickness),
            Part("antenna+x", "segment", (5.0, 0.0, 0.0), (10.0, 0.0, 0.0), antenna_half_width),
            Part("antenna-x", "segment", (-10.0, 0.0, 0.0), (-5.0, 0.0, 0.0), antenna_half_width),
        ),
        body_tolerance=body_tolerance,
        deputy_radius=deputy_radius,
    )

