"""Tschauner-Hempel plant: orbit rates, closed forms and the nonlinear two-body reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from uqguide.models.dynamics.tschauner_hempel import (
    ChiefOrbit, LVLHPlant, propagate_free, rk4_transition,
)

WANG_ORBIT = ChiefOrbit(a=6778.1336e3, e=0.01, f0=0.0)


def test_omega_dot_is_the_time_derivative_of_omega():
    # d(omega)/dt = d(omega)/df * df/dt; central difference in f, step 1e-5 rad: truncation
    # ~ h^2 * omega''' / omega' ~ 1e-10 relative, rounding ~ 1e-16 / 1e-5 -> 1e-6 bound is ample.
    orbit = ChiefOrbit(a=7000e3, e=0.3)
    f = np.linspace(0.1, 6.2, 37)
    h = 1e-5
    fd = (orbit.omega(f + h) - orbit.omega(f - h)) / (2 * h) * orbit.omega(f)
    np.testing.assert_allclose(orbit.omega_dot(f), fd, rtol=1e-6)
    # the printed form (sign and exponent lost, spec A3) is not the derivative
    assert not np.allclose(orbit.omega_dot(f, printed=True), fd, rtol=1e-2)


def test_orbit_validates_its_elements():
    with pytest.raises(ValueError, match="eccentricity"):
        ChiefOrbit(a=7000e3, e=1.0)
    with pytest.raises(ValueError, match="semi-major axis"):
        ChiefOrbit(a=-1.0, e=0.0)


def _cw_stm(n: float, t: float) -> np.ndarray:
    """Clohessy-Wiltshire state transition matrix (x radial, y along-track, z normal)."""
    s, c = np.sin(n * t), np.cos(n * t)
    return np.array(
        [
            [4 - 3 * c, 0, 0, s / n, 2 * (1 - c) / n, 0],
            [6 * (s - n * t), 1, 0, -2 * (1 - c) / n, (4 * s - 3 * n * t) / n, 0],
            [0, 0, c, 0, 0, s / n],
            [3 * n * s, 0, 0, c, 2 * s, 0],
            [-6 * n * (1 - c), 0, 0, -2 * s, 4 * c - 3, 0],
            [0, 0, -n * s, 0, 0, c],
        ]
    )


def test_circular_orbit_reduces_to_clohessy_wiltshire():
    # e = 0: the TH plant is the CW plant; RK4 with 1 s steps (n h ~ 1e-3) has a global error
    # ~ (n h)^4 n t ~ 1e-12 relative, so 1e-9 m on 20 m states is a safe bound.
    orbit = ChiefOrbit(a=6778.1336e3, e=0.0)
    plant = LVLHPlant(orbit)
    x0 = np.array([[1.0, -16.0, 2.0, 0.01, -0.02, 0.005], [-15.0, 16.0, 0.0, 0.0, 0.0, 0.0]])
    path = propagate_free(plant, x0, t_f=800.0, dt=1.0)
    expected = x0 @ _cw_stm(orbit.mean_motion, 800.0).T
    np.testing.assert_allclose(path[:, -1], expected, rtol=0, atol=1e-9)


def test_held_control_map_matches_the_cw_forced_response():
    # The control column of the RK4 map is the response to a constant acceleration: for CW,
    # the integral of the STM's velocity columns over the period.
    orbit = ChiefOrbit(a=6778.1336e3, e=0.0)
    maps = rk4_transition(LVLHPlant(orbit), 0.0, 0.0, dt=1.0, n_sub=10)
    tau = np.linspace(0.0, 1.0, 20001)
    cols = np.array([_cw_stm(orbit.mean_motion, 1.0 - s)[:, 3:] for s in tau])
    expected = np.trapezoid(cols, tau, axis=0)  # trapezoid error ~ (5e-5)^2 * n^2 ~ 1e-14
    np.testing.assert_allclose(maps.gam[-1], expected, rtol=0, atol=1e-12)
    # sub-step maps are cumulative: the first sub-step covers 0.1 s
    np.testing.assert_allclose(maps.phi[0], _cw_stm(orbit.mean_motion, 0.1), rtol=0, atol=1e-13)


def _two_body_relative(orbit: ChiefOrbit, x0_lvlh: np.ndarray, t_f: float) -> np.ndarray:
    """Nonlinear reference: chief and deputy on Keplerian orbits, relative state in LVLH."""
    mu, a, e = orbit.mu, orbit.a, orbit.e
    p = a * (1 - e**2)
    rc0 = np.array([p / (1 + e), 0.0, 0.0])  # perigee (f0 = 0)
    vc0 = np.sqrt(mu / p) * np.array([0.0, 1 + e, 0.0])

    def frame(rc: np.ndarray, vc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        h = np.cross(rc, vc)
        xh = rc / np.linalg.norm(rc)
        zh = h / np.linalg.norm(h)
        R = np.column_stack([xh, np.cross(zh, xh), zh])  # LVLH -> inertial
        return R, zh * np.linalg.norm(h) / np.dot(rc, rc)

    def rhs(_t: float, s: np.ndarray) -> np.ndarray:
        rc, vc, dr, dv = s[0:3], s[3:6], s[6:9], s[9:12]
        rd = rc + dr
        ac = -mu * rc / np.linalg.norm(rc) ** 3
        # relative acceleration computed as a difference of nearly equal terms is exact enough
        # here: both are ~8 m/s^2 and the difference ~1e-5 m/s^2, i.e. 1e-11 relative rounding
        da = -mu * rd / np.linalg.norm(rd) ** 3 - ac
        return np.concatenate([vc, ac, dv, da])

    R0, w0 = frame(rc0, vc0)
    dr0 = R0 @ x0_lvlh[:3]
    dv0 = R0 @ x0_lvlh[3:] + np.cross(w0, dr0)
    sol = solve_ivp(rhs, (0.0, t_f), np.concatenate([rc0, vc0, dr0, dv0]), method="DOP853",
                    rtol=1e-12, atol=1e-12)
    s = sol.y[:, -1]
    R, w = frame(s[0:3], s[3:6])
    return np.concatenate([R.T @ s[6:9], R.T @ (s[9:12] - np.cross(w, s[6:9]))])


def test_elliptic_plant_matches_two_body_motion_and_needs_the_corrected_omega_dot():
    # For a 20 m separation the linearisation error is ~ 3 |dr|^2 / r_c * (n t)^2 ~ 1e-4 m over
    # 800 s; the printed dw/dt (wrong sign, spec A3) is off by ~2 n^2 e |dr| t^2 ~ 0.1 m.
    x0 = np.array([1.0, -16.0, 3.0, 0.02, 0.01, -0.01])
    truth = _two_body_relative(WANG_ORBIT, x0, 800.0)
    lin = propagate_free(LVLHPlant(WANG_ORBIT), x0[None], 800.0, 1.0)[0, -1]
    printed = propagate_free(LVLHPlant(WANG_ORBIT, printed_omega_dot=True), x0[None], 800.0, 1.0)
    err = np.linalg.norm(lin[:3] - truth[:3])
    err_printed = np.linalg.norm(printed[0, -1, :3] - truth[:3])
    assert err < 1e-3
    assert err_printed > 20 * err
