"""Relative motion in the body frame of a target spinning on an elliptical orbit ([C] eqs 1-9).

``r_b'' = A21 r_b + A22 r_b' + u_b`` with the corrected [C 7] matrices
(:func:`body_frame_matrices`; the printed form behind ``printed=True``, A20), a spin rate common
or per sample (:class:`RotatingBodyFrame`), the exact Kepler true anomaly on the half-step grid
RK4 needs (:func:`rk4_step`), and [C 32]'s "LVLH control" as a diagnostic only
(:func:`eq32_acceleration`, A24). The frames, the derivation and the corrections:
docs/papers.md#relative-motion-near-an-elliptical-orbit-and-a-spinning-target.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from .mrp import skew
from .tschauner_hempel import ChiefOrbit


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` for broadcastable (..., 3) arrays (``np.cross`` without its axis handling,
    which dominated the per-step cost of small batches)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def true_anomaly(orbit: ChiefOrbit, t: np.ndarray) -> np.ndarray:
    """Exact true anomaly ``f(t)`` [rad] of the target from Kepler's equation at times ``t``
    (T,) [s], with ``f(0) = orbit.f0``; continuous in ``t`` (not wrapped), so ``f(t) - f0`` is the
    swept angle."""
    e = orbit.e
    t = np.asarray(t, dtype=float)
    # f - E = 2 atan(beta sin E / (1 - beta cos E)) is continuous in E (no quadrant wrap), so
    # f stays continuous over revolutions; beta = e / (1 + sqrt(1 - e^2)).
    beta = e / (1 + np.sqrt(1 - e * e))
    f0 = orbit.f0
    E0 = f0 - 2.0 * np.arctan2(beta * np.sin(f0), 1 + beta * np.cos(f0))
    M = E0 - e * np.sin(E0) + orbit.mean_motion * t
    E = np.array(M, dtype=float)
    # Newton on E - e sin E = M converges quadratically from E = M for e < 1; 50 iterations
    # is a cap, the loop exits after 3-5 for the near-circular orbits of the papers.
    for _ in range(50):
        dE = (E - e * np.sin(E) - M) / (1 - e * np.cos(E))
        E -= dE
        if np.max(np.abs(dE), initial=0.0) < 1e-15:
            break
    return E + 2.0 * np.arctan2(beta * np.sin(E), 1 - beta * np.cos(E))


def lvlh_matrices(
    orbit: ChiefOrbit, f: np.ndarray, printed_omega_dot: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """Tschauner-Hempel ``A(f)`` [1/s^2], ``B(f)`` [1/s], each (T, 3, 3), at true anomalies ``f``
    (T,) ([C 2-3], corrected: A2); ``printed_omega_dot``: the printed ``dw/dt`` (wrong sign and
    exponent, A3)."""
    f = np.atleast_1d(np.asarray(f, dtype=float))
    w = orbit.omega(f)
    wd = orbit.omega_dot(f, printed=printed_omega_dot)
    k = orbit.mu / orbit.radius(f) ** 3
    A = np.zeros(f.shape + (3, 3))
    A[:, 0, 0] = w * w + 2 * k
    A[:, 0, 1] = wd
    A[:, 1, 0] = -wd
    A[:, 1, 1] = w * w - k
    A[:, 2, 2] = -k
    B = np.zeros(f.shape + (3, 3))
    B[:, 0, 1] = 2 * w
    B[:, 1, 0] = -2 * w
    return A, B


def spin_attitude(w: np.ndarray, t: float, C0: np.ndarray | None = None) -> np.ndarray:
    """Body -> LVLH attitudes (m, 3, 3) ``C(t) = C0 exp(t [w x])`` of a constant spin (Rodrigues).

    ``w`` (m, 3): spin rate of the body relative to LVLH, body components [rad/s]; ``t`` [s];
    ``C0``: attitude at ``t = 0``, identity by default ([C] Table 5).
    """
    w = np.atleast_2d(np.asarray(w, dtype=float))
    rate = np.linalg.norm(w, axis=1)
    axis = w / np.where(rate > 0, rate, 1.0)[:, None]
    angle = rate * t
    K = skew(axis)
    C = (
        np.eye(3)
        + np.sin(angle)[:, None, None] * K
        + (1 - np.cos(angle))[:, None, None] * (K @ K)
    )
    return C if C0 is None else np.asarray(C0, dtype=float) @ C


def body_frame_matrices(
    A: np.ndarray,
    B: np.ndarray,
    C: np.ndarray,
    w: np.ndarray,
    w_dot: np.ndarray | None = None,
    printed: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """``A21`` [1/s^2], ``A22`` [1/s], each (m, 3, 3), of the body-frame plant (the corrected
    [C 7], A20).

    ``A``, ``B`` (3, 3): LVLH plant at the current true anomaly; ``C`` (m, 3, 3): body -> LVLH
    attitude; ``w`` (m, 3): body rate relative to LVLH, body components [rad/s]; ``w_dot``: its
    body-frame derivative [rad/s^2] (0 in [C]); ``printed``: the sign-restored printed [C 7]
    (``A C``, ``B`` unrotated) instead of the correct form.
    """
    W = skew(w)
    W2 = _mm(W, W)
    if printed:
        Ab, Bb = _mm(A, C), np.broadcast_to(B, C.shape)
    else:
        Ct = np.swapaxes(C, -1, -2)
        Ab, Bb = _mm(_mm(Ct, A), C), _mm(_mm(Ct, B), C)
    A21 = Ab + _mm(Bb, W) - W2
    if w_dot is not None:
        A21 = A21 - skew(w_dot)
    return A21, Bb - 2.0 * W


def body_to_lvlh(
    C: np.ndarray, w: np.ndarray, r_b: np.ndarray, v_b: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity in LVLH from the body frame ([C 4-5]): ``r_l = C r_b``,
    ``v_l = C (v_b + w x r_b)`` (``v`` are frame derivatives in each frame).

    ``C`` (m, 3, 3), ``w`` (m, 3) [rad/s], ``r_b``, ``v_b`` (n, 3) [m], [m/s], ``m`` 1 or ``n``.
    """
    r_l = rotate(C, r_b)
    v_l = rotate(C, v_b + np.cross(w, r_b))
    return r_l, v_l


def lvlh_to_body(
    C: np.ndarray, w: np.ndarray, r_l: np.ndarray, v_l: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of :func:`body_to_lvlh`: ``r_b = C^T r_l``, ``v_b = C^T v_l - w x r_b``
    (shapes and units as there)."""
    Ct = np.swapaxes(C, -1, -2)
    r_b = rotate(Ct, r_l)
    return r_b, rotate(Ct, v_l) - np.cross(w, r_b)


def rotate(C: np.ndarray, x: np.ndarray, transpose: bool = False) -> np.ndarray:
    """``C x`` (or ``C^T x``) for ``C`` (m, 3, 3), ``m`` in {1, n}, and vectors ``x`` (n, 3).

    Element-wise products summed in a fixed order, so a sample gives bit-identical results in a
    batch with per-sample matrices and alone (a BLAS product may reorder the sums).
    """
    if transpose:
        return np.sum(C * x[:, :, None], axis=-2)
    return np.sum(C * x[:, None, :], axis=-1)


def _mm(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Batched 3x3 product ``A @ B`` in a fixed summation order (see :func:`rotate`)."""
    return np.sum(A[..., :, :, None] * B[..., None, :, :], axis=-2)


def eq32_acceleration(w: np.ndarray, r_b: np.ndarray, v_b: np.ndarray, u_b: np.ndarray
                      ) -> np.ndarray:
    """``u + 2 w x v_b + w x (w x r_b)`` of [C 32], body components [m/s^2].

    The difference between the relative accelerations seen in LVLH and in the body frame, not
    a different thrust (A24): a diagnostic to compare with [C] Fig. 11 once
    rotated to LVLH. The physical thrust in LVLH is ``C u_b``.
    """
    return u_b + 2.0 * np.cross(w, v_b) + np.cross(w, np.cross(w, r_b))


@dataclass(frozen=True)
class BodyFrameStage:
    """The body-frame plant at one instant, applied to states without forming ``A21``, ``A22``.

    ``A21 r + A22 v = C^T (A C r + B C (v + w x r)) - w x (w x r) - 2 w x v`` (the corrected
    [C 7], :func:`body_frame_matrices`; ``w' = 0``); with ``printed=True`` the sign-restored
    printed form ``A C r + B (v + w x r) - w x (w x r) - 2 w x v``. ``A``, ``B`` (3, 3): the LVLH
    matrices at the instant; ``C`` (m, 3, 3), ``w`` (m, 3) [rad/s] as in :func:`body_to_lvlh`.
    """

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    w: np.ndarray
    printed: bool = False

    def apply(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``A21 r + A22 v`` [m/s^2] for body-frame ``r`` [m], ``v`` [m/s], each (n, 3)."""
        wr = cross(self.w, r)
        frame = -cross(self.w, wr) - 2.0 * cross(self.w, v)
        A, B = self.A[None], self.B[None]
        if self.printed:
            return rotate(A, rotate(self.C, r)) + rotate(B, v + wr) + frame
        lvlh = rotate(A, rotate(self.C, r)) + rotate(B, rotate(self.C, v + wr))
        return rotate(self.C, lvlh, transpose=True) + frame

    def matrices(self) -> tuple[np.ndarray, np.ndarray]:
        """The plant's matrices (:func:`body_frame_matrices`)."""
        return body_frame_matrices(self.A, self.B, self.C, self.w, printed=self.printed)


@dataclass(frozen=True)
class LinearStage:
    """A plant given by its matrices, ``A21 r + A22 v`` (each (3, 3) or (m, 3, 3))."""

    A21: np.ndarray
    A22: np.ndarray

    def apply(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``A21 r + A22 v`` [m/s^2] for ``r`` [m], ``v`` [m/s], each (n, 3)."""
        A21 = np.asarray(self.A21, dtype=float).reshape(-1, 3, 3)
        A22 = np.asarray(self.A22, dtype=float).reshape(-1, 3, 3)
        return rotate(A21, r) + rotate(A22, v)


@dataclass(frozen=True)
class RotatingBodyFrame:
    """Body-frame plant of a target spinning at a constant rate on an elliptical ``orbit``
    (common to the batch): spin rate(s) ``w (m, 3)`` relative to LVLH, body components [rad/s]
    (``m = 1``, common, or ``n``); initial attitude ``C0``; ``printed``: the printed [C 7] form
    (:func:`body_frame_matrices`); ``printed_omega_dot``: the printed ``dw/dt`` (A3)."""

    orbit: ChiefOrbit
    w: np.ndarray
    C0: np.ndarray = field(default_factory=lambda: np.eye(3))
    printed: bool = False
    printed_omega_dot: bool = False

    def __post_init__(self) -> None:
        w = np.atleast_2d(np.asarray(self.w, dtype=float))
        if w.ndim != 2 or w.shape[1] != 3:
            raise ValueError(f"the spin rate must have shape (m, 3), got {w.shape}")
        C0 = np.asarray(self.C0, dtype=float)
        if C0.shape != (3, 3) or not np.allclose(C0 @ C0.T, np.eye(3), atol=1e-12):
            raise ValueError("the initial attitude C0 must be a 3x3 rotation matrix")
        object.__setattr__(self, "w", w)
        object.__setattr__(self, "C0", C0)

    def attitude(self, t: float) -> np.ndarray:
        """The body -> LVLH attitude (m, 3, 3) at time ``t`` [s]."""
        return spin_attitude(self.w, t, self.C0)

    def matrices(self, t: float, f: float) -> tuple[np.ndarray, np.ndarray]:
        """``A21``, ``A22`` at time ``t`` [s] and true anomaly ``f`` [rad], each (3, 3).

        The :class:`~uqguide.models.dynamics.tschauner_hempel.RelativePlant` interface (one
        common spin rate, ``m = 1``), so the shared RK4 maps apply to this plant too.
        """
        if self.w.shape[0] != 1:
            raise ValueError("matrices(t, f) needs one common spin rate; use stage_matrices")
        A, B = lvlh_matrices(self.orbit, np.array([f]), self.printed_omega_dot)
        A21, A22 = body_frame_matrices(A[0], B[0], self.attitude(t), self.w, printed=self.printed)
        return A21[0], A22[0]

    def stage_schedule(self, n_steps: int, h: float) -> StageSchedule:
        """Orbit matrices at the RK4 stage times ``k h / 2``, ``k = 0 .. 2 n_steps``, ``h`` [s]."""
        times = 0.5 * h * np.arange(2 * n_steps + 1)
        f = true_anomaly(self.orbit, times)
        A, B = lvlh_matrices(self.orbit, f, self.printed_omega_dot)
        return StageSchedule(h=h, times=times, f=f, A=A, B=B)

    def stage_at(self, schedule: StageSchedule, j: int) -> BodyFrameStage:
        """The plant at the half-step grid point ``j`` (index into ``schedule.times``)."""
        return BodyFrameStage(schedule.A[j], schedule.B[j], self.attitude(schedule.times[j]),
                              self.w, self.printed)

    def matrices_at(self, schedule: StageSchedule, j: int) -> tuple[np.ndarray, np.ndarray]:
        """The plant's matrices (m, 3, 3) at the half-step grid point ``j`` of ``schedule``."""
        return self.stage_at(schedule, j).matrices()


@dataclass(frozen=True)
class StageSchedule:
    """The target orbit's LVLH matrices on the half-step grid (common to a batch).

    ``times`` (2 N + 1,): ``j h / 2`` [s] for the step ``h``; ``f``: the exact true anomaly [rad]
    there; ``A``, ``B`` (2 N + 1, 3, 3).
    """

    h: float
    times: np.ndarray
    f: np.ndarray
    A: np.ndarray
    B: np.ndarray


class Stage(Protocol):
    def apply(self, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """``A21 r + A22 v`` [m/s^2] for position [m] and velocity [m/s], each (n, 3)."""
        ...


def rk4_step(x: np.ndarray, u: np.ndarray, s0: Stage, s_half: Stage, s1: Stage, h: float
             ) -> np.ndarray:
    """One classical RK4 step of ``[r, v]' = [v, A21 r + A22 v + u]`` with ``u`` held.

    ``x`` (n, 6): ``[r (m), v (m/s)]`` in the body frame; ``u`` (n, 3): thrust acceleration, body
    components [m/s^2], constant over the step (ZOH); ``s0``, ``s_half``, ``s1``: the plant at the
    step's start, middle and end; ``h`` [s].
    """
    r, v = x[:, :3], x[:, 3:]
    k1r, k1v = v, s0.apply(r, v) + u
    r2, v2 = r + 0.5 * h * k1r, v + 0.5 * h * k1v
    k2r, k2v = v2, s_half.apply(r2, v2) + u
    r3, v3 = r + 0.5 * h * k2r, v + 0.5 * h * k2v
    k3r, k3v = v3, s_half.apply(r3, v3) + u
    r4, v4 = r + h * k3r, v + h * k3v
    k4r, k4v = v4, s1.apply(r4, v4) + u
    out = np.empty_like(x)
    out[:, :3] = r + (h / 6.0) * (k1r + 2 * k2r + 2 * k3r + k4r)
    out[:, 3:] = v + (h / 6.0) * (k1v + 2 * k2v + 2 * k3v + k4v)
    return out


def propagate_free(frame: RotatingBodyFrame, x0: np.ndarray, t_f: float, h: float
                   ) -> np.ndarray:
    """Unforced body-frame propagation of ``x0`` (n, 6) (RK4, step ``h`` [s], ``t_f`` a multiple
    of it); the states (n, N + 1, 6) at ``k h``."""
    n_steps = int(round(t_f / h))
    sched = frame.stage_schedule(n_steps, h)
    x = np.array(x0, dtype=float)
    out = np.empty((x.shape[0], n_steps + 1, 6))
    out[:, 0] = x
    zero = np.zeros((x.shape[0], 3))
    m_start = frame.stage_at(sched, 0)
    for k in range(n_steps):
        m_half = frame.stage_at(sched, 2 * k + 1)
        m_end = frame.stage_at(sched, 2 * k + 2)
        x = rk4_step(x, zero, m_start, m_half, m_end, h)
        m_start = m_end
        out[:, k + 1] = x
    return out
