"""NumPy oracle of the GMM proximity closed loop (``uqguide/models/gmm/kernel_numba.py``).

The same sampled-data loop as the compiled kernel (command at ``t_k``, bad-command guard,
saturation, thrust scale, RK4 sub-step maps, per-sub-step clearance, penetration, range and
swept collision tests, records and ZEM), written independently: NumPy over the batch, one
Python-level step per control period, the geometry of a period in one compiled loop
(:func:`_advance`). It also takes what the kernel does not: any controller with a ``command``
method, a per-period thrust noise and the applied control of every period.
"""

from __future__ import annotations

import logging
from typing import Protocol

import numpy as np

from uqguide.models.gmm.geometry import ChiefGeometry
from uqguide.models.gmm.loop import SampledRun, StepSchedule
from uqguide.models.kernels import njit

log = logging.getLogger(__name__)


class Controller(Protocol):
    def command(self, r: np.ndarray, v: np.ndarray, A: np.ndarray, B: np.ndarray) -> np.ndarray:
        """Commanded acceleration (n, 3) [m/s^2] for states ``r, v`` (n, 3) and plant A, B."""
        ...


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
        Plant maps (:func:`uqguide.models.gmm.loop.build_schedule`).
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
) -> None:  # pragma: no cover - compiled
    """Propagate one control period and update the geometry records, in place.

    ``x`` (n, 6) are the states at the period's start, ``u`` (n, 3) the held controls and
    ``phi[j]`` (6, 6), ``gam[j]`` (6, 3) the RK4 maps to sub-step ``j``; the end state goes to
    ``x_next``. The path of a sample is its start and sub-step positions; clearance,
    penetration and the swept test use the same arithmetic as ``point_box_distance``,
    ``penetration_depth`` and ``segment_box_hits`` of :mod:`uqguide.models.gmm.geometry`, fused
    in one loop (the NumPy versions spent most of a batch run on temporaries, and BLAS threads
    on tiny products).
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
