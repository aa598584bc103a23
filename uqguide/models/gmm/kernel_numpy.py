"""Sampled-data closed-loop simulation of a batch of deputies near a box-built chief (spec 8).

At ``t_k = k dt`` the controller computes ``u_k`` from the sampled state and the plant
matrices at ``(t_k, f(t_k))``; the command is saturated, optionally corrupted by a thrust
error, and held constant over ``[t_k, t_k + dt)`` (zero-order hold). The plant is propagated
by classical RK4 with ``n_sub`` sub-steps per period; since the plant is linear and the chief
orbit is shared by the batch, the RK4 maps of every sub-step are computed once
(:class:`StepSchedule`) and a batch is advanced by matrix products.

Per run it accumulates (spec 8 "Outputs per run"):

* ``delta_v = sum_k ||u_k|| dt`` of the applied control ([W 24], exact for a ZOH, spec A14);
* per part, the minimum clearance of the recorded positions (every sub-step) to the part's
  zero-thickness skeleton, and the maximum penetration depth of the body;
* per part, whether any straight segment between consecutive sub-step positions crosses the
  part's collision box (swept test, spec 4.2);
* the minimum range to the chief's centre; saturated and non-finite command counts;
* recorded states every ``record_every`` periods and, on request, the zero-effort miss (ZEM):
  the distance from the goal at which the deputy would be at ``t_f`` if the thrust stopped at
  ``t_k`` (the coasting state propagated by the same RK4 maps).

Geometry checks run in one compiled loop per period (numba); a per-period bounding box of the
sub-step path skips the swept test where it cannot hit, which does not change the result.
This is the reference of :mod:`.kernel_numba` (the whole run compiled, about 7x faster per
CPU-second); ``kernel: numpy`` (or ``UQGUIDE_KERNEL=numpy``) runs it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..dynamics.tschauner_hempel import RelativePlant, rk4_transition
from ..kernels import njit
from ..time_grid import whole_steps
from .geometry import ChiefGeometry

log = logging.getLogger(__name__)


class Controller(Protocol):
    def command(self, r: np.ndarray, v: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Commanded acceleration (n, 3) [m/s^2] for states ``r, v`` (n, 3) and plant A, B."""
        ...


@dataclass(frozen=True)
class StepSchedule:
    """Plant matrices at the sample times and RK4 maps of every control period.

    Attributes
    ----------
    dt : float
        Control period [s].
    times : ndarray, shape (N + 1,)
        Sample times ``k dt`` [s].
    f : ndarray, shape (N + 1,)
        Chief true anomaly at the sample times [rad].
    A, B : ndarray, shape (N, 3, 3)
        Plant matrices at the sample times (what the controllers cancel).
    phi : ndarray, shape (N, n_sub, 6, 6)
    gam : ndarray, shape (N, n_sub, 6, 3)
        ``x(t_k + (j+1) h) = phi[k, j] x(t_k) + gam[k, j] u_k``.
    """

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
    """The :class:`StepSchedule` of ``plant`` on ``[0, t_f]`` (``t_f`` a multiple of ``dt``).

    Parameters
    ----------
    plant : RelativePlant
    t_f, dt : float
        Final time and control period [s].
    n_sub : int
        RK4 sub-steps per period.
    """
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
    """What :func:`simulate` returns for a batch of ``n`` runs (SI units).

    Attributes
    ----------
    time : ndarray, shape (T,)
        Recording times [s].
    r, v : ndarray, shape (n, T, 3)
        Relative position [m] and velocity [m/s] in the plant's axes.
    zem : ndarray, shape (n, T) or None
        Zero-effort miss to the goal at ``t_f`` [m], if asked for.
    delta_v_history : ndarray, shape (n, T)
        Accumulated ``delta_v`` at the recording times [m/s].
    u : ndarray, shape (n, N, 3) or None
        Applied control [m/s^2] per period, if asked for.
    delta_v : ndarray, shape (n,)
        Accumulated ``sum ||u_k|| dt`` [m/s] ([W 24]).
    clearance : ndarray, shape (n, P)
        Minimum distance [m] of the path to each part's skeleton.
    penetration : ndarray, shape (n,)
        Maximum depth [m] inside the solid body.
    hits : ndarray of bool, shape (n, P)
        Swept-segment collision with each part's collision box.
    min_range : ndarray, shape (n,)
        Minimum distance to the chief's centre [m].
    n_saturated, n_nonfinite : ndarray of int, shape (n,)
        Periods with a saturated command; non-finite commands replaced by 0.
    failed : ndarray of bool, shape (n,)
        A state became non-finite.
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


def saturate(u: np.ndarray, a_max: float, per_axis: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Limit commands to ``a_max`` [m/s^2]: by norm (direction kept, default) or per axis (A13).

    Returns the limited commands (n, 3) and whether each was limited (n,).
    """
    if not np.isfinite(a_max):
        return u, np.zeros(u.shape[0], dtype=bool)
    if per_axis:
        limited = np.any(np.abs(u) > a_max, axis=1)
        return np.clip(u, -a_max, a_max), limited
    norm = np.linalg.norm(u, axis=1)
    limited = norm > a_max
    scale = np.where(limited, a_max / np.where(limited, norm, 1.0), 1.0)
    return u * scale[:, None], limited


def simulate(
    schedule: StepSchedule,
    controller: Controller,
    x0: np.ndarray,
    geometry: ChiefGeometry,
    a_max: float = np.inf,
    per_axis_saturation: bool = False,
    thrust_scale: np.ndarray | None = None,
    thrust_noise: float = 0.0,
    rng: np.random.Generator | None = None,
    record_every: int = 1,
    goal: np.ndarray | None = None,
    keep_control: bool = False,
) -> SampledRun:
    """Run the sampled-data closed loop for a batch.

    Parameters
    ----------
    schedule : StepSchedule
        Plant maps (:func:`build_schedule`).
    controller : Controller
    x0 : ndarray, shape (n, 6)
        Initial states ``[r (m), v (m/s)]``.
    geometry : ChiefGeometry
        Parts for clearance and collision checks (in the plant's axes).
    a_max : float
        Acceleration limit [m/s^2] (``inf``: none).
    per_axis_saturation : bool
        Clip each axis instead of scaling the vector.
    thrust_scale : ndarray, shape (n,), optional
        Multiplicative thrust-magnitude error per run (applied after saturation: a mis-
        calibrated thruster delivers ``scale`` times what is commanded).
    thrust_noise : float
        Half-width ``w`` of an i.i.d. per-axis, per-period factor ``1 + U(-w, w)`` ([C] 4.2,
        spec A25); needs ``rng``.
    rng : numpy.random.Generator, optional
    record_every : int
        Record states every this many periods (plus ``t = 0``; ``t_f`` is recorded when
        ``n_steps`` is a multiple).
    goal : ndarray, shape (3,), optional
        If given, the ZEM to this goal is computed at the recording times.
    keep_control : bool
        Keep the applied control of every period (memory ``n * N * 3``).

    Returns
    -------
    SampledRun
    """
    x = np.array(x0, dtype=float)
    n = x.shape[0]
    N, dt = schedule.n_steps, schedule.dt
    if N % record_every:
        raise ValueError(f"record_every ({record_every}) must divide the {N} control periods")
    if thrust_noise > 0 and rng is None:
        raise ValueError("a thrust noise needs a random generator (rng)")
    P = len(geometry.parts)
    T = N // record_every + 1
    r_rec = np.empty((n, T, 3))
    v_rec = np.empty((n, T, 3))
    dv_rec = np.zeros((n, T))
    r_rec[:, 0], v_rec[:, 0] = x[:, :3], x[:, 3:]
    coast = schedule.coast_to_end() if goal is not None else None
    zem = np.empty((n, T)) if goal is not None else None
    if zem is not None and coast is not None:
        zem[:, 0] = np.linalg.norm(x @ coast[0][:3].T - goal, axis=1)
    u_all = np.empty((n, N, 3)) if keep_control else None

    delta_v = np.zeros(n)
    n_sat = np.zeros(n, dtype=int)
    n_bad = np.zeros(n, dtype=int)
    failed = np.zeros(n, dtype=bool)
    hits = np.zeros((n, P), dtype=bool)
    clearance = geometry.clearance(x[:, :3])
    penetration = geometry.body_penetration(x[:, :3])
    min_range = np.linalg.norm(x[:, :3], axis=1)
    solid = np.zeros(P, dtype=np.bool_)
    solid[geometry.solid_index()] = True
    s_lo, s_hi = geometry.skeleton_lo, geometry.skeleton_hi
    c_lo, c_hi = geometry.collision_lo, geometry.collision_hi

    for k in range(N):
        r, v = x[:, :3], x[:, 3:]
        with np.errstate(all="ignore"):
            u = controller.command(r, v, schedule.A[k], schedule.B[k])
        bad = ~np.all(np.isfinite(u), axis=1)
        if bad.any():
            u[bad] = 0.0
            n_bad += bad
        u, limited = saturate(u, a_max, per_axis_saturation)
        n_sat += limited
        if thrust_scale is not None:
            u = u * thrust_scale[:, None]
        if thrust_noise > 0 and rng is not None:  # (checked above: noise needs a generator)
            u = u * (1.0 + rng.uniform(-thrust_noise, thrust_noise, size=u.shape))
        if u_all is not None:
            u_all[:, k] = u
        delta_v += np.linalg.norm(u, axis=1) * dt

        x_next = np.empty_like(x)
        _advance(
            x, np.ascontiguousarray(u), schedule.phi[k], schedule.gam[k], s_lo, s_hi, c_lo, c_hi,
            solid, x_next, clearance, penetration, hits, min_range,
        )
        x = x_next
        newly_bad = ~np.all(np.isfinite(x), axis=1) & ~failed
        if newly_bad.any():
            failed |= newly_bad
            x[newly_bad] = 0.0  # frozen; the sample is flagged and its outputs unusable
        if (k + 1) % record_every == 0:
            j = (k + 1) // record_every
            r_rec[:, j], v_rec[:, j] = x[:, :3], x[:, 3:]
            dv_rec[:, j] = delta_v
            if zem is not None and coast is not None:
                zem[:, j] = np.linalg.norm(x @ coast[k + 1][:3].T - goal, axis=1)

    if n_bad.any():
        log.warning("%d non-finite commands were replaced by 0", int(n_bad.sum()))
    return SampledRun(
        time=np.arange(T) * dt * record_every,
        r=r_rec,
        v=v_rec,
        zem=zem,
        delta_v_history=dv_rec,
        u=u_all,
        delta_v=delta_v,
        clearance=clearance,
        penetration=penetration,
        hits=hits,
        min_range=min_range,
        n_saturated=n_sat,
        n_nonfinite=n_bad,
        failed=failed,
    )


@njit(cache=True)
def _advance(
    x: np.ndarray,
    u: np.ndarray,
    phi: np.ndarray,
    gam: np.ndarray,
    s_lo: np.ndarray,
    s_hi: np.ndarray,
    c_lo: np.ndarray,
    c_hi: np.ndarray,
    solid: np.ndarray,
    x_next: np.ndarray,
    clearance: np.ndarray,
    penetration: np.ndarray,
    hits: np.ndarray,
    min_range: np.ndarray,
) -> None:  # pragma: no cover - compiled; checked against the NumPy reference in the tests
    """Propagate one control period and update the geometry records, in place.

    ``x`` (n, 6) are the states at the period's start, ``u`` (n, 3) the held controls and
    ``phi[j]`` (6, 6), ``gam[j]`` (6, 3) the RK4 maps to sub-step ``j``; the end state goes to
    ``x_next``. The path of a sample is its start and sub-step positions; clearance,
    penetration and the swept test use the same arithmetic as
    :func:`~.geometry.point_box_distance`, :func:`~.geometry.penetration_depth` and
    :func:`~.geometry.segment_box_hits`, fused in one loop (the NumPy versions spent most of a
    batch run on temporaries, and BLAS threads on tiny products).
    """
    n = x.shape[0]
    m = phi.shape[0] + 1
    P = s_lo.shape[0]
    pts = np.empty((m, 3))
    for i in range(n):
        for a in range(3):
            pts[0, a] = x[i, a]
        for s in range(1, m):
            for a in range(6):
                acc = 0.0
                for b in range(6):
                    acc += phi[s - 1, a, b] * x[i, b]
                for b in range(3):
                    acc += gam[s - 1, a, b] * u[i, b]
                if a < 3:
                    pts[s, a] = acc
                if s == m - 1:
                    x_next[i, a] = acc
            rng = np.sqrt(pts[s, 0] ** 2 + pts[s, 1] ** 2 + pts[s, 2] ** 2)
            if rng < min_range[i]:
                min_range[i] = rng
        # bounding box of the period's path: its segments lie inside it
        blo = np.empty(3)
        bhi = np.empty(3)
        for a in range(3):
            blo[a] = pts[0, a]
            bhi[a] = pts[0, a]
            for s in range(1, m):
                blo[a] = min(blo[a], pts[s, a])
                bhi[a] = max(bhi[a], pts[s, a])
        for p in range(P):
            for s in range(1, m):
                d2 = 0.0
                depth = np.inf
                for a in range(3):
                    pa = pts[s, a]
                    g = max(s_lo[p, a] - pa, pa - s_hi[p, a], 0.0)
                    d2 += g * g
                    depth = min(depth, pa - s_lo[p, a], s_hi[p, a] - pa)
                d = np.sqrt(d2)
                if d < clearance[i, p]:
                    clearance[i, p] = d
                if solid[p] and depth > penetration[i]:
                    penetration[i] = depth
            if hits[i, p]:
                continue
            overlap = True
            for a in range(3):
                if bhi[a] < c_lo[p, a] or blo[a] > c_hi[p, a]:
                    overlap = False
            if not overlap:
                continue
            for s in range(m - 1):
                t_enter = -np.inf
                t_exit = np.inf
                for a in range(3):
                    p0 = pts[s, a]
                    dp = pts[s + 1, a] - p0
                    if dp != 0.0:
                        t1 = (c_lo[p, a] - p0) / dp
                        t2 = (c_hi[p, a] - p0) / dp
                        t_enter = max(t_enter, min(t1, t2))
                        t_exit = min(t_exit, max(t1, t2))
                    elif p0 < c_lo[p, a] or p0 > c_hi[p, a]:
                        t_enter = np.inf
                        t_exit = -np.inf
                if t_enter <= t_exit and t_exit >= 0.0 and t_enter <= 1.0:
                    hits[i, p] = True
                    break
