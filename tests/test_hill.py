"""Hill / CW relative dynamics against independent solutions (matrix exponential, two-body)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from uqguide.models.dynamics.hill import (
    MU_EARTH, cw_propagate, cw_stm, hill_acceleration, hill_matrix, mean_motion,
)

A_TARGET = 7043.14e3  # paper Table 1
N_MEAN = mean_motion(A_TARGET)


def test_mean_motion_of_table1_orbit():
    # n = sqrt(mu / a^3); period 2 pi / n of a 700 km LEO orbit is about 98 minutes.
    assert 2 * np.pi / N_MEAN / 60 == pytest.approx(98.05, abs=0.05)
    with pytest.raises(ValueError, match="positive"):
        mean_motion(-1.0)


@pytest.mark.parametrize("t", [0.5, 77.0, 1500.0, 6000.0])
def test_stm_equals_matrix_exponential(t):
    # expm(A t) is an independent numerical solution of the same linear ODE; its error is
    # round-off, ~1e-15 times the largest entry (|Phi_yvy| ~ 3 t).
    ref = expm(hill_matrix(N_MEAN) * t)
    assert np.allclose(cw_stm(N_MEAN, t), ref, rtol=0, atol=1e-12 * max(1.0, 3 * t))


def test_stm_is_a_flow():
    P = cw_stm(N_MEAN, np.array([30.0, 70.0, 100.0]))
    assert np.allclose(P[0] @ P[1], P[2], atol=1e-12)


def test_acceleration_is_the_system_matrix():
    rng = np.random.default_rng(0)
    r, v = rng.normal(size=(5, 3)) * 100, rng.normal(size=(5, 3))
    x = np.concatenate([r, v], axis=1)
    assert np.allclose(hill_acceleration(r, v, N_MEAN), (x @ hill_matrix(N_MEAN).T)[:, 3:],
                       rtol=1e-14, atol=0)


@pytest.mark.parametrize("t", [1.0, 80.0, 3000.0])
def test_forced_solution_equals_augmented_exponential(t):
    # Constant forcing: [x; a]' = [[A, B], [0, 0]] [x; a], solved by expm of the 9 x 9 matrix.
    r = np.array([[120.0, -40.0, 30.0]])
    v = np.array([[-1.0, 0.5, 0.2]])
    a = np.array([[0.1, -0.05, 0.02]])
    M = np.zeros((9, 9))
    M[:6, :6] = hill_matrix(N_MEAN)
    M[3:6, 6:9] = np.eye(3)
    ref = expm(M * t) @ np.concatenate([r[0], v[0], a[0]])
    rt, vt = cw_propagate(r, v, N_MEAN, t, a)
    # Cancellation of the |a| / n^2 ~ 1e5 m terms of the particular solution costs ~1e-11 m.
    assert np.allclose(rt[0], ref[:3], rtol=0, atol=1e-9 * max(1.0, t))
    assert np.allclose(vt[0], ref[3:6], rtol=0, atol=1e-11 * max(1.0, t))


def _two_body(state0: np.ndarray, t: np.ndarray) -> np.ndarray:
    def f(_, y):
        r = y[:3]
        return np.concatenate([y[3:], -MU_EARTH * r / np.linalg.norm(r) ** 3])

    return solve_ivp(f, (0, t[-1]), state0, t_eval=t, rtol=1e-12, atol=1e-9, method="DOP853").y.T


def test_sign_for_line_of_sight_target_minus_chaser():
    """r = target - chaser in the target's LVLH frame obeys r'' = g(r, v) with the same form
    as the chaser-relative CW equations: checked against two absolute Kepler orbits."""
    target0 = np.array([A_TARGET, 0, 0, 0, np.sqrt(MU_EARTH / A_TARGET), 0])
    r_lvlh = np.array([-800.0, 500.0, 300.0])  # chaser relative position, LVLH axes
    v_lvlh = np.array([0.6, -0.4, 0.3])
    # Inertial frame = LVLH at t = 0 (x radial, y along-track, z normal); rotation rate n z.
    omega = np.array([0.0, 0.0, N_MEAN])
    chaser0 = target0 + np.concatenate([r_lvlh, v_lvlh + np.cross(omega, r_lvlh)])
    t = np.linspace(0, 120.0, 7)
    tgt, chs = _two_body(target0, t), _two_body(chaser0, t)
    los_ref = []
    for yt, yc in zip(tgt, chs):
        xh = yt[:3] / np.linalg.norm(yt[:3])
        zh = np.cross(yt[:3], yt[3:])
        zh /= np.linalg.norm(zh)
        Rm = np.stack([xh, np.cross(zh, xh), zh])  # rows: LVLH axes in inertial coordinates
        d = yt[:3] - yc[:3]  # target - chaser
        dv = yt[3:] - yc[3:]
        w = N_MEAN * zh
        los_ref.append(np.concatenate([Rm @ d, Rm @ (dv - np.cross(w, d))]))
    los_ref = np.array(los_ref)
    rt, vt = cw_propagate(np.repeat(-r_lvlh[None], t.size, 0), np.repeat(-v_lvlh[None], t.size, 0),
                          N_MEAN, t)
    # CW drops the second-order gravity gradient, ~(3/2)(rho/a) n^2 rho t^2 = 1.2e-3 m for
    # rho = 1 km over 120 s; a wrong sign of any Hill term would be off by ~n^2 rho t^2 ~ 10 m.
    rho, tt = 1000.0, t[-1]
    tol = 3 * 1.5 * rho / A_TARGET * N_MEAN**2 * rho * tt**2
    assert np.abs(rt - los_ref[:, :3]).max() < tol
    assert np.abs(vt - los_ref[:, 3:]).max() < 3 * tol / tt
    # and the Hill terms matter at this scale: straight-line motion misses by far more than tol
    straight = -r_lvlh[None] - v_lvlh[None] * t[:, None]
    assert np.abs(straight - los_ref[:, :3]).max() > 100 * tol
