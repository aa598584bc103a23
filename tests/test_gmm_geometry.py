"""Chief geometry: clearance, penetration and the swept-segment test (spec 4.2, 12.5)."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.models.gmm.geometry import (
    Part, penetration_depth, point_box_distance, segment_box_hits, wang2022_chief,
)
from uqguide.models.gmm.point_cloud import WANG2022_GRID_COUNTS, grid_cloud, random_cloud
from tests.oracles.gmm import _advance

CHIEF = wang2022_chief()
NAMES = CHIEF.names  # body, panel+y, panel-y, antenna+x, antenna-x


def _hits(p0, p1):
    return dict(zip(NAMES, CHIEF.segment_hits(np.array([p0], float), np.array([p1], float))[0]))


def test_segment_through_a_panel_hits_it():
    h = _hits([1.0, -10.0, 0.0], [-1.0, -10.0, 0.0])
    assert h["panel-y"] and not any(v for k, v in h.items() if k != "panel-y")


def test_segment_parallel_to_a_panel_hits_only_within_its_half_thickness():
    assert _hits([0.04, -14.0, 1.0], [0.04, -6.0, 1.0])["panel-y"]  # inside the 0.05 m slab
    assert not _hits([0.06, -14.0, 1.0], [0.06, -6.0, 1.0])["panel-y"]
    assert not _hits([0.0, -14.0, 2.6], [0.0, -6.0, 2.6])["panel-y"]  # beyond the panel's edge


def test_segment_ending_inside_the_body_hits_it_and_touching_the_goal_face_does_not():
    assert _hits([-8.0, 0.5, 0.5], [-4.5, 0.5, 0.5])["body"]
    goal = [-5.0, -0.913043, -0.304348]  # on the -x face: allowed (penetration tolerance 0.01 m)
    assert not _hits([-6.0, -0.913043, -0.304348], goal)["body"]
    assert not _hits([-5.0, -3.0, 1.0], [-5.0, 3.0, 1.0])["body"]  # sliding along the face
    assert _hits([-4.98, -3.0, 1.0], [-4.98, 3.0, 1.0])["body"]  # 2 cm deep


def test_segment_grazing_an_antenna_within_its_half_width():
    assert _hits([-7.0, 0.09, -1.0], [-7.0, 0.09, 1.0])["antenna-x"]
    assert not _hits([-7.0, 0.11, -1.0], [-7.0, 0.11, 1.0])["antenna-x"]
    assert not _hits([-11.0, 0.0, -1.0], [-11.0, 0.0, 1.0])["antenna-x"]  # beyond the tip


def test_segment_hits_is_symmetric_and_handles_stationary_points():
    rng = np.random.default_rng(0)
    p0 = rng.uniform(-16, 16, (2000, 3))
    p1 = p0 + rng.normal(scale=3.0, size=p0.shape)
    fwd = CHIEF.segment_hits(p0, p1)
    np.testing.assert_array_equal(fwd, CHIEF.segment_hits(p1, p0))
    # a degenerate segment hits exactly when its point is inside the collision box
    inside = np.all((CHIEF.collision_lo <= p0[:, None]) & (p0[:, None] <= CHIEF.collision_hi),
                    axis=2)
    np.testing.assert_array_equal(CHIEF.segment_hits(p0, p0), inside)
    # a dense sampling of each segment never finds a hit the slab test misses
    s = np.linspace(0, 1, 401)[None, :, None]
    pts = p0[:, None] + s * (p1 - p0)[:, None]
    in_box = (CHIEF.collision_lo <= pts[:, :, None]) & (pts[:, :, None] <= CHIEF.collision_hi)
    sampled = np.any(np.all(in_box, axis=3), axis=1)
    assert not np.any(sampled & ~fwd)


def test_clearance_and_penetration_against_analytic_distances():
    pts = np.array([[8.0, 0.0, 0.0], [8.0, 7.0, 0.0], [0.0, -10.0, 3.5], [-7.5, 0.3, 0.4],
                    [4.0, 0.0, 0.0]])
    d = CHIEF.clearance(pts)
    body, panel_m, ant_m = 0, 2, 4
    assert d[0, body] == pytest.approx(3.0)
    assert d[1, body] == pytest.approx(np.hypot(3.0, 2.0))
    assert d[2, panel_m] == pytest.approx(1.0)  # 3.5 - 2.5 above the panel's edge
    assert d[3, ant_m] == pytest.approx(0.5)
    assert d[4, body] == 0.0
    assert CHIEF.body_penetration(pts)[4] == pytest.approx(1.0)
    np.testing.assert_array_equal(CHIEF.body_penetration(pts)[:4], 0.0)


def test_part_rejects_inconsistent_kinds():
    with pytest.raises(ValueError, match="zero-extent"):
        Part("panel", "plate", (0, 0, 0), (1, 1, 1))
    with pytest.raises(ValueError, match="below"):
        Part("body", "solid", (1, 1, 1), (0, 2, 2))


def test_compiled_period_update_matches_the_numpy_reference():
    # _advance fuses propagation, clearance, penetration and the swept test; compare it with
    # the NumPy functions on random paths crossing the chief.
    rng = np.random.default_rng(1)
    n, n_sub = 300, 10
    x = np.concatenate([rng.uniform(-12, 12, (n, 3)), rng.normal(scale=2.0, size=(n, 3))], axis=1)
    u = rng.normal(scale=0.3, size=(n, 3))
    t = (np.arange(n_sub) + 1) / n_sub
    phi = np.zeros((n_sub, 6, 6))
    phi[:, :3, :3] = phi[:, 3:, 3:] = np.eye(3)
    phi[:, :3, 3:] = t[:, None, None] * np.eye(3)  # free-space kinematics
    gam = np.zeros((n_sub, 6, 3))
    gam[:, :3] = 0.5 * t[:, None, None] ** 2 * np.eye(3)
    gam[:, 3:] = t[:, None, None] * np.eye(3)
    P = len(CHIEF.parts)
    clearance = point_box_distance(x[:, :3], CHIEF.skeleton_lo, CHIEF.skeleton_hi)
    penetration = CHIEF.body_penetration(x[:, :3])
    hits = np.zeros((n, P), dtype=bool)
    min_range = np.linalg.norm(x[:, :3], axis=1)
    solid = np.array([p.kind == "solid" for p in CHIEF.parts])
    x_next = np.empty_like(x)
    _advance(x, u, phi, gam, CHIEF.skeleton_lo, CHIEF.skeleton_hi, CHIEF.collision_lo,
             CHIEF.collision_hi, solid, x_next, clearance, penetration, hits, min_range)

    sub = np.einsum("sij,nj->nsi", phi, x) + np.einsum("sij,nj->nsi", gam, u)
    pts = np.concatenate([x[:, None, :3], sub[:, :, :3]], axis=1)
    np.testing.assert_allclose(x_next, sub[:, -1], rtol=1e-14, atol=1e-13)
    ref_clear = point_box_distance(pts, CHIEF.skeleton_lo, CHIEF.skeleton_hi).min(axis=1)
    np.testing.assert_allclose(clearance, ref_clear, rtol=1e-13, atol=1e-13)
    ref_pen = penetration_depth(pts, CHIEF.skeleton_lo[:1], CHIEF.skeleton_hi[:1]).max(axis=(1, 2))
    np.testing.assert_allclose(penetration, ref_pen, atol=1e-13)
    ref_hits = segment_box_hits(pts[:, :-1], pts[:, 1:], CHIEF.collision_lo,
                                CHIEF.collision_hi).any(axis=1)
    np.testing.assert_array_equal(hits, ref_hits)
    assert ref_hits.any() and (~ref_hits).any()
    np.testing.assert_allclose(min_range, np.linalg.norm(pts, axis=2).min(axis=1), rtol=1e-14)


def test_wang_grid_cloud_has_the_spec_counts_and_face_statistics():
    pts = grid_cloud(CHIEF, WANG2022_GRID_COUNTS)
    # 6 faces of 200 x 200 minus shared edges: 6*40000 - 12*200 + 8 corners counted thrice
    # -> 237,608; panels 2 * 283 * 141; antennas 2 * 99,000 (spec 4.3: ~515,000)
    assert pts.shape == (237_608 + 2 * 283 * 141 + 2 * 99_000, 3)
    on_axis = (pts[:, 1] == 0) & (pts[:, 2] == 0)  # the +x antenna's root point
    on_face = np.isclose(pts[:, 0], 5.0) & (np.abs(pts[:, 1]) <= 5) & (np.abs(pts[:, 2]) <= 5)
    face = pts[on_face & ~on_axis]
    assert face.shape[0] == 40_000
    # a 200-point grid on [-5, 5] has variance (10^2 / 12) * 201 / 199 = 8.4171 (spec 4.3)
    assert face[:, 1].var() == pytest.approx(100 / 12 * 201 / 199, rel=1e-12)


def test_random_cloud_is_seeded_and_on_the_surfaces():
    counts = {"body": 50, "panel+y": 30, "panel-y": 30, "antenna+x": 10, "antenna-x": 10}
    a = random_cloud(CHIEF, counts, np.random.default_rng(4))
    b = random_cloud(CHIEF, counts, np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)
    assert a.shape == (6 * 50 + 60 + 20, 3)
    np.testing.assert_allclose(CHIEF.clearance(a).min(axis=1), 0.0, atol=1e-12)
