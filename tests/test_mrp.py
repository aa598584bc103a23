"""Property tests of the MRP helpers (ft-as-controller.md section 1.1 identities)."""

from __future__ import annotations

import pytest
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from uqguide.models.dynamics import mrp

# |sigma| <= 1 is the principal set; up to 3 also exercises the shadow-set formulas.
component = st.floats(-1.0, 1.0, allow_nan=False, allow_infinity=False)
vec = arrays(np.float64, 3, elements=component)
big_vec = arrays(np.float64, 3, elements=st.floats(-3.0, 3.0, allow_nan=False))
# strictly inside the unit ball: |sigma| = 1 is the 180-deg rotation, where both sets coincide
principal = vec.filter(lambda s: float(s @ s) < 0.99)
rate = arrays(np.float64, 3, elements=st.floats(-0.5, 0.5, allow_nan=False))


@given(big_vec)
def test_dcm_is_a_rotation(sigma):
    C = mrp.dcm(sigma)
    np.testing.assert_allclose(C @ C.T, np.eye(3), atol=1e-13)
    assert np.linalg.det(C) > 0.0


@given(big_vec)
def test_inverse_kinematics_matrix(sigma):
    np.testing.assert_allclose(
        mrp.kinematics_matrix_inv(sigma) @ mrp.kinematics_matrix(sigma), np.eye(3), atol=1e-12
    )


@given(vec, rate)
def test_kinematics_matrix_dot_is_the_derivative(sigma, sigma_dot):
    # central difference along sigma + t sigma_dot: G is quadratic in sigma, so the central
    # difference is exact up to rounding (~1e-16 / d)
    d = 1e-4
    G_plus = mrp.kinematics_matrix(sigma + d * sigma_dot)
    fd = (G_plus - mrp.kinematics_matrix(sigma - d * sigma_dot)) / (2 * d)
    np.testing.assert_allclose(mrp.kinematics_matrix_dot(sigma, sigma_dot), fd, atol=1e-10)


@pytest.mark.slow
@given(vec, rate)
def test_dcm_rate_is_minus_skew_omega_times_dcm(sigma, omega):
    # sigma_dot = G omega; d/dt C = -S(omega) C. Fourth-order central difference along the
    # exact trajectory (RK4 micro-steps), truncation ~ d^4 |C^(5)| << 1e-9.
    def flow(s0, t):
        n = 8
        hh = t / n
        s = s0.copy()
        for _ in range(n):
            k1 = mrp.kinematics_matrix(s) @ omega
            k2 = mrp.kinematics_matrix(s + hh / 2 * k1) @ omega
            k3 = mrp.kinematics_matrix(s + hh / 2 * k2) @ omega
            k4 = mrp.kinematics_matrix(s + hh * k3) @ omega
            s = s + hh / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        return s

    d = 1e-3
    Cp, Cm = mrp.dcm(flow(sigma, d)), mrp.dcm(flow(sigma, -d))
    Cp2, Cm2 = mrp.dcm(flow(sigma, 2 * d)), mrp.dcm(flow(sigma, -2 * d))
    fd = (8 * (Cp - Cm) - (Cp2 - Cm2)) / (12 * d)
    np.testing.assert_allclose(fd, -mrp.skew(omega) @ mrp.dcm(sigma), atol=1e-9)


@given(principal)
def test_from_dcm_inverts_dcm_on_the_principal_set(sigma):
    np.testing.assert_allclose(mrp.from_dcm(mrp.dcm(sigma)), sigma, atol=1e-12)


@given(big_vec)
def test_shadow_set_is_the_same_attitude(sigma):
    s = mrp.shadow(sigma)
    assert np.dot(s, s) <= 1.0 + 1e-12
    np.testing.assert_allclose(mrp.dcm(s), mrp.dcm(sigma), atol=1e-12)


@settings(max_examples=200)
@given(vec, vec)
def test_relative_mrp_composes_rotations(sigma, sigma_t):
    # C(sigma_{B/R}) = C(sigma_{B/N}) C(sigma_{R/N})^T  (paper eq 4)
    den = 1.0 + np.dot(sigma_t, sigma_t) * np.dot(sigma, sigma) + 2 * np.dot(sigma_t, sigma)
    if den < 1e-3:  # eq 4 is singular where the relative rotation is 360 deg
        return
    np.testing.assert_allclose(
        mrp.dcm(mrp.relative(sigma, sigma_t)), mrp.dcm(sigma) @ mrp.dcm(sigma_t).T, atol=1e-9
    )


def test_batched_shapes():
    s = np.random.default_rng(0).uniform(-0.5, 0.5, (4, 2, 3))
    assert mrp.dcm(s).shape == (4, 2, 3, 3)
    assert mrp.kinematics_matrix_dot(s, s).shape == (4, 2, 3, 3)
    np.testing.assert_allclose(mrp.from_dcm(mrp.dcm(s)), s, atol=1e-12)
    np.testing.assert_allclose(mrp.skew(s[0, 0]) @ s[1, 1], np.cross(s[0, 0], s[1, 1]))
