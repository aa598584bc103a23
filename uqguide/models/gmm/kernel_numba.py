"""Compiled GMM proximity closed loop, whole run (:mod:`.loop`: its RK4 maps and result).

One compiled function runs the sampled-data loop; it agrees with the NumPy oracle
``tests/oracles/gmm.py`` to round-off (``tests/test_gmm_kernel.py``), and a sample gives the same
bits whatever the batch split and the thread count. The layout and where the time goes:
docs/performance.md#the-gmm-proximity-kernel.
"""

from __future__ import annotations

import logging
import math

import numba
import numpy as np
from numba import prange

from ..kernels import njit
from ..record_rows import put_lane
from .controllers import NTSMC, TSMC
from .geometry import ChiefGeometry
from .loop import SampledRun, StepSchedule

log = logging.getLogger(__name__)

BLOCK = 64
"""Most samples per parallel task; they advance in lockstep (see :func:`block_size`)."""


def block_size(n: int, threads: int) -> int:
    """Samples per block for a batch of ``n`` on ``threads`` threads: at most :data:`BLOCK`, and
    as many blocks per thread as possible (docs/performance.md#the-gmm-proximity-kernel)."""
    threads = max(1, threads)
    blocks = max(1, -(-n // BLOCK))
    blocks = -(-blocks // threads) * threads
    return max(1, -(-n // blocks))

# entries of the law's scalar parameters ``law``
(LW_NTSMC, LW_XI0, LW_TAU, LW_RHO, LW_EPS, LW_ALPHA, LW_AMAX, LW_PERAXIS, LW_DT) = range(9)
N_LAW = 9
# rows of the law's per-axis gains ``gains (N_GAIN, 3)``
(G_RF, G_KS, G_NEGKS, G_NEGL1, G_L2, G_XI1, G_XI2, G_TAUXI1, G_GAIN) = range(9)
N_GAIN = 9

# rows of the per-period work array ``W (N_W, m)`` of a block
(W_V, W_G0, W_G1, W_G2, W_H00, W_H01, W_H02, W_H10, W_H11, W_H12, W_H20, W_H21, W_H22,
 W_TH0, W_TH1, W_TH2, W_Q, W_ETA, W_E0, W_E1, W_E2, W_ME0, W_ME1, W_ME2, W_QE, W_PG0, W_PG1,
 W_PG2, W_S0, W_S1, W_S2, W_U0, W_U1, W_U2, W_PE0, W_PE1, W_PE2, W_PV0, W_PV1, W_PV2, W_X3, W_X4,
 W_X5) = range(43)
N_W = 43

# kernel parameters copied per block: ``kp (K, N_KP, m)``: c, mu (3), L (9)
KP_C, KP_MU, KP_L = 0, 1, 4
N_KP = 13

_EXP_UNDERFLOW = 746.0
"""``exp(-x)`` is exactly 0 in double precision for ``x > 745.14``: no call needed there."""


def simulate_compiled(
    schedule: StepSchedule,
    controller: NTSMC | TSMC,
    x0: np.ndarray,
    geometry: ChiefGeometry,
    a_max: float = np.inf,
    per_axis_saturation: bool = False,
    thrust_scale: np.ndarray | None = None,
    record_every: int = 1,
    goal: np.ndarray | None = None,
) -> SampledRun:
    """Run the sampled-data closed loop for a batch (``u`` of the result is None).

    ``schedule``: the plant maps (:func:`.loop.build_schedule`); ``x0 (n, 6)``: initial
    ``[r (m), v (m/s)]``; ``geometry``: the parts, in the plant's axes; ``a_max`` [m/s^2]: the
    acceleration limit (``inf``: none), which ``per_axis_saturation`` applies per axis instead
    of to the vector; ``thrust_scale (n,)``: a thrust-magnitude factor per run, after
    saturation; states are recorded every ``record_every`` periods (and at ``t = 0``), with the
    ZEM to ``goal`` (3,) when it is given.
    """
    x0 = np.ascontiguousarray(x0, dtype=float)
    n = x0.shape[0]
    N, dt = schedule.n_steps, schedule.dt
    if N % record_every:
        raise ValueError(f"record_every ({record_every}) must divide the {N} control periods")
    P = len(geometry.parts)
    T = N // record_every + 1
    pot = controller.potential
    c, mu, L = pot.V._batched(n)
    law = np.zeros(N_LAW)
    gains = np.zeros((N_GAIN, 3))
    reach = controller.reaching
    gains[G_RF] = controller.r_f
    gains[G_KS] = controller.k_s
    gains[G_NEGKS] = -controller.k_s
    gains[G_NEGL1] = -reach.lambda1
    gains[G_L2] = reach.lambda2
    law[LW_ALPHA] = reach.alpha
    if isinstance(controller, NTSMC):
        law[LW_NTSMC] = 1.0
        law[LW_XI0], law[LW_TAU] = controller.xi0, controller.tau
        law[LW_RHO], law[LW_EPS] = controller.rho, controller.eps
        gains[G_XI1] = controller.xi1
        gains[G_XI2] = controller.xi2
        gains[G_TAUXI1] = controller.tau * controller.xi1
        gains[G_GAIN] = (controller.q / controller.p) / controller.xi2
    law[LW_AMAX] = a_max
    law[LW_PERAXIS] = float(per_axis_saturation)
    law[LW_DT] = dt
    tscale = (np.ones(n) if thrust_scale is None
              else np.ascontiguousarray(thrust_scale, dtype=float))
    r_rec = np.empty((n, T, 3))
    v_rec = np.empty((n, T, 3))
    dv_rec = np.zeros((n, T))
    r_rec[:, 0], v_rec[:, 0] = x0[:, :3], x0[:, 3:]
    if goal is not None:
        coast = np.ascontiguousarray(schedule.coast_to_end()[:, :3])
        zem = np.empty((n, T))
        goal_ = np.asarray(goal, dtype=float)
    else:
        coast = np.zeros((0, 3, 6))
        zem = np.empty((0, T))
        goal_ = np.zeros(3)
    delta_v = np.empty(n)
    d2min = np.empty((n, P))
    r2min = np.empty(n)
    penetration = np.array(geometry.body_penetration(x0[:, :3]), dtype=float)
    hits = np.zeros((n, P), dtype=np.bool_)
    n_sat = np.zeros(n, dtype=np.int64)
    n_bad = np.zeros(n, dtype=np.int64)
    failed = np.zeros(n, dtype=np.bool_)
    solid = np.zeros(P, dtype=np.bool_)
    solid[geometry.solid_index()] = True
    simulate_block_parallel(
        block_size(n, numba.get_num_threads()), x0, schedule.A, schedule.B, schedule.phi,
        schedule.gam, law, gains, pot.P, pot.M, c, mu, L, geometry.skeleton_lo,
        geometry.skeleton_hi, geometry.collision_lo, geometry.collision_hi, solid, tscale,
        record_every, coast, goal_, r_rec, v_rec, dv_rec, zem, delta_v, d2min, r2min,
        penetration, hits, n_sat, n_bad, failed)
    # the minimum of the square roots is the square root of the minimum (sqrt is monotone and
    # correctly rounded), started from the initial position as in the reference
    clearance = geometry.clearance(x0[:, :3])
    d = np.sqrt(d2min)
    clearance = np.where(d < clearance, d, clearance)
    min_range = np.linalg.norm(x0[:, :3], axis=1)
    rmin = np.sqrt(r2min)
    min_range = np.where(rmin < min_range, rmin, min_range)
    if n_bad.any():
        log.warning("%d non-finite commands were replaced by 0", int(n_bad.sum()))
    return SampledRun(
        time=np.arange(T) * dt * record_every, r=r_rec, v=v_rec,
        zem=zem if goal is not None else None, delta_v_history=dv_rec, u=None, delta_v=delta_v,
        clearance=clearance, penetration=penetration, hits=hits, min_range=min_range,
        n_saturated=n_sat, n_nonfinite=n_bad, failed=failed)


@njit(cache=True, error_model="numpy", parallel=True)
def simulate_block_parallel(block, x0, A, B, phi, gam, law, gains, P, M, c, mu, L, s_lo, s_hi, c_lo,
                            c_hi, solid, tscale, record_every, coast, goal,
                            r_rec, v_rec, dv_rec, zem, delta_v, d2min, r2min, penetration, hits,
                            n_sat, n_bad, failed):  # pragma: no cover - compiled
    """Run the batch in parallel blocks of ``block`` samples; arguments as
    :func:`simulate_compiled` passes them.

    Outputs (written in place): records ``r_rec, v_rec (n, T, 3)``, ``dv_rec (n, T)``, ``zem
    (n, T)`` (if ``coast`` has rows), totals ``delta_v (n,)``, the minimum squared distance to
    each part's skeleton over the sub-steps ``d2min (n, P)``, the minimum squared range
    ``r2min (n,)``, ``penetration (n,)`` (starts at the initial depth), ``hits (n, P)``, the
    counts ``n_sat, n_bad (n,)`` and ``failed (n,)``.
    """
    n = x0.shape[0]
    for b in prange((n + block - 1) // block):
        _block(b * block, min(n, (b + 1) * block), x0, A, B, phi, gam, law, gains, P, M, c, mu,
               L, s_lo, s_hi, c_lo, c_hi, solid, tscale, record_every, coast, goal, r_rec,
               v_rec, dv_rec, zem, delta_v, d2min, r2min, penetration, hits, n_sat, n_bad,
               failed)


@njit(cache=True, error_model="numpy")
def _gauss_sum(m, K, st, kp, W):  # pragma: no cover - compiled
    """Value, gradient and Hessian of the Gaussian sum at every lane's position (rows W_V ..
    W_H22), each lane in the order of :func:`.gauss_sum._gauss_sum_kernel`."""
    for row in range(W_V, W_H22 + 1):
        for l in range(m):
            W[row, l] = 0.0
    for k in range(K):
        for l in range(m):
            d0 = st[0, l] - kp[k, KP_MU, l]
            d1 = st[1, l] - kp[k, KP_MU + 1, l]
            d2 = st[2, l] - kp[k, KP_MU + 2, l]
            W[W_TH0, l] = kp[k, KP_L, l] * d0 + kp[k, KP_L + 1, l] * d1 + kp[k, KP_L + 2, l] * d2
            W[W_TH1, l] = (kp[k, KP_L + 3, l] * d0 + kp[k, KP_L + 4, l] * d1
                           + kp[k, KP_L + 5, l] * d2)
            W[W_TH2, l] = (kp[k, KP_L + 6, l] * d0 + kp[k, KP_L + 7, l] * d1
                           + kp[k, KP_L + 8, l] * d2)
        for l in range(m):
            d0 = st[0, l] - kp[k, KP_MU, l]
            d1 = st[1, l] - kp[k, KP_MU + 1, l]
            d2 = st[2, l] - kp[k, KP_MU + 2, l]
            W[W_Q, l] = -0.5 * (d0 * W[W_TH0, l] + d1 * W[W_TH1, l] + d2 * W[W_TH2, l])
        any_on = False
        for l in range(m):
            # the call only where the exponential does not underflow (most lanes, for the
            # published GMM's 3 mm sheets, most of the time)
            a = W[W_Q, l]
            eta = 0.0 if a <= -_EXP_UNDERFLOW else kp[k, KP_C, l] * math.exp(a)
            W[W_ETA, l] = eta
            any_on |= eta != 0.0
        if not any_on:
            continue
        for l in range(m):
            eta = W[W_ETA, l]
            if eta != 0.0:
                W[W_V, l] += eta
                W[W_G0, l] -= eta * W[W_TH0, l]
                W[W_G1, l] -= eta * W[W_TH1, l]
                W[W_G2, l] -= eta * W[W_TH2, l]
        for a in range(3):
            for l in range(m):
                eta = W[W_ETA, l]
                if eta != 0.0:
                    ta = W[W_TH0 + a, l]
                    W[W_H00 + 3 * a, l] += eta * (ta * W[W_TH0, l] - kp[k, KP_L + 3 * a, l])
                    W[W_H00 + 3 * a + 1, l] += eta * (ta * W[W_TH1, l]
                                                      - kp[k, KP_L + 3 * a + 1, l])
                    W[W_H00 + 3 * a + 2, l] += eta * (ta * W[W_TH2, l]
                                                      - kp[k, KP_L + 3 * a + 2, l])


@njit(cache=True, error_model="numpy")
def _sig(x, p):  # pragma: no cover - compiled
    """``sign(x) p`` with ``p = |x|^a`` already evaluated."""
    return p if x > 0.0 else (-p if x < 0.0 else (0.0 if x == 0.0 else x))


@njit(cache=True, error_model="numpy")
def _command(m, st, W, law, gains, P, M, Ak, Bk):  # pragma: no cover - compiled
    """The commanded acceleration of every lane (rows W_U0..2), the potential's derivatives
    being in W: the arithmetic of :meth:`.controllers.NTSMC.command` / :meth:`TSMC.command`
    and :meth:`.potential.AttractRepulsePotential.derivatives`, operation for operation except
    the fractional powers (module docstring)."""
    ntsmc = law[LW_NTSMC] != 0.0
    xi0, tau, rho, eps, alpha = law[LW_XI0], law[LW_TAU], law[LW_RHO], law[LW_EPS], law[LW_ALPHA]
    tm1 = tau - 1.0
    half = tm1 == 0.5
    omr = 1.0 - rho
    for l in range(m):
        e0 = st[0, l] - gains[G_RF, 0]
        e1 = st[1, l] - gains[G_RF, 1]
        e2 = st[2, l] - gains[G_RF, 2]
        W[W_E0, l] = e0
        W[W_E1, l] = e1
        W[W_E2, l] = e2
    for l in range(m):
        e0, e1, e2 = W[W_E0, l], W[W_E1, l], W[W_E2, l]
        W[W_ME0, l] = e0 * M[0, 0] + e1 * M[0, 1] + e2 * M[0, 2]
        W[W_ME1, l] = e0 * M[1, 0] + e1 * M[1, 1] + e2 * M[1, 2]
        W[W_ME2, l] = e0 * M[2, 0] + e1 * M[2, 1] + e2 * M[2, 2]
    for l in range(m):
        W[W_QE, l] = 0.5 * (W[W_E0, l] * W[W_ME0, l] + W[W_E1, l] * W[W_ME1, l]
                            + W[W_E2, l] * W[W_ME2, l])
    # gradient of the potential, g = P e + V M e + (q/2) grad V
    for a in range(3):
        for l in range(m):
            e0, e1, e2 = W[W_E0, l], W[W_E1, l], W[W_E2, l]
            W[W_PG0 + a, l] = ((e0 * P[a, 0] + e1 * P[a, 1] + e2 * P[a, 2])
                               + W[W_V, l] * W[W_ME0 + a, l] + W[W_QE, l] * W[W_G0 + a, l])
    # the Hessian in place of the Gaussian sum's: P + V M + g Me^T + Me g^T + (q/2) hess V
    for a in range(3):
        for b in range(3):
            for l in range(m):
                W[W_H00 + 3 * a + b, l] = ((((P[a, b] + W[W_V, l] * M[a, b])
                                             + W[W_G0 + b, l] * W[W_ME0 + a, l])
                                            + W[W_G0 + a, l] * W[W_ME0 + b, l])
                                           + W[W_QE, l] * W[W_H00 + 3 * a + b, l])
    # sliding variable S (rows W_S), then the command
    for a in range(3):
        ks, xi1, xi2 = gains[G_KS, a], gains[G_XI1, a], gains[G_XI2, a]
        for l in range(m):
            v = st[3 + a, l]
            if ntsmc:
                e = W[W_E0 + a, l]
                ae = abs(e)
                av = abs(v)
                pe = math.sqrt(ae) if half else ae ** tm1  # |e|^(tau-1), once
                pv = max(av, eps) ** omr  # max(|v|, eps)^(1-rho), once
                vr = av / pv if av >= eps and av > 0.0 else av ** rho  # |v|^rho
                W[W_S0 + a, l] = (ks * W[W_PG0 + a, l] + xi0 * e + xi1 * _sig(e, ae * pe)
                                  + xi2 * _sig(v, vr))
                W[W_PE0 + a, l] = pe
                W[W_PV0 + a, l] = pv
            else:
                W[W_S0 + a, l] = ks * W[W_PG0 + a, l] + v
    for a in range(3):
        nks, nl1, l2 = gains[G_NEGKS, a], gains[G_NEGL1, a], gains[G_L2, a]
        txi1, gain = gains[G_TAUXI1, a], gains[G_GAIN, a]
        for l in range(m):
            v0, v1, v2 = st[3, l], st[4, l], st[5, l]
            Hv = (W[W_H00 + 3 * a, l] * v0 + W[W_H00 + 3 * a + 1, l] * v1
                  + W[W_H00 + 3 * a + 2, l] * v2)
            S = W[W_S0 + a, l]
            rate = nl1 * S - l2 * _sig(S, abs(S) ** alpha)
            Ar = st[0, l] * Ak[a, 0] + st[1, l] * Ak[a, 1] + st[2, l] * Ak[a, 2]
            Bv = v0 * Bk[a, 0] + v1 * Bk[a, 1] + v2 * Bk[a, 2]
            v = st[3 + a, l]
            if ntsmc:
                pe = W[W_PE0 + a, l]
                pv = W[W_PV0 + a, l]
                bracket = nks * Hv + rate - xi0 * v - txi1 * pe * v
                u = (gain * pv) * bracket - Ar - Bv
            else:
                u = nks * Hv - Ar - Bv + rate
            W[W_U0 + a, l] = u


@njit(cache=True, error_model="numpy")
def _block(i0, i1, x0, A, B, phi, gam, law, gains, P, M, c, mu, L, s_lo, s_hi, c_lo, c_hi,
           solid, tscale, record_every, coast, goal, r_rec, v_rec, dv_rec, zem, delta_v, d2min,
           r2min, penetration, hits, n_sat, n_bad, failed):  # pragma: no cover - compiled
    """Samples ``i0 .. i1-1`` in lockstep over the whole run (module docstring)."""
    m = i1 - i0
    N = phi.shape[0]
    n_sub = phi.shape[1]
    K = mu.shape[1]
    Pn = s_lo.shape[0]
    a_max, per_axis, dt = law[LW_AMAX], law[LW_PERAXIS] != 0.0, law[LW_DT]
    limit = a_max < np.inf
    with_zem = coast.shape[0] > 0
    st = np.empty((6, m))
    W = np.zeros((N_W, m))
    pts = np.empty((n_sub + 1, 3, m))
    kp = np.empty((K, N_KP, m))
    d2 = np.empty((Pn, m))
    r2 = np.empty(m)
    dep = np.empty(m)
    bb = np.empty((6, m))
    dv = np.zeros(m)
    for l in range(m):
        i = i0 + l
        ic = i if c.shape[0] > 1 else 0
        im = i if mu.shape[0] > 1 else 0
        iL = i if L.shape[0] > 1 else 0
        for k in range(K):
            kp[k, KP_C, l] = c[ic, k]
            for a in range(3):
                kp[k, KP_MU + a, l] = mu[im, k, a]
                for b in range(3):
                    kp[k, KP_L + 3 * a + b, l] = L[iL, k, a, b]
        for q in range(6):
            st[q, l] = x0[i, q]
        r2[l] = np.inf
        dep[l] = penetration[i]
        for p in range(Pn):
            d2[p, l] = np.inf
    if with_zem:
        _zem(0, i0, m, st, coast[0], goal, zem)
    for k in range(N):
        # ---- the command at t_k, every lane
        _gauss_sum(m, K, st, kp, W)
        _command(m, st, W, law, gains, P, M, A[k], B[k])
        for l in range(m):
            i = i0 + l
            u0, u1, u2 = W[W_U0, l], W[W_U1, l], W[W_U2, l]
            if not (math.isfinite(u0) and math.isfinite(u1) and math.isfinite(u2)):
                u0 = u1 = u2 = 0.0
                n_bad[i] += 1
            if limit:
                if per_axis:
                    if abs(u0) > a_max or abs(u1) > a_max or abs(u2) > a_max:
                        n_sat[i] += 1
                    u0 = min(max(u0, -a_max), a_max)
                    u1 = min(max(u1, -a_max), a_max)
                    u2 = min(max(u2, -a_max), a_max)
                else:
                    norm = math.sqrt(u0 * u0 + u1 * u1 + u2 * u2)
                    if norm > a_max:
                        n_sat[i] += 1
                        s = a_max / norm
                        u0, u1, u2 = u0 * s, u1 * s, u2 * s
            ts = tscale[i]
            u0, u1, u2 = u0 * ts, u1 * ts, u2 * ts
            W[W_U0, l], W[W_U1, l], W[W_U2, l] = u0, u1, u2
            dv[l] += math.sqrt(u0 * u0 + u1 * u1 + u2 * u2) * dt
        # ---- the sub-steps: positions from the period's start (rows of the maps)
        for a in range(3):
            for l in range(m):
                pts[0, a, l] = st[a, l]
        for s in range(n_sub):
            ph = phi[k, s]
            gm = gam[k, s]
            for a in range(3):
                f0, f1, f2, f3, f4, f5 = ph[a, 0], ph[a, 1], ph[a, 2], ph[a, 3], ph[a, 4], ph[a, 5]
                g0, g1, g2 = gm[a, 0], gm[a, 1], gm[a, 2]
                for l in range(m):
                    pts[s + 1, a, l] = (f0 * st[0, l] + f1 * st[1, l] + f2 * st[2, l]
                                        + f3 * st[3, l] + f4 * st[4, l] + f5 * st[5, l]
                                        + g0 * W[W_U0, l] + g1 * W[W_U1, l] + g2 * W[W_U2, l])
        # velocity at the period's end (positions are the last sub-step's)
        ph = phi[k, n_sub - 1]
        gm = gam[k, n_sub - 1]
        for a in range(3, 6):
            f0, f1, f2, f3, f4, f5 = ph[a, 0], ph[a, 1], ph[a, 2], ph[a, 3], ph[a, 4], ph[a, 5]
            g0, g1, g2 = gm[a, 0], gm[a, 1], gm[a, 2]
            for l in range(m):
                W[W_X3 + a - 3, l] = (f0 * st[0, l] + f1 * st[1, l] + f2 * st[2, l]
                                      + f3 * st[3, l] + f4 * st[4, l] + f5 * st[5, l]
                                      + g0 * W[W_U0, l] + g1 * W[W_U1, l] + g2 * W[W_U2, l])
        # ---- geometry of the sub-step positions, part by part (squared distances)
        for s in range(1, n_sub + 1):
            for l in range(m):
                x, y, z = pts[s, 0, l], pts[s, 1, l], pts[s, 2, l]
                q = x * x + y * y + z * z
                r2[l] = q if q < r2[l] else r2[l]
        for p in range(Pn):
            lo0, lo1, lo2 = s_lo[p, 0], s_lo[p, 1], s_lo[p, 2]
            hi0, hi1, hi2 = s_hi[p, 0], s_hi[p, 1], s_hi[p, 2]
            for s in range(1, n_sub + 1):
                for l in range(m):
                    x, y, z = pts[s, 0, l], pts[s, 1, l], pts[s, 2, l]
                    gx = max(lo0 - x, x - hi0, 0.0)
                    gy = max(lo1 - y, y - hi1, 0.0)
                    gz = max(lo2 - z, z - hi2, 0.0)
                    q = gx * gx + gy * gy + gz * gz
                    d2[p, l] = q if q < d2[p, l] else d2[p, l]
            if solid[p]:
                for s in range(1, n_sub + 1):
                    for l in range(m):
                        x, y, z = pts[s, 0, l], pts[s, 1, l], pts[s, 2, l]
                        depth = min(np.inf, x - lo0, hi0 - x)
                        depth = min(depth, y - lo1, hi1 - y)
                        depth = min(depth, z - lo2, hi2 - z)
                        dep[l] = depth if depth > dep[l] else dep[l]
        # bounding box of each lane's path in the period
        for a in range(3):
            for l in range(m):
                bb[a, l] = pts[0, a, l]
                bb[3 + a, l] = pts[0, a, l]
            for s in range(1, n_sub + 1):
                for l in range(m):
                    bb[a, l] = min(bb[a, l], pts[s, a, l])
                    bb[3 + a, l] = max(bb[3 + a, l], pts[s, a, l])
        # ---- scalar pass: swept tests where the box meets a part, the new state, records
        for l in range(m):
            i = i0 + l
            for p in range(Pn):
                if hits[i, p]:
                    continue
                if (bb[3, l] < c_lo[p, 0] or bb[0, l] > c_hi[p, 0] or bb[4, l] < c_lo[p, 1]
                        or bb[1, l] > c_hi[p, 1] or bb[5, l] < c_lo[p, 2]
                        or bb[2, l] > c_hi[p, 2]):
                    continue
                if _swept(pts, l, n_sub, c_lo[p], c_hi[p]):
                    hits[i, p] = True
            x, y, z = pts[n_sub, 0, l], pts[n_sub, 1, l], pts[n_sub, 2, l]
            vx, vy, vz = W[W_X3, l], W[W_X4, l], W[W_X5, l]
            if not failed[i] and not (math.isfinite(x) and math.isfinite(y)
                                      and math.isfinite(z) and math.isfinite(vx)
                                      and math.isfinite(vy) and math.isfinite(vz)):
                failed[i] = True
                x = y = z = vx = vy = vz = 0.0  # frozen; flagged, its outputs unusable
            st[0, l], st[1, l], st[2, l], st[3, l], st[4, l], st[5, l] = x, y, z, vx, vy, vz
        if (k + 1) % record_every == 0:
            j = (k + 1) // record_every
            for l in range(m):
                i = i0 + l
                put_lane(r_rec, i, j, 0, st, 0, 3, l)
                put_lane(v_rec, i, j, 0, st, 3, 3, l)
                dv_rec[i, j] = dv[l]
            if with_zem:
                _zem(j, i0, m, st, coast[k + 1], goal, zem)
    for l in range(m):
        i = i0 + l
        delta_v[i] = dv[l]
        r2min[i] = r2[l]
        penetration[i] = dep[l]
        for p in range(Pn):
            d2min[i, p] = d2[p, l]


@njit(cache=True, error_model="numpy")
def _zem(j, i0, m, st, C, goal, zem):  # pragma: no cover - compiled
    """``|Phi(t_f, t) x - goal|`` of every lane into column ``j`` (``C`` the first 3 rows)."""
    for l in range(m):
        acc = 0.0
        for a in range(3):
            z = 0.0
            for b in range(6):
                z += C[a, b] * st[b, l]
            z -= goal[a]
            acc += z * z
        zem[i0 + l, j] = math.sqrt(acc)


@njit(cache=True, error_model="numpy")
def _swept(pts, l, n_sub, lo, hi):  # pragma: no cover - compiled
    """Whether one of lane ``l``'s segments between consecutive positions meets the box
    ``[lo, hi]`` (the slab test of :func:`.geometry.segment_box_hits`)."""
    for s in range(n_sub):
        t_enter = -np.inf
        t_exit = np.inf
        for a in range(3):
            p0 = pts[s, a, l]
            dp = pts[s + 1, a, l] - p0
            if dp != 0.0:
                t1 = (lo[a] - p0) / dp
                t2 = (hi[a] - p0) / dp
                t_enter = max(t_enter, min(t1, t2))
                t_exit = min(t_exit, max(t1, t2))
            elif p0 < lo[a] or p0 > hi[a]:
                t_enter = np.inf
                t_exit = -np.inf
        if t_enter <= t_exit and t_exit >= 0.0 and t_enter <= 1.0:
            return True
    return False
