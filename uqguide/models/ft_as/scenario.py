"""Scenario of the FT-AS paper (Wei et al. 2024, section 5.1).

The reference orbit (circular, propagated in closed form), the initial tracking errors of
Table 1 computed from the two orbits' elements, and the truth model's time-varying mass,
inertia and disturbances. Everything is numpy, batched over a leading sample axis where a
quantity depends on an uncertain input; the numba kernel (``kernel_numba.py``) evaluates the same
formulas per sample and is checked against these functions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics import mrp

MU_EARTH = 3.986e14
"""Earth's gravitational parameter [m^3/s^2] (paper section 5.1; [A17], confirmed by Table 1)."""

# Table 1 attitude errors: sigma_e(0) [-] and omega_e(0) [rad/s].
SIGMA_E0 = np.array([0.10, 0.05, -0.15])
OMEGA_E0 = np.array([0.01, -0.02, 0.015])

# Observer initial state, section 5.1 ([A4]: the exponent of psi_2(0) is unreadable, 1e-5).
PSI1_0 = np.array([1.0, 2.0, 4.0, 2.0, 1.0, 2.0]) * 1e-5
PSI2_0 = np.array([1.0, 1.0, 1.0, 0.2, -0.4, 0.4]) * 1e-5

# Nominal inertia [kg m^2] ([A3]: J0(3,3) = 62.9, the OCR prints "629").
J0_NOMINAL = np.array([[166.5, 4.44, 3.33], [4.44, 74.0, 5.18], [3.33, 5.18, 62.9]])


@dataclass(frozen=True)
class CircularOrbit:
    """A circular Keplerian orbit: radius ``a`` [m]; inclination, right ascension of the ascending
    node, argument of perigee and mean anomaly at t = 0 [deg]; ``mu`` [m^3/s^2]."""

    a: float
    inc: float = 28.5
    raan: float = 100.0
    argp: float = 0.0
    m0: float = 130.0
    mu: float = MU_EARTH

    @property
    def mean_motion(self) -> float:
        """``n = sqrt(mu / a^3)`` [rad/s]."""
        return float(np.sqrt(self.mu / self.a**3))

    def basis(self) -> tuple[np.ndarray, np.ndarray]:
        """Perifocal-like unit vectors ``P`` (to the node) and ``Q`` (90 deg ahead), ECI, (3,)."""
        O, i = np.radians(self.raan), np.radians(self.inc)
        P = np.array([np.cos(O), np.sin(O), 0.0])
        Q = np.array([-np.sin(O) * np.cos(i), np.cos(O) * np.cos(i), np.sin(i)])
        return P, Q

    def state(self, t: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Position [m] and velocity [m/s] (..., 3) in ECI at times ``t`` [s]."""
        P, Q = self.basis()
        n = self.mean_motion
        u = np.radians(self.argp + self.m0) + n * np.asarray(t, dtype=float)
        c, s = np.cos(u)[..., None], np.sin(u)[..., None]
        return self.a * (c * P + s * Q), self.a * n * (-s * P + c * Q)


def rtn_dcm(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """DCM ``C_{R/N}`` of the RTN frame (rows: radial, along-track, normal in ECI), (..., 3, 3)."""
    x = r / np.linalg.norm(r, axis=-1, keepdims=True)
    hvec = np.cross(r, v)
    z = hvec / np.linalg.norm(hvec, axis=-1, keepdims=True)
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=-2)


def reference_attitude(orbit: CircularOrbit, t: np.ndarray | float) -> np.ndarray:
    """``sigma_t = sigma_{R/N}(t)``, MRP of the reference orbit's RTN frame ([A1]), (..., 3)."""
    r, v = orbit.state(t)
    return mrp.from_dcm(rtn_dcm(r, v))


def initial_orbit_errors(
    actual: CircularOrbit, reference: CircularOrbit
) -> tuple[np.ndarray, np.ndarray]:
    """``r_e(0) = r(0) - r_t(0)`` [m] and ``v_e(0)`` [m/s] in ECI (Table 1), each (3,)."""
    r, v = actual.state(0.0)
    rt, vt = reference.state(0.0)
    return r - rt, v - vt


def mass_true(t: np.ndarray | float, m0: float, offset: np.ndarray | float = 0.0) -> np.ndarray:
    """``m(t) = m0 + 1 + 0.1 sin(0.1 t) + offset`` [kg] (section 3.1, [R]/[A5]).

    ``offset`` is the dispersion input ``mass_offset`` (0 in the paper).
    """
    return m0 + 1.0 + 0.1 * np.sin(0.1 * np.asarray(t)) + offset


def inertia_delta_diag(t: np.ndarray | float) -> np.ndarray:
    """Diagonal of ``Delta J(t) = diag(0.1 + 0.01 sin(0.1 k t))``, k = 1..3 [kg m^2], (..., 3)."""
    t = np.asarray(t, dtype=float)[..., None]
    return 0.1 + 0.01 * np.sin(np.array([0.1, 0.2, 0.3]) * t)


def force_disturbance(t: np.ndarray | float, amplitude: np.ndarray | float) -> np.ndarray:
    """``d_f(t) = A_f [sin 0.1t, cos 0.2t, sin 0.3t]`` [N], ECI, (..., 3) ([A2])."""
    t = np.asarray(t, dtype=float)
    w = np.stack([np.sin(0.1 * t), np.cos(0.2 * t), np.sin(0.3 * t)], axis=-1)
    return np.asarray(amplitude, dtype=float)[..., None] * w


def torque_disturbance(t: np.ndarray | float, amplitude: np.ndarray | float) -> np.ndarray:
    """``d_tau(t) = A_tau [2 sin 0.1t, 2 cos 0.2t, 2 sin 0.3t]`` [N m], body, (..., 3) ([A2])."""
    return 2.0 * force_disturbance(t, amplitude)
