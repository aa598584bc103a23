"""NumPy oracle of the GMM-FTC closed loop (``uqguide/models/gmm_ftc/kernel_numba.py``).

The same sampled-data loop as the compiled kernel, vectorised over the batch with one
Python-level step per control period (:class:`uqguide.models.gmm_ftc.loop.LoopSettings`): the
law's NumPy ``command``, the thrust factors and keyed noise, RK4 of the body-frame plant, the
geometry of every sub-step and the same metrics:

* convergence times ``inf{t : ||e(tau)|| < tol for all tau >= t}`` (position, velocity, s2),
  on the 0.1 s sample grid;
* maxima of ``||r'||``, ``||u||`` (all time, after ``t_check``, after position convergence),
  per-component maxima, the spread of ``u`` after ``t_check`` (claim C6);
* delta-v ``sum_k ||u_k|| dt`` of the applied thrust ([W 24], exact for a ZOH);
* per part: minimum clearance of the sampled positions to the zero-thickness skeleton, body
  penetration, and swept-segment collision between consecutive positions (spec 4.2).
"""

from __future__ import annotations

import logging

import numpy as np

from uqguide.models.dynamics.rotating_body_frame import (
    RotatingBodyFrame, body_to_lvlh, eq32_acceleration, rk4_step, rotate,
)
from uqguide.models.gmm.geometry import (
    ChiefGeometry, penetration_depth, point_box_distance, segment_box_hits,
)
from uqguide.models.gmm_ftc import noise
from uqguide.models.gmm_ftc.law import GMMFTCLaw
from uqguide.models.gmm_ftc.loop import LoopRun, LoopSettings, scalar_results

log = logging.getLogger(__name__)


def run_closed_loop(
    plant: RotatingBodyFrame,
    controller_plant: RotatingBodyFrame | None,
    law: GMMFTCLaw,
    geometry: ChiefGeometry,
    x0: np.ndarray,
    settings: LoopSettings,
    thrust_scale: np.ndarray | None = None,
    noise_keys: np.ndarray | None = None,
) -> LoopRun:
    """Simulate a batch of servicers under GMM-FTC.

    Parameters
    ----------
    plant : RotatingBodyFrame
        True body-frame dynamics; its spin rate is common (``m = 1``) or per sample.
    controller_plant : RotatingBodyFrame or None
        The dynamics the law cancels (``None``: the true plant).
    law : GMMFTCLaw
    geometry : ChiefGeometry
        Target parts, body frame.
    x0 : ndarray, shape (n, 6)
        Initial body-frame ``[r (m), r' (m/s)]``.
    settings : LoopSettings
    thrust_scale : ndarray, shape (n, 3), optional
        Per-sample, per-axis thrust factor (1: exact).
    noise_keys : ndarray of uint64, shape (n,), optional
        Keys of the per-period thrust noise streams (:mod:`.noise`); needed when
        ``settings.thrust_noise > 0``.

    Returns
    -------
    LoopRun
        ``scalars`` holds (shape (n,) unless noted): ``t_converge``, ``converged``,
        ``t_settle``, ``t_converge_vel``, ``t_reach_s2``, ``pos_error_final`` (max after
        ``t_check``),
        ``speed_final``, ``speed_max``, ``speed_max_axes`` (n, 3), ``u_max``,
        ``u_max_converged``, ``u_spread_final`` (norm of the component ranges of ``u`` after
        ``t_check``), ``u_final``, ``delta_v``, ``clearance_parts`` (n, P), ``min_clearance``,
        ``penetration``, ``hits`` (n, P) bool, ``collided``, ``range_min``, ``n_guarded``,
        ``n_nonfinite``, ``t_speed_below`` (time after which ``||r'|| < 0.15 m/s``) and
        ``t_u_below`` (after which ``||u|| < 0.06 m/s^2``).
    """
    st = settings
    x = np.array(x0, dtype=float)
    n = x.shape[0]
    N, dt = st.n_steps, st.dt
    if st.thrust_noise > 0 and noise_keys is None:
        raise ValueError("a per-period thrust noise needs the samples' noise keys")
    h = dt / st.n_sub
    sched = plant.stage_schedule(N * st.n_sub, h)
    scale = np.ones((n, 3)) if thrust_scale is None else np.asarray(thrust_scale, dtype=float)
    T = N // st.record_every + 1
    rec = {k: np.empty((n, T, 3)) for k in ("r", "v", "u", "r_l", "v_l", "u_l", "u_eq32_l")}
    rec_s2 = np.empty((n, T))
    rec_dv = np.empty((n, T))

    P = len(geometry.parts)
    s_lo, s_hi = geometry.skeleton_lo, geometry.skeleton_hi
    c_lo, c_hi = geometry.collision_lo, geometry.collision_hi
    body = geometry.solid_index()
    clearance = point_box_distance(x[:, :3], s_lo, s_hi)
    d_prev = clearance.copy()
    # largest distance from a skeleton to the surface of its collision box (corner of an
    # inflated segment), plus a margin for rounding
    reach = float(np.sqrt(3.0) * np.max(np.abs(c_lo - s_lo)) + 1e-9)
    penetration = penetration_depth(x[:, :3], s_lo[body], s_hi[body]).max(axis=-1)
    hits = np.zeros((n, P), dtype=bool)
    range_min = np.linalg.norm(x[:, :3], axis=1)

    minus1 = np.full(n, -1)
    bad_e, bad_settle, bad_v, bad_s2, bad_speed, bad_u = (minus1.copy() for _ in range(6))
    pos_final = np.zeros(n)
    speed_final = np.zeros(n)
    speed_max = np.zeros(n)
    speed_axes = np.zeros((n, 3))
    u_max = np.zeros(n)
    u_conv = np.zeros(n)
    u_lo = np.full((n, 3), np.inf)
    u_hi = np.full((n, 3), -np.inf)
    delta_v = np.zeros(n)
    n_guarded = np.zeros(n, dtype=int)
    n_bad = np.zeros(n, dtype=int)
    failed = np.zeros(n, dtype=bool)
    k_check = int(np.ceil(st.t_check / dt - 1e-9))

    m_start = plant.stage_at(sched, 0)
    # a diverging sample is flagged (failed), not warned about at every step
    with np.errstate(all="ignore"):
        for k in range(N + 1):
            j0 = 2 * k * st.n_sub
            r, v = x[:, :3], x[:, 3:]
            ctl = m_start if controller_plant is None else controller_plant.stage_at(sched, j0)
            cmd = law.command(r, v, ctl)
            u = cmd.u
            nonfinite = ~np.all(np.isfinite(u), axis=1)
            if nonfinite.any():
                u[nonfinite] = 0.0
                n_bad += nonfinite
            n_guarded += cmd.guarded
            if np.isfinite(st.u_max):
                norm = np.linalg.norm(u, axis=1)
                u = u * np.minimum(1.0, st.u_max / np.maximum(norm, 1e-300))[:, None]
            u = u * scale
            if st.thrust_noise > 0 and noise_keys is not None:  # (checked on entry)
                u = u * (1.0 + st.thrust_noise * (2.0 * noise.uniform(noise_keys, k) - 1.0))

            # -------- per-sample-time statistics (time t_k)
            e_norm = np.linalg.norm(r - law.r_f, axis=1)
            speed = np.linalg.norm(v, axis=1)
            u_norm = np.linalg.norm(u, axis=1)
            s2_norm = np.linalg.norm(cmd.s2, axis=1)
            bad_e = np.where(~(e_norm < st.converge_tol), k, bad_e)
            bad_settle = np.where(~(e_norm < st.settle_tol), k, bad_settle)
            bad_v = np.where(~(speed < st.velocity_tol), k, bad_v)
            bad_s2 = np.where(~(s2_norm < st.s2_tol), k, bad_s2)
            bad_speed = np.where(~(speed < 0.15), k, bad_speed)
            bad_u = np.where(~(u_norm < 0.06), k, bad_u)
            speed_max = np.fmax(speed_max, speed)
            speed_axes = np.fmax(speed_axes, np.abs(v))
            u_max = np.fmax(u_max, u_norm)
            # max |u| since the last position-error violation = max |u| after convergence
            u_conv = np.where(e_norm < st.converge_tol, np.fmax(u_conv, u_norm), 0.0)
            if k >= k_check:
                pos_final = np.fmax(pos_final, e_norm)
                speed_final = np.fmax(speed_final, speed)
                u_lo = np.fmin(u_lo, u)
                u_hi = np.fmax(u_hi, u)

            if k % st.record_every == 0:
                i = k // st.record_every
                C = plant.attitude(sched.times[j0])
                r_l, v_l = body_to_lvlh(C, plant.w, r, v)
                rec["r"][:, i], rec["v"][:, i], rec["u"][:, i] = r, v, u
                rec["r_l"][:, i], rec["v_l"][:, i] = r_l, v_l
                rec["u_l"][:, i] = rotate(C, u)
                rec["u_eq32_l"][:, i] = rotate(C, eq32_acceleration(plant.w, r, v, u))
                rec_s2[:, i] = s2_norm
                rec_dv[:, i] = delta_v
            if k == N:
                break

            # -------- propagate over [t_k, t_k + dt) with u held
            delta_v += u_norm * dt
            for s in range(st.n_sub):
                j = j0 + 2 * s
                m_half = plant.stage_at(sched, j + 1)
                m_end = plant.stage_at(sched, j + 2)
                x_new = rk4_step(x, u, m_start, m_half, m_end, h)
                p0, p1 = x[:, :3], x_new[:, :3]
                d_new = point_box_distance(p1, s_lo, s_hi)
                clearance = np.fmin(clearance, d_new)
                inside = np.flatnonzero(np.any(d_new[:, body] == 0.0, axis=1))
                if inside.size:
                    depth = penetration_depth(p1[inside], s_lo[body], s_hi[body]).max(axis=-1)
                    penetration[inside] = np.fmax(penetration[inside], depth)
                # Every point of a segment lies within half its length of an end point, so a
                # segment can only reach a collision box if an end point is within that plus the
                # box's inflation of the skeleton; the exact slab test runs on those rows only.
                half = 0.5 * np.linalg.norm(p1 - p0, axis=1)
                near = np.flatnonzero(
                    np.any(np.fmin(d_prev, d_new) <= half[:, None] + reach, axis=1))
                if near.size:
                    hits[near] |= segment_box_hits(p0[near], p1[near], c_lo, c_hi)
                d_prev = d_new
                range_min = np.fmin(range_min, np.linalg.norm(p1, axis=1))
                x = x_new
                m_start = m_end
            newly = ~np.all(np.isfinite(x), axis=1) & ~failed
            if newly.any():
                failed |= newly
                x[newly] = 0.0  # frozen; flagged, its outputs are not to be used

    if n_bad.any():
        log.warning("%d non-finite GMM-FTC commands were replaced by 0", int(n_bad.sum()))
    if n_guarded.any():
        log.info("singular I + k_s H guarded %d times", int(n_guarded.sum()))
    scalars = scalar_results(
        bad={"bad_e": bad_e, "bad_settle": bad_settle, "bad_v": bad_v, "bad_s2": bad_s2,
             "bad_speed": bad_speed, "bad_u": bad_u},
        dt=dt, t_final=st.t_final, n_steps=N, pos_final=pos_final, speed_final=speed_final,
        speed_max=speed_max, speed_axes=speed_axes, u_max=u_max, u_conv=u_conv, u_lo=u_lo,
        u_hi=u_hi,
        u_last=rec["u"][:, -1], delta_v=delta_v, clearance=clearance, penetration=penetration,
        hits=hits, range_min=range_min, n_guarded=n_guarded.astype(float),
        n_nonfinite=n_bad.astype(float))
    return LoopRun(time=np.arange(T) * dt * st.record_every, goal=law.r_f, s2=rec_s2,
                   dv_cum=rec_dv, scalars=scalars, failed=failed, **rec)
