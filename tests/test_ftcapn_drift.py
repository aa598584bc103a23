"""Zero-effort miss of the drift after the stop against brute-force minimisation."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from uqguide.models.dynamics.hill import cw_propagate, mean_motion
from uqguide.models.ftcapn.drift import miss_hill, miss_parabola, miss_straight

N_MEAN = mean_motion(7043.14e3)


def _brute(dist, t_end: float) -> tuple[float, float]:
    """Global minimum of dist(t) on [0, t_end]: a dense grid, then a bounded local search."""
    t = np.linspace(0.0, t_end, 4001)
    d = dist(t)
    k = int(np.argmin(d))
    lo, hi = t[max(k - 1, 0)], t[min(k + 1, t.size - 1)]
    res = minimize_scalar(lambda s: float(dist(np.array([s]))[0]), bounds=(lo, hi),
                          method="bounded", options={"xatol": 1e-10})
    return (res.fun, res.x) if res.fun < d[k] else (d[k], t[k])


def _states(seed: int, m: int):
    rng = np.random.default_rng(seed)
    r = rng.normal(size=(m, 3))
    r *= 50.0 / np.linalg.norm(r, axis=1, keepdims=True)
    v = -0.9 * 5.0 * r / 50.0 + rng.normal(size=(m, 3)) * 0.8  # closing, with a miss
    a = rng.normal(size=(m, 3)) * 0.1
    return r, v, a


def test_straight_line_miss_is_cross_product_formula():
    r, v, _ = _states(0, 20)
    miss, t = miss_straight(r, v)
    closing = np.einsum("ij,ij->i", r, v) < 0
    expect = np.linalg.norm(np.cross(r, v), axis=1) / np.linalg.norm(v, axis=1)
    assert np.allclose(miss[closing], expect[closing], rtol=1e-12)
    assert np.allclose(miss[~closing], np.linalg.norm(r[~closing], axis=1))


@pytest.mark.parametrize("seed", [1, 2])
def test_parabola_miss_is_the_global_minimum(seed):
    r, v, a = _states(seed, 15)
    a[0] = 0.0  # no maneuver: straight line
    a[1] = -v[1] * 0.5  # decelerating along the velocity: turns back
    miss, t_miss = miss_parabola(r, v, a)
    for i in range(r.shape[0]):
        def dist(t, i=i):
            p = r[i] + v[i] * t[:, None] + 0.5 * a[i] * t[:, None] ** 2
            return np.linalg.norm(p, axis=1)

        ref, _ = _brute(dist, 200.0)
        # the brute force can only find a larger value (it samples); the closed form must not
        # exceed it by more than the local search's tolerance
        assert miss[i] <= ref + 1e-8
        assert miss[i] >= ref - 1e-8
        assert dist(np.array([t_miss[i]]))[0] == pytest.approx(miss[i], rel=1e-12)


def test_hill_miss_matches_brute_force_cw_drift():
    r, v, a = _states(3, 8)
    miss, t_miss = miss_hill(r, v, a, N_MEAN)
    for i in range(r.shape[0]):
        def dist(t, i=i):
            rt, _ = cw_propagate(np.repeat(r[i][None], t.size, 0), np.repeat(v[i][None], t.size, 0),
                                 N_MEAN, t, a[i])
            return np.linalg.norm(rt, axis=1)

        # the close pass happens within ~30 s of a 50 m, 5 m/s approach
        ref, _ = _brute(dist, 60.0)
        assert miss[i] == pytest.approx(ref, abs=1e-7)
