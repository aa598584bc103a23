"""The GMM-FTC closed loop's settings and result (:func:`.kernel_numba.run_closed_loop_numba`).

At ``t_k = k dt`` (``dt = 0.1 s``, [C] 4.2) the law computes ``u_k`` from the sampled body-frame
state and the plant matrices at ``t_k``; the thrust is corrupted (per-sample per-axis scale,
per-period +-5 % noise) and held over ``[t_k, t_k + dt)``; the body-frame plant is propagated by
classical RK4 with ``n_sub`` sub-steps per period (``n_sub = 1`` in [C]: "integration step =
control period"). What the paper's claims need is accumulated at every step, so the recorded
grid can be coarser than the step (:func:`scalar_results`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..time_grid import recording_stride, whole_steps


@dataclass(frozen=True)
class LoopSettings:
    """Timing, thrust error and claim thresholds of one closed-loop run (SI units).

    ``t_final`` [s] is a multiple of ``dt``, and of ``record_every`` periods; ``thrust_noise``
    is the half-width ``w`` of the per-axis, per-period thrust factor ``1 + U(-w, w)``;
    ``converge_tol`` [m], ``velocity_tol`` [m/s] set the convergence times, the coarser
    ``settle_tol`` [m] a settling time a steady offset does not censor, ``s2_tol`` [m/s] the
    reaching time of ``||s2||``; ``t_check`` [s] starts the "converged" window of the claims;
    ``u_max`` [m/s^2] limits the commanded acceleration's norm (``inf``: none, as in [C]).
    """

    dt: float = 0.1
    n_sub: int = 1
    t_final: float = 300.0
    record_every: int = 10
    thrust_noise: float = 0.0
    converge_tol: float = 1e-4
    settle_tol: float = 1e-2
    velocity_tol: float = 1e-4
    s2_tol: float = 1e-6
    t_check: float = 150.0
    u_max: float = np.inf

    def __post_init__(self) -> None:
        # the kernel relies on a whole number of recorded periods
        recording_stride(self.record_every * self.dt, self.dt,
                         whole_steps(self.t_final, self.dt, "t_final"), "record_every * dt")

    @property
    def n_steps(self) -> int:
        return int(round(self.t_final / self.dt))


@dataclass
class LoopRun:
    """Result of a closed-loop run of ``n`` samples on the recording times ``time (T,)`` [s].

    ``goal`` is the law's ``r_f`` [m]; ``r``, ``v``, ``u`` ``(n, T, 3)`` the body-frame
    position [m], velocity [m/s] and applied thrust acceleration [m/s^2] held from each
    recording time (at ``t_final``: the command computed there); ``s2 (n, T)`` is ``||s2||``
    [m/s]; ``r_l``, ``v_l``, ``u_l``, ``u_eq32_l`` their LVLH forms (``C u``, and the [C 32]
    diagnostic ``C (u + 2 w x v + w x (w x r))``); ``dv_cum (n, T)`` the accumulated delta-v
    [m/s]; ``scalars`` those of :func:`scalar_results`; ``failed (n,)`` where a state became
    non-finite.
    """

    time: np.ndarray
    goal: np.ndarray
    r: np.ndarray
    v: np.ndarray
    u: np.ndarray
    s2: np.ndarray
    r_l: np.ndarray
    v_l: np.ndarray
    u_l: np.ndarray
    u_eq32_l: np.ndarray
    dv_cum: np.ndarray
    scalars: dict[str, np.ndarray]
    failed: np.ndarray


def scalar_results(*, bad: dict[str, np.ndarray], dt: float, t_final: float, n_steps: int,
                   pos_final: np.ndarray, speed_final: np.ndarray, speed_max: np.ndarray,
                   speed_axes: np.ndarray, u_max: np.ndarray, u_conv: np.ndarray,
                   u_lo: np.ndarray, u_hi: np.ndarray, u_last: np.ndarray,
                   delta_v: np.ndarray, clearance: np.ndarray, penetration: np.ndarray,
                   hits: np.ndarray, range_min: np.ndarray, n_guarded: np.ndarray,
                   n_nonfinite: np.ndarray) -> dict[str, np.ndarray]:
    """The ``scalars`` of a :class:`LoopRun` from the per-sample accumulators (the kernel's and
    its test oracle's).

    ``bad`` holds, per threshold, the index of the last control step that violated it (-1:
    none); the time after which it holds is the next sample time, ``t_final`` when violated at
    the end (censored).
    """
    t = {k: np.minimum((np.asarray(v) + 1) * dt, t_final) for k, v in bad.items()}
    converged = np.asarray(bad["bad_e"]) < n_steps
    span = np.where(np.isfinite(u_hi - u_lo), u_hi - u_lo, np.nan)
    return {
        "t_converge": t["bad_e"],
        "converged": converged.astype(float),
        "t_settle": t["bad_settle"],
        "t_converge_vel": t["bad_v"],
        "t_reach_s2": t["bad_s2"],
        "t_speed_below": t["bad_speed"],
        "t_u_below": t["bad_u"],
        "pos_error_final": pos_final,
        "speed_final": speed_final,
        "speed_max": speed_max,
        "speed_max_axes": speed_axes,
        "u_max": u_max,
        "u_max_converged": np.where(converged, u_conv, np.nan),
        "u_spread_final": np.linalg.norm(span, axis=1),
        "u_final": np.linalg.norm(u_last, axis=1),
        "delta_v": delta_v,
        "clearance_parts": clearance,
        "min_clearance": clearance.min(axis=1),
        "penetration": penetration,
        "hits": hits,
        "collided": hits.any(axis=1).astype(float),
        "range_min": range_min,
        "n_guarded": n_guarded,
        "n_nonfinite": n_nonfinite,
    }
