"""The GMM proximity closed loop's inputs and result: the RK4 maps of every control period and
what a batch run returns (:func:`.kernel_numba.simulate_compiled`).

At ``t_k = k dt`` the controller computes ``u_k`` from the sampled state and the plant matrices
at ``(t_k, f(t_k))``; the command is saturated and held over ``[t_k, t_k + dt)`` (zero-order
hold), and the plant is propagated by classical RK4 with ``n_sub`` sub-steps per period. The
plant is linear and the chief orbit shared by the batch, so the RK4 maps of every sub-step are
computed once (:class:`StepSchedule`) and a batch is advanced by matrix products.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.tschauner_hempel import RelativePlant, rk4_transition
from ..time_grid import whole_steps


@dataclass(frozen=True)
class StepSchedule:
    """Plant matrices at the sample times and RK4 maps of every control period: sample
    ``times (N + 1,)`` ``k dt`` [s] and the chief's true anomaly ``f`` there [rad]; ``A``,
    ``B (N, 3, 3)`` the plant matrices the controllers cancel; ``phi (N, n_sub, 6, 6)``, ``gam
    (N, n_sub, 6, 3)`` with ``x(t_k + (j+1) h) = phi[k, j] x(t_k) + gam[k, j] u_k``."""

    dt: float
    times: np.ndarray
    f: np.ndarray
    A: np.ndarray
    B: np.ndarray
    phi: np.ndarray
    gam: np.ndarray

    @property
    def n_steps(self) -> int:
        return int(self.A.shape[0])

    @property
    def n_sub(self) -> int:
        return int(self.phi.shape[1])

    def coast_to_end(self) -> np.ndarray:
        """``Phi(t_f, t_k)`` of the unforced plant for every ``k``, shape (N + 1, 6, 6)."""
        N = self.n_steps
        out = np.empty((N + 1, 6, 6))
        out[N] = np.eye(6)
        for k in range(N - 1, -1, -1):
            out[k] = out[k + 1] @ self.phi[k, -1]
        return out


def build_schedule(plant: RelativePlant, t_f: float, dt: float, n_sub: int) -> StepSchedule:
    """The :class:`StepSchedule` of ``plant`` on ``[0, t_f]`` [s] with the control period ``dt``
    (``t_f`` a multiple of it) and ``n_sub`` RK4 sub-steps per period."""
    n_steps = whole_steps(t_f, dt, "t_f")
    if n_sub < 1:
        raise ValueError(f"n_sub must be at least 1, got {n_sub}")
    f = np.empty(n_steps + 1)
    A = np.empty((n_steps, 3, 3))
    B = np.empty((n_steps, 3, 3))
    phi = np.empty((n_steps, n_sub, 6, 6))
    gam = np.empty((n_steps, n_sub, 6, 3))
    f[0] = plant.orbit.f0
    for k in range(n_steps):
        A[k], B[k] = plant.matrices(k * dt, f[k])
        maps = rk4_transition(plant, k * dt, f[k], dt, n_sub)
        phi[k], gam[k], f[k + 1] = maps.phi, maps.gam, maps.f_end
    return StepSchedule(dt=dt, times=np.arange(n_steps + 1) * dt, f=f, A=A, B=B, phi=phi, gam=gam)


@dataclass
class SampledRun:
    """What a closed-loop run returns for a batch of ``n`` runs (SI units).

    On the recording times ``time (T,)`` [s]: ``r``, ``v (n, T, 3)`` position [m] and velocity
    [m/s] in the plant's axes, ``zem (n, T)`` the zero-effort miss to the goal at ``t_f`` [m]
    and ``delta_v_history (n, T)`` [m/s]; ``u (n, N, 3)`` the applied control per period
    [m/s^2] (``zem`` and ``u`` only if asked for). Per run: ``delta_v`` ``sum ||u_k|| dt``
    [m/s] ([W 24], exact for a ZOH), ``clearance (n, P)`` the path's (every sub-step) least
    distance to each part's skeleton [m], ``penetration`` the deepest point inside the solid
    body [m], ``hits (n, P)`` swept-segment collisions with each part's collision box,
    ``min_range`` the least distance to the chief's centre [m], ``n_saturated`` periods with a
    saturated command, ``n_nonfinite`` non-finite commands replaced by 0, and ``failed``
    where a state became non-finite.
    """

    time: np.ndarray
    r: np.ndarray
    v: np.ndarray
    zem: np.ndarray | None
    delta_v_history: np.ndarray
    u: np.ndarray | None
    delta_v: np.ndarray
    clearance: np.ndarray
    penetration: np.ndarray
    hits: np.ndarray
    min_range: np.ndarray
    n_saturated: np.ndarray
    n_nonfinite: np.ndarray
    failed: np.ndarray

    @property
    def collided(self) -> np.ndarray:
        """Any part hit, shape (n,)."""
        return np.asarray(self.hits.any(axis=1))
