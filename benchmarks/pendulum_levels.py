"""A three-level pendulum for ``benchmarks/multifidelity.py --case pendulum``: the user's
``callable`` levels, a module that imports NumPy only (as a user's would)."""

from __future__ import annotations

import numpy as np

#: ``theta'' = -(g / L) sin theta - c theta'`` from rest at ``theta_0``, explicit Euler to
#: ``PENDULUM_T``: the steps of the three levels, finest first
PENDULUM_T, PENDULUM_STEPS = 4.0, (4000, 1000, 250)


def _pendulum(x: np.ndarray, steps: int) -> np.ndarray:
    """The angle at ``PENDULUM_T`` [rad] of ``x (n, 3)``: theta_0 [rad], length [m], damping
    [1/s], in ``steps`` explicit Euler steps (vectorised over the rows, as a user's would be)."""
    theta, w2, c = x[:, 0].copy(), 9.81 / x[:, 1], x[:, 2]
    omega = np.zeros_like(theta)
    dt = PENDULUM_T / steps
    for _ in range(steps):
        theta, omega = theta + dt * omega, omega - dt * (w2 * np.sin(theta) + c * omega)
    return theta


def pendulum_fine(x: np.ndarray) -> np.ndarray:
    """The pendulum's highest level (dt = 1 ms)."""
    return _pendulum(x, PENDULUM_STEPS[0])


def pendulum_mid(x: np.ndarray) -> np.ndarray:
    """dt = 4 ms."""
    return _pendulum(x, PENDULUM_STEPS[1])


def pendulum_coarse(x: np.ndarray) -> np.ndarray:
    """dt = 16 ms."""
    return _pendulum(x, PENDULUM_STEPS[2])


def pendulum_unrelated(x: np.ndarray) -> np.ndarray:
    """A cheap level uncorrelated with the pendulum (a fast-oscillating function of the inputs):
    ``mfmc`` falls back to plain Monte Carlo of the highest level."""
    return np.sin(1e4 * x[:, 0] * x[:, 1])
