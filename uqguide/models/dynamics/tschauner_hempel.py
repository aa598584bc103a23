"""Tschauner-Hempel linearised relative motion about an elliptical chief orbit.

``r'' = A(f) r + B(f) r' + u`` in LVLH axes (:class:`ChiefOrbit`, :class:`LVLHPlant`), corrected
where both papers misprint ``A(1, 1)`` and ``dw/dt`` (A2, A3); :func:`rk4_transition` gives the
exact linear maps RK4 realises over a period, so a batch advances by one matrix product per
sub-step. The equations and corrections:
docs/papers.md#relative-motion-near-an-elliptical-orbit-and-a-spinning-target.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

MU_EARTH = 3.986e14
"""Earth's gravitational parameter [m^3/s^2] as used by both GMM papers ([W] 4.1, [C] 2.3)."""


@dataclass(frozen=True)
class ChiefOrbit:
    """Keplerian orbit of the chief: semi-major axis ``a`` [m], eccentricity ``0 <= e < 1``,
    true anomaly ``f0`` [rad] at ``t = 0`` ([W] does not publish it; A4: 0), ``mu``
    [m^3/s^2]."""

    a: float
    e: float
    f0: float = 0.0
    mu: float = MU_EARTH

    def __post_init__(self) -> None:
        if not self.a > 0:
            raise ValueError(f"the semi-major axis must be positive, got a = {self.a} m")
        if not 0 <= self.e < 1:
            raise ValueError(f"the eccentricity must be in [0, 1) for a closed orbit, got {self.e}")

    @property
    def mean_motion(self) -> float:
        """``n = sqrt(mu / a^3)`` [rad/s]."""
        return float(np.sqrt(self.mu / self.a**3))

    def radius(self, f: np.ndarray | float) -> np.ndarray:
        """Chief orbit radius ``r_c = a (1 - e^2) / (1 + e cos f)`` [m], ``f`` [rad]."""
        return self.a * (1 - self.e**2) / (1 + self.e * np.cos(f))

    def omega(self, f: np.ndarray | float) -> np.ndarray:
        """Orbit (LVLH) rate ``df/dt = n (1 + e cos f)^2 / (1 - e^2)^{3/2}`` [rad/s] [W 4]."""
        return self.mean_motion * (1 + self.e * np.cos(f)) ** 2 / (1 - self.e**2) ** 1.5

    def omega_dot(self, f: np.ndarray | float, printed: bool = False) -> np.ndarray:
        """Orbit angular acceleration [rad/s^2] at true anomaly ``f`` [rad].

        ``-2 n^2 e sin f (1 + e cos f)^3 / (1 - e^2)^3`` (A3). With ``printed=True`` the
        (wrong) form printed in [W 5] / [C 3], ``+2 n^2 e sin f (1 + e cos f)^3 / (1 - e^2)^{3/2}``.
        """
        n2 = self.mean_motion**2
        core = 2 * n2 * self.e * np.sin(f) * (1 + self.e * np.cos(f)) ** 3
        if printed:
            return core / (1 - self.e**2) ** 1.5
        return -core / (1 - self.e**2) ** 3


class RelativePlant(Protocol):
    """A linear relative-motion plant ``r'' = A(t, f) r + B(t, f) r' + u`` on a shared orbit.

    Implemented by :class:`LVLHPlant`; a body-frame plant of a spinning chief
    (:mod:`.rotating_body_frame`) has the same interface with time-dependent matrices.
    """

    # Read-only, so that frozen dataclasses (LVLHPlant) satisfy the protocol.
    @property
    def orbit(self) -> ChiefOrbit: ...

    def matrices(self, t: float, f: float) -> tuple[np.ndarray, np.ndarray]:
        """``A`` [1/s^2], ``B`` [1/s], each (3, 3), at time ``t`` [s] and chief true anomaly
        ``f`` [rad]."""
        ...


@dataclass(frozen=True)
class LVLHPlant:
    """Tschauner-Hempel plant in LVLH axes; ``printed_omega_dot``: the papers'
    printed ``dw/dt`` (wrong sign and exponent) instead of the correct one."""

    orbit: ChiefOrbit
    printed_omega_dot: bool = False

    def matrices(self, t: float, f: float) -> tuple[np.ndarray, np.ndarray]:
        """``A(f)``, ``B(f)`` of [W 2-3] (corrected); ``t`` is unused in LVLH."""
        w = float(self.orbit.omega(f))
        wd = float(self.orbit.omega_dot(f, printed=self.printed_omega_dot))
        k = self.orbit.mu / float(self.orbit.radius(f)) ** 3
        A = np.array([[w * w + 2 * k, wd, 0.0], [-wd, w * w - k, 0.0], [0.0, 0.0, -k]])
        B = np.array([[0.0, 2 * w, 0.0], [-2 * w, 0.0, 0.0], [0.0, 0.0, 0.0]])
        return A, B


def _augmented(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The (9, 9) matrix of ``d/dt [r, v, u] = [v, A r + B v + u, 0]``."""
    F = np.zeros((9, 9))
    F[0:3, 3:6] = np.eye(3)
    F[3:6, 0:3] = A
    F[3:6, 3:6] = B
    F[3:6, 6:9] = np.eye(3)
    return F


@dataclass(frozen=True)
class StepMaps:
    """Linear maps realised by RK4 over one control period with a held control:
    ``x(t0 + (j+1) h) = phi[j] x(t0) + gam[j] u`` for sub-step ``j`` (``h = dt / n_sub``;
    ``phi (n_sub, 6, 6)``, ``gam (n_sub, 6, 3)``), and the chief's true anomaly ``f_end`` [rad]
    at the end of the period."""

    phi: np.ndarray
    gam: np.ndarray
    f_end: float


def rk4_transition(plant: RelativePlant, t0: float, f0: float, dt: float, n_sub: int) -> StepMaps:
    """Maps of ``n_sub`` classical RK4 sub-steps over ``[t0, t0 + dt]`` [s] with the control held,
    from the true anomaly ``f0`` [rad] at ``t0``.

    The true anomaly is integrated by the same RK4 (``df/dt = w(f)``) and the plant matrices
    are evaluated at every stage time and stage anomaly, exactly as an RK4 of the coupled state
    ``(r, v, f)`` would.
    """
    h = dt / n_sub
    orbit = plant.orbit
    X = np.eye(9)
    phis = np.empty((n_sub, 6, 6))
    gams = np.empty((n_sub, 6, 3))
    t, f = t0, f0
    for j in range(n_sub):
        k1f = float(orbit.omega(f))
        f2 = f + 0.5 * h * k1f
        k2f = float(orbit.omega(f2))
        f3 = f + 0.5 * h * k2f
        k3f = float(orbit.omega(f3))
        f4 = f + h * k3f
        k4f = float(orbit.omega(f4))
        F1 = _augmented(*plant.matrices(t, f))
        F2 = _augmented(*plant.matrices(t + 0.5 * h, f2))
        F3 = _augmented(*plant.matrices(t + 0.5 * h, f3))
        F4 = _augmented(*plant.matrices(t + h, f4))
        K1 = F1 @ X
        K2 = F2 @ (X + 0.5 * h * K1)
        K3 = F3 @ (X + 0.5 * h * K2)
        K4 = F4 @ (X + h * K3)
        X = X + (h / 6.0) * (K1 + 2 * K2 + 2 * K3 + K4)
        f = f + (h / 6.0) * (k1f + 2 * k2f + 2 * k3f + k4f)
        t = t + h
        phis[j] = X[0:6, 0:6]
        gams[j] = X[0:6, 6:9]
    return StepMaps(phi=phis, gam=gams, f_end=f)


def propagate_free(
    plant: RelativePlant, x0: np.ndarray, t_f: float, dt: float, n_sub: int = 1
) -> np.ndarray:
    """Unforced propagation (``u = 0``) of states ``x0`` (n, 6) ``[r (m), v (m/s)]`` at ``t = 0``
    (true anomaly ``plant.orbit.f0``); the states (n, N + 1, 6) at ``t = 0, dt, ..., t_f``
    (``dt`` [s] with ``n_sub`` RK4 sub-steps, ``t_f`` a multiple of it)."""
    n_steps = int(round(t_f / dt))
    x = np.asarray(x0, dtype=float)
    out = np.empty((x.shape[0], n_steps + 1, 6))
    out[:, 0] = x
    f = plant.orbit.f0
    for k in range(n_steps):
        maps = rk4_transition(plant, k * dt, f, dt, n_sub)
        x = x @ maps.phi[-1].T
        f = maps.f_end
        out[:, k + 1] = x
    return out
