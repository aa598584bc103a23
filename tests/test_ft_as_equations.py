"""Unit tests of the FT-AS equations (ft-as-controller.md section 13, tests 2-7) on their NumPy
form (tests/oracles/ft_as_equations.py)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from tests.oracles import ft_as_equations as cl
from uqguide.models.dynamics import mrp
from uqguide.models.ft_as import scenario
from uqguide.models.ft_as.params import FTASParams
from uqguide.models.ft_as.setup import OMEGA, R_E, SIGMA_E, V_E, Batch

PARAMS = FTASParams()
PLANT = PARAMS.plant()


def _batch(n: int, rng: np.random.Generator) -> Batch:
    return Batch(
        x0=np.zeros((n, 36)),
        mass_offset=rng.uniform(-5, 5, n),
        inertia_scale_error=rng.uniform(-0.1, 0.1, n),
        force_amp=np.full(n, 1e-3),
        torque_amp=np.full(n, 1e-5),
        controller=np.zeros(n, int),
        observer_on_applied=np.ones(n, bool),
        psi2_bound=np.full(n, np.inf),
        omega_chi=np.full(n, 0.05),
        switch_input=np.ones(n, bool),
    )


def _random_state(n: int, rng: np.random.Generator) -> np.ndarray:
    x = np.zeros((n, 36))
    x[:, R_E] = rng.uniform(-500, 500, (n, 3))
    x[:, V_E] = rng.uniform(-0.3, 0.3, (n, 3))
    x[:, SIGMA_E] = rng.uniform(-0.3, 0.3, (n, 3))
    x[:, OMEGA] = rng.uniform(-0.03, 0.03, (n, 3))
    return x


def test_table1_initial_errors_from_the_elements():
    # spec test 5: Table 1 printed digits (1 mm, 0.1 mm/s)
    r_e, v_e = scenario.initial_orbit_errors(
        PARAMS.orbit(PARAMS.actual_semi_major_axis), PARAMS.orbit(PARAMS.reference_semi_major_axis)
    )
    np.testing.assert_array_equal(np.round(r_e, 3), [275.683, 374.962, -182.762])
    np.testing.assert_array_equal(np.round(v_e, 4), [0.1858, -0.1769, -0.0827])
    assert PARAMS.orbit(7000.5e3).mean_motion == pytest.approx(1.07789e-3, rel=1e-5)


def test_split_into_h_M_d_matches_closed_form():
    # spec test 3: d = e2_dot(true plant) - h - M u equals the closed form of section 5.
    rng = np.random.default_rng(3)
    n, t = 6, 123.4
    batch, x = _batch(n, rng), _random_state(n, rng)
    u = rng.uniform(-2, 2, (n, 6))
    tr = cl.tracking(t, x, PLANT)
    xdot = cl.plant_rhs(t, x, u, batch, PLANT)
    sigma_dot = tr.e2[:, 3:]
    # omega_e_dot = omega_dot + omega_e x (C omega_t) for a constant omega_t
    omega_e_dot = xdot[:, OMEGA] + np.cross(tr.omega_e, tr.C @ PLANT.omega_t)
    e2_dot = np.concatenate(
        [
            xdot[:, V_E],
            np.einsum("nij,nj->ni", mrp.kinematics_matrix_dot(x[:, SIGMA_E], sigma_dot), tr.omega_e)
            + np.einsum("nij,nj->ni", tr.G, omega_e_dot),
        ],
        axis=1,
    )
    d = e2_dot - tr.h - cl.apply_M(u, tr.G, PLANT)
    d_closed = cl.true_disturbance(t, x, u, batch, PLANT)
    # absolute level: |e2_dot| ~ 1e-2, so 1e-14 is ~ 100 ulp of the terms that cancel
    np.testing.assert_allclose(d, d_closed, rtol=0, atol=1e-14)
    # and sigma_dot really is the time derivative of sigma_e (independent check of e2)
    np.testing.assert_allclose(xdot[:, SIGMA_E], sigma_dot, atol=1e-16)


def test_M_and_M_inv_are_inverse():
    rng = np.random.default_rng(4)
    x = _random_state(5, rng)
    tr = cl.tracking(0.0, x, PLANT)
    v = rng.normal(size=(5, 6))
    np.testing.assert_allclose(cl.apply_M(cl.apply_M_inv(v, tr.G_inv, PLANT), tr.G, PLANT), v,
                               rtol=1e-12, atol=1e-15)  # fmt: skip


@pytest.mark.parametrize("seed", range(5))
def test_sliding_variable_obeys_the_reaching_law(seed):
    # spec test 4: with d_hat = d, gamma = 0 and phi = 1 the law gives
    # s_dot = -nu2 sig^r2(s) - eta2 sig^rho2(s) exactly; finite difference along e1, e2.
    rng = np.random.default_rng(seed)
    n = 4
    gains = FTASParams(gamma=0.0).gains()
    x = _random_state(n, rng)
    tr = cl.tracking(50.0, x, PLANT)
    e1 = rng.uniform(-1, 1, (n, 6))
    e2 = rng.uniform(-0.1, 0.1, (n, 6))
    d = rng.normal(scale=1e-3, size=(n, 6))
    u, s = cl.control_law(e1, e2, tr.h, d, tr.G_inv, np.ones(n, bool), gains, PLANT)
    e2_dot = tr.h + cl.apply_M(u, tr.G, PLANT) + d
    dt = 1e-6
    s_plus = cl.sliding_variable(e1 + dt * e2 + dt**2 / 2 * e2_dot, e2 + dt * e2_dot, gains)
    s_minus = cl.sliding_variable(e1 - dt * e2 + dt**2 / 2 * e2_dot, e2 - dt * e2_dot, gains)
    s_dot = (s_plus - s_minus) / (2 * dt)
    expected = -gains.nu2 * cl.sig(s, gains.m2n2) - gains.eta2 * cl.sig(s, gains.p2q2)
    np.testing.assert_allclose(s_dot, expected, rtol=1e-4, atol=1e-9)


def test_wrong_kappa_power_would_be_detected():
    # the identity above distinguishes kappa^(-q1/p1) from kappa^(1 - q1/p1) ([A8]): the
    # two terms differ by a factor kappa = 1/(nu1|e1|^b + eta1) ~ 25, far beyond rtol 1e-4
    e1 = np.array([0.5])
    kappa = 1.0 / (0.001 * abs(e1) ** 1.1 + 0.04)
    assert abs(kappa[0] - 1.0) > 10.0


@given(st.floats(-1e6, 1e6, allow_nan=False))
def test_saturation_bounded_and_identity_near_zero(x):
    # spec test 6
    lim = np.array([2.0])
    y = cl.saturate(np.array([x]), lim)[0]
    assert abs(y) <= 2.0
    if abs(x) < 20.0:  # tanh(10) < 1 in double precision
        assert abs(y) < 2.0
    if abs(x) < 0.02:  # tanh(z) = z - z^3/3: relative shrink x^2 / (3 u^2) < 3.4e-5
        assert y == pytest.approx(x, rel=4e-5, abs=1e-300)


def test_observer_converges_on_a_known_disturbance():
    # spec test 7: FT-DO alone; e2_dot = d(t) with |d_dot| = 0.01 sqrt(6) < lambda3 = 0.1.
    gains = PARAMS.gains()
    k = np.arange(6)
    amp, w = 0.02, 0.5

    def d(t):
        return amp * np.sin(w * t + k)[None, :]

    def e2(t):
        return -amp / w * np.cos(w * t + k)[None, :]

    zero = np.zeros((1, 6))
    psi1, psi2 = scenario.PSI1_0[None, :].copy(), scenario.PSI2_0[None, :].copy()
    h = 0.01
    t_settle, eps2_late = 0.0, 0.0
    for i in range(2000):
        t = i * h

        def rhs(tt, p1, p2):
            return cl.observer_rhs(p1, p2, e2(tt), zero, zero, gains)

        a1, a2 = rhs(t, psi1, psi2)
        b1, b2 = rhs(t + h / 2, psi1 + h / 2 * a1, psi2 + h / 2 * a2)
        c1, c2 = rhs(t + h / 2, psi1 + h / 2 * b1, psi2 + h / 2 * b2)
        d1, d2 = rhs(t + h, psi1 + h * c1, psi2 + h * c2)
        psi1 = psi1 + h / 6 * (a1 + 2 * b1 + 2 * c1 + d1)
        psi2 = psi2 + h / 6 * (a2 + 2 * b2 + 2 * c2 + d2)
        if np.linalg.norm(psi1 - e2(t + h)) > 1e-3:
            t_settle = t + h
        if t + h >= 10.0:
            eps2_late = max(eps2_late, np.abs(psi2 - d(t + h)).max())
    assert t_settle <= 5.0
    assert eps2_late <= 10 * gains.lam3 * h


@pytest.mark.slow
def test_relative_kinematics_match_absolute_propagation():
    # spec test 2: integrate (sigma_{B/N}, omega) and (sigma_e, omega) side by side, no control.
    rng = np.random.default_rng(7)
    batch = _batch(1, rng)
    ref = PLANT.reference
    sig_t0 = scenario.reference_attitude(ref, 0.0)
    sig_e0 = scenario.SIGMA_E0
    sig_bn0 = mrp.from_dcm(mrp.dcm(sig_e0) @ mrp.dcm(sig_t0))
    x = np.zeros((1, 12))
    x[0, SIGMA_E] = sig_e0
    x[0, OMEGA] = scenario.OMEGA_E0 + mrp.dcm(sig_e0) @ PLANT.omega_t
    u = np.zeros((1, 6))

    def f_err(t, y):
        return cl.plant_rhs(t, y, u, batch, PLANT)

    def f_abs(t, y):
        # (sigma_{B/N}, omega): omega_dot from the same truth model
        out = np.zeros_like(y)
        out[:, SIGMA_E] = np.einsum("nij,nj->ni", mrp.kinematics_matrix(y[:, SIGMA_E]), y[:, OMEGA])
        out[:, OMEGA] = cl.plant_rhs(t, y, u, batch, PLANT)[:, OMEGA]
        return out

    ya = x.copy()
    ya[0, SIGMA_E] = sig_bn0
    h = 0.2  # RK4 local error ~ (|omega| h)^5 ~ 1e-13 per step; 1000 steps stay below 1e-9
    for i in range(1000):
        t = i * h
        for f, name in ((f_err, "e"), (f_abs, "a")):
            y = x if name == "e" else ya
            k1 = f(t, y)
            k2 = f(t + h / 2, y + h / 2 * k1)
            k3 = f(t + h / 2, y + h / 2 * k2)
            k4 = f(t + h, y + h * k3)
            y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
            y[:, SIGMA_E] = mrp.shadow(y[:, SIGMA_E])
            if name == "e":
                x = y
            else:
                ya = y
    sig_t = scenario.reference_attitude(ref, 200.0)
    sig_e_abs = mrp.shadow(mrp.relative(ya[0, SIGMA_E], sig_t))
    np.testing.assert_allclose(x[0, SIGMA_E], sig_e_abs, atol=1e-9)
    np.testing.assert_allclose(x[0, OMEGA], ya[0, OMEGA], atol=1e-12)
