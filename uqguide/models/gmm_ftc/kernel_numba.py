"""Compiled GMM-FTC closed loop: the arithmetic of :mod:`.closed_loop`, one sample at a time.

:func:`.closed_loop.run_closed_loop` (NumPy over the batch) is the reference; this kernel runs
the same sampled-data loop (GMM-FTC at ``t_k``, thrust factors and keyed noise, RK4 of the
body-frame plant, per-sub-step geometry, the same metrics) in one compiled function with the
batch as the outer, parallel loop. NumPy advances a whole batch per Python-level step and pays
~1 ms of call overhead per step whatever the batch size; the kernel pays nothing per step, so
one 3,000-step run costs a few milliseconds. Results agree with the reference to rounding
(tests/test_gmm_ftc_kernel.py), not bit for bit: sums are taken in another order.

Layout of the per-sample scalar results (columns of ``sc``) is :data:`SCALAR_COLUMNS`.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..kernels import njit

SCALAR_COLUMNS: tuple[str, ...] = (
    "bad_e", "bad_settle", "bad_v", "bad_s2", "bad_speed", "bad_u", "pos_error_final",
    "speed_final", "speed_max", "speed_max_x", "speed_max_y", "speed_max_z", "u_max", "u_conv",
    "u_lo_x", "u_lo_y", "u_lo_z", "u_hi_x", "u_hi_y", "u_hi_z", "delta_v", "penetration",
    "range_min", "n_guarded", "n_nonfinite", "failed",
)
COL = {name: i for i, name in enumerate(SCALAR_COLUMNS)}

_GAMMA = np.uint64(0x9E3779B97F4A7C15)
_M1 = np.uint64(0xBF58476D1CE4E5B9)
_M2 = np.uint64(0x94D049BB133111EB)
_S30 = np.uint64(30)
_S27 = np.uint64(27)
_S31 = np.uint64(31)
_S11 = np.uint64(11)
_ONE = np.uint64(1)


@njit(cache=True, inline="always")
def _uniform(key: np.uint64, element: int) -> float:  # pragma: no cover - compiled
    # element `element` of the SplitMix64 stream `key` (noise.uniform, same bits)
    z = key + (np.uint64(element) + _ONE) * _GAMMA
    z = (z ^ (z >> _S30)) * _M1
    z = (z ^ (z >> _S27)) * _M2
    z = z ^ (z >> _S31)
    return float(z >> _S11) * 2.0**-53


@njit(cache=True, inline="always")
def _attitude(w: np.ndarray, t: float, C0: np.ndarray, C: np.ndarray) -> None:  # pragma: no cover
    # C = C0 exp(t [w x]) (Rodrigues)
    rate = math.sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2])
    R = np.eye(3)
    if rate > 0.0:
        k0, k1, k2 = w[0] / rate, w[1] / rate, w[2] / rate
        s = math.sin(rate * t)
        c1 = 1.0 - math.cos(rate * t)
        K = np.array([[0.0, -k2, k1], [k2, 0.0, -k0], [-k1, k0, 0.0]])
        for a in range(3):
            for b in range(3):
                kk = K[a, 0] * K[0, b] + K[a, 1] * K[1, b] + K[a, 2] * K[2, b]
                R[a, b] += s * K[a, b] + c1 * kk
    for a in range(3):
        for b in range(3):
            C[a, b] = C0[a, 0] * R[0, b] + C0[a, 1] * R[1, b] + C0[a, 2] * R[2, b]


@njit(cache=True, inline="always")
def _mv(M: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    for a in range(3):
        out[a] = M[a, 0] * x[0] + M[a, 1] * x[1] + M[a, 2] * x[2]


@njit(cache=True, inline="always")
def _mtv(M: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    for a in range(3):
        out[a] = M[0, a] * x[0] + M[1, a] * x[1] + M[2, a] * x[2]


@njit(cache=True, inline="always")
def _cross(a: np.ndarray, b: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@njit(cache=True)
def _plant(A: np.ndarray, B: np.ndarray, C: np.ndarray, w: np.ndarray, printed: bool,
           r: np.ndarray, v: np.ndarray, out: np.ndarray) -> None:  # pragma: no cover
    # A21 r + A22 v = C^T (A C r + B C (v + w x r)) - w x (w x r) - 2 w x v   (corrected [C 7])
    # printed: A C r + B (v + w x r) - w x (w x r) - 2 w x v
    wr = np.empty(3)
    wwr = np.empty(3)
    wv = np.empty(3)
    Cr = np.empty(3)
    t1 = np.empty(3)
    t2 = np.empty(3)
    s = np.empty(3)
    _cross(w, r, wr)
    _cross(w, wr, wwr)
    _cross(w, v, wv)
    _mv(C, r, Cr)
    _mv(A, Cr, t1)
    for a in range(3):
        s[a] = v[a] + wr[a]
    if printed:
        _mv(B, s, t2)
        for a in range(3):
            out[a] = t1[a] + t2[a] - wwr[a] - 2.0 * wv[a]
    else:
        Cs = np.empty(3)
        _mv(C, s, Cs)
        _mv(B, Cs, t2)
        for a in range(3):
            t1[a] += t2[a]
        _mtv(C, t1, t2)
        for a in range(3):
            out[a] = t2[a] - wwr[a] - 2.0 * wv[a]


@njit(cache=True)
def _sig(x: float, a: float) -> float:  # pragma: no cover
    if x > 0.0:
        return x**a
    if x < 0.0:
        return -((-x) ** a)
    return 0.0


@njit(cache=True)
def _law(r, v, r_f, P, M, c, mu, L, alpha1, beta1, lam1, lam2, zeta1, zeta2, k_s, det_guard,
         plant_acc, u, s2):  # pragma: no cover
    """GMM-FTC command u (and s2); returns 1 if the Jacobian was guarded."""
    K = mu.shape[0]
    Vv = 0.0
    gV = np.zeros(3)
    HV = np.zeros((3, 3))
    TV = np.zeros(3)
    d = np.empty(3)
    th = np.empty(3)
    Ly = np.empty(3)
    for k in range(K):
        for a in range(3):
            d[a] = r[a] - mu[k, a]
        q = 0.0
        for a in range(3):
            th[a] = L[k, a, 0] * d[0] + L[k, a, 1] * d[1] + L[k, a, 2] * d[2]
            q += d[a] * th[a]
        eta = c[k] * math.exp(-0.5 * q)
        if eta == 0.0:
            continue
        Vv += eta
        yLy = 0.0
        ty = 0.0
        for a in range(3):
            Ly[a] = L[k, a, 0] * v[0] + L[k, a, 1] * v[1] + L[k, a, 2] * v[2]
            yLy += v[a] * Ly[a]
            ty += th[a] * v[a]
        for a in range(3):
            gV[a] -= eta * th[a]
            for b in range(3):
                HV[a, b] += eta * (th[a] * th[b] - L[k, a, b])
            TV[a] += eta * ((yLy - ty * ty) * th[a] + 2.0 * ty * Ly[a])
    e = np.empty(3)
    for a in range(3):
        e[a] = r[a] - r_f[a]
    Me = np.empty(3)
    Pe = np.empty(3)
    My = np.empty(3)
    hy = np.empty(3)
    _mv(M, e, Me)
    _mv(P, e, Pe)
    _mv(M, v, My)
    _mv(HV, v, hy)
    qe = e[0] * Me[0] + e[1] * Me[1] + e[2] * Me[2]
    gy = gV[0] * v[0] + gV[1] * v[1] + gV[2] * v[2]
    yhy = v[0] * hy[0] + v[1] * hy[1] + v[2] * hy[2]
    eMy = e[0] * My[0] + e[1] * My[1] + e[2] * My[2]
    yMy = v[0] * My[0] + v[1] * My[1] + v[2] * My[2]
    g = np.empty(3)
    H = np.empty((3, 3))
    gam = np.empty(3)
    for a in range(3):
        g[a] = Pe[a] + Vv * Me[a] + 0.5 * qe * gV[a]
        gam[a] = (2.0 * gy * My[a] + yhy * Me[a] + 2.0 * eMy * hy[a] + yMy * gV[a]
                  + 0.5 * qe * TV[a])
        for b in range(3):
            H[a, b] = (P[a, b] + Vv * M[a, b] + Me[a] * gV[b] + gV[a] * Me[b]
                       + 0.5 * qe * HV[a, b])
    s1 = np.empty(3)
    Hv = np.empty(3)
    _mv(H, v, Hv)
    J = np.empty((3, 3))
    rhs = np.empty(3)
    for a in range(3):
        s1[a] = e[a] + k_s[a] * g[a]
    for a in range(3):
        s2[a] = v[a] + alpha1[a] * s1[a] + beta1[a] * s1[a] ** 3 + k_s[a] * Hv[a]
        for b in range(3):
            J[a, b] = (1.0 if a == b else 0.0) + k_s[a] * H[a, b]
    for a in range(3):
        Jv = v[a] + k_s[a] * Hv[a]
        lam_y2 = (alpha1[a] + 3.0 * beta1[a] * s1[a] * s1[a]) * Jv
        rhs[a] = (-lam1[a] * _sig(s2[a], zeta1) - lam2[a] * _sig(s2[a], zeta2) - lam_y2
                  - k_s[a] * gam[a])
    det = (J[0, 0] * (J[1, 1] * J[2, 2] - J[1, 2] * J[2, 1])
           - J[0, 1] * (J[1, 0] * J[2, 2] - J[1, 2] * J[2, 0])
           + J[0, 2] * (J[1, 0] * J[2, 1] - J[1, 1] * J[2, 0]))
    guarded = 0
    if not abs(det) >= det_guard:
        guarded = 1
        for a in range(3):
            u[a] = rhs[a] - plant_acc[a]
        return guarded
    # Cramer's rule (3x3, det checked above)
    for a in range(3):
        Ja = J.copy()
        for b in range(3):
            Ja[b, a] = rhs[b]
        da = (Ja[0, 0] * (Ja[1, 1] * Ja[2, 2] - Ja[1, 2] * Ja[2, 1])
              - Ja[0, 1] * (Ja[1, 0] * Ja[2, 2] - Ja[1, 2] * Ja[2, 0])
              + Ja[0, 2] * (Ja[1, 0] * Ja[2, 1] - Ja[1, 1] * Ja[2, 0]))
        u[a] = da / det - plant_acc[a]
    return guarded


@njit(cache=True)
def _box_distance(p, lo, hi) -> float:  # pragma: no cover
    s = 0.0
    for a in range(3):
        gap = max(lo[a] - p[a], p[a] - hi[a], 0.0)
        s += gap * gap
    return math.sqrt(s)


@njit(cache=True)
def _depth(p, lo, hi) -> float:  # pragma: no cover
    d = np.inf
    for a in range(3):
        d = min(d, p[a] - lo[a], hi[a] - p[a])
    return max(d, 0.0)


@njit(cache=True)
def _segment_hits(p0, p1, lo, hi) -> bool:  # pragma: no cover
    # slab test of gmm.geometry.segment_box_hits
    t_enter = -np.inf
    t_exit = np.inf
    for a in range(3):
        d = p1[a] - p0[a]
        if d != 0.0:
            t1 = (lo[a] - p0[a]) / d
            t2 = (hi[a] - p0[a]) / d
            t_enter = max(t_enter, min(t1, t2))
            t_exit = min(t_exit, max(t1, t2))
        elif not (lo[a] <= p0[a] <= hi[a]):
            return False
    return t_enter <= t_exit and t_exit >= 0.0 and t_enter <= 1.0


@njit(cache=True, parallel=True)
def simulate(x0, W, Wc, C0, ctl_separate, plant_printed, ctl_printed, times, A_st, B_st,
             r_f, P, M, c, mu, L, alpha1, beta1, lam1, lam2, zeta1, zeta2, k_s, det_guard,
             scale, noise_w, keys, s_lo, s_hi, c_lo, c_hi, is_solid, reach,
             dt, n_sub, N, record_every, converge_tol, settle_tol, velocity_tol, s2_tol,
             k_check, u_max,
             rec_r, rec_v, rec_u, rec_rl, rec_vl, rec_ul, rec_u32, rec_s2, rec_dv,
             clearance, hits, sc):  # pragma: no cover - compiled
    """Run every sample; fill the record arrays (n, T, ...) and scalars ``sc`` (n, columns).

    ``W`` (m, 3) / ``Wc`` (mc, 3): plant / controller spins (m, mc in {1, n});
    ``times``, ``A_st``, ``B_st``: the orbit on the half-step grid (2 N n_sub + 1 points).
    """
    n = x0.shape[0]
    nP = s_lo.shape[0]
    h = dt / n_sub
    mw = W.shape[0]
    mwc = Wc.shape[0]
    for i in nb.prange(n):
        ii = np.int64(i)
        w = W[min(ii, np.int64(mw - 1))]
        wc = Wc[min(ii, np.int64(mwc - 1))]
        r = x0[i, :3].copy()
        v = x0[i, 3:].copy()
        C = np.empty((3, 3))
        Ch = np.empty((3, 3))
        C1 = np.empty((3, 3))
        Cc = np.empty((3, 3))
        pa = np.empty(3)
        u = np.empty(3)
        s2 = np.empty(3)
        tmp = np.empty(3)
        tmp2 = np.empty(3)
        d_prev = np.empty(nP)
        for p in range(nP):
            clearance[i, p] = _box_distance(r, s_lo[p], s_hi[p])
            d_prev[p] = clearance[i, p]
            hits[i, p] = False
        pen = 0.0
        for p in range(nP):
            if is_solid[p]:
                pen = max(pen, _depth(r, s_lo[p], s_hi[p]))
        rng_min = math.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2)
        bad_e = bad_settle = bad_v = bad_s2 = bad_speed = bad_u = -1
        pos_final = speed_final = speed_max = u_mx = u_conv = dv = 0.0
        sp_ax = np.zeros(3)
        u_lo = np.full(3, np.inf)
        u_hi = np.full(3, -np.inf)
        n_guard = 0
        n_bad = 0
        failed = False
        _attitude(w, times[0], C0, C)
        k1r = np.empty(3)
        k1v = np.empty(3)
        k2r = np.empty(3)
        k2v = np.empty(3)
        k3r = np.empty(3)
        k3v = np.empty(3)
        k4r = np.empty(3)
        k4v = np.empty(3)
        rs = np.empty(3)
        vs = np.empty(3)
        for k in range(N + 1):
            j0 = 2 * k * n_sub
            if ctl_separate:
                _attitude(wc, times[j0], C0, Cc)
                _plant(A_st[j0], B_st[j0], Cc, wc, ctl_printed, r, v, pa)
            else:
                _plant(A_st[j0], B_st[j0], C, w, plant_printed, r, v, pa)
            n_guard += _law(r, v, r_f, P, M, c, mu, L, alpha1, beta1, lam1, lam2, zeta1,
                            zeta2, k_s, det_guard, pa, u, s2)
            if not (math.isfinite(u[0]) and math.isfinite(u[1]) and math.isfinite(u[2])):
                u[:] = 0.0
                n_bad += 1
            if math.isfinite(u_max):
                un = math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2)
                f = min(1.0, u_max / max(un, 1e-300))
                for a in range(3):
                    u[a] *= f
            for a in range(3):
                u[a] *= scale[i, a]
            if noise_w > 0.0:
                for a in range(3):
                    u[a] *= 1.0 + noise_w * (2.0 * _uniform(keys[i], 3 * k + a) - 1.0)
            e_norm = math.sqrt((r[0] - r_f[0]) ** 2 + (r[1] - r_f[1]) ** 2
                               + (r[2] - r_f[2]) ** 2)
            speed = math.sqrt(v[0] ** 2 + v[1] ** 2 + v[2] ** 2)
            u_norm = math.sqrt(u[0] ** 2 + u[1] ** 2 + u[2] ** 2)
            s2n = math.sqrt(s2[0] ** 2 + s2[1] ** 2 + s2[2] ** 2)
            if not e_norm < converge_tol:
                bad_e = k
            if not e_norm < settle_tol:
                bad_settle = k
            if not speed < velocity_tol:
                bad_v = k
            if not s2n < s2_tol:
                bad_s2 = k
            if not speed < 0.15:
                bad_speed = k
            if not u_norm < 0.06:
                bad_u = k
            speed_max = max(speed_max, speed)
            u_mx = max(u_mx, u_norm)
            for a in range(3):
                sp_ax[a] = max(sp_ax[a], abs(v[a]))
            u_conv = max(u_conv, u_norm) if e_norm < converge_tol else 0.0
            if k >= k_check:
                pos_final = max(pos_final, e_norm)
                speed_final = max(speed_final, speed)
                for a in range(3):
                    u_lo[a] = min(u_lo[a], u[a])
                    u_hi[a] = max(u_hi[a], u[a])
            if k % record_every == 0:
                ir = k // record_every
                _cross(w, r, tmp)
                for a in range(3):
                    rec_r[i, ir, a] = r[a]
                    rec_v[i, ir, a] = v[a]
                    rec_u[i, ir, a] = u[a]
                    tmp[a] += v[a]
                _mv(C, r, tmp2)
                rec_rl[i, ir] = tmp2
                _mv(C, tmp, tmp2)
                rec_vl[i, ir] = tmp2
                _mv(C, u, tmp2)
                rec_ul[i, ir] = tmp2
                # eq (32): u + 2 w x v + w x (w x r)
                _cross(w, r, tmp)
                _cross(w, tmp, tmp2)
                _cross(w, v, tmp)
                for a in range(3):
                    tmp2[a] += u[a] + 2.0 * tmp[a]
                _mv(C, tmp2, tmp)
                rec_u32[i, ir] = tmp
                rec_s2[i, ir] = s2n
                rec_dv[i, ir] = dv
            if k == N:
                break
            dv += u_norm * dt
            for s in range(n_sub):
                j = j0 + 2 * s
                _attitude(w, times[j + 1], C0, Ch)
                _attitude(w, times[j + 2], C0, C1)
                _plant(A_st[j], B_st[j], C, w, plant_printed, r, v, k1v)
                for a in range(3):
                    k1r[a] = v[a]
                    k1v[a] += u[a]
                    rs[a] = r[a] + 0.5 * h * k1r[a]
                    vs[a] = v[a] + 0.5 * h * k1v[a]
                _plant(A_st[j + 1], B_st[j + 1], Ch, w, plant_printed, rs, vs, k2v)
                for a in range(3):
                    k2r[a] = vs[a]
                    k2v[a] += u[a]
                for a in range(3):
                    rs[a] = r[a] + 0.5 * h * k2r[a]
                    vs[a] = v[a] + 0.5 * h * k2v[a]
                _plant(A_st[j + 1], B_st[j + 1], Ch, w, plant_printed, rs, vs, k3v)
                for a in range(3):
                    k3r[a] = vs[a]
                    k3v[a] += u[a]
                for a in range(3):
                    rs[a] = r[a] + h * k3r[a]
                    vs[a] = v[a] + h * k3v[a]
                _plant(A_st[j + 2], B_st[j + 2], C1, w, plant_printed, rs, vs, k4v)
                for a in range(3):
                    k4r[a] = vs[a]
                    k4v[a] += u[a]
                p0 = r.copy()
                for a in range(3):
                    r[a] = r[a] + (h / 6.0) * (k1r[a] + 2 * k2r[a] + 2 * k3r[a] + k4r[a])
                    v[a] = v[a] + (h / 6.0) * (k1v[a] + 2 * k2v[a] + 2 * k3v[a] + k4v[a])
                half = 0.5 * math.sqrt((r[0] - p0[0]) ** 2 + (r[1] - p0[1]) ** 2
                                       + (r[2] - p0[2]) ** 2)
                near = False
                for p in range(nP):
                    dn = _box_distance(r, s_lo[p], s_hi[p])
                    clearance[i, p] = min(clearance[i, p], dn)
                    if is_solid[p] and dn == 0.0:
                        pen = max(pen, _depth(r, s_lo[p], s_hi[p]))
                    if min(d_prev[p], dn) <= half + reach:
                        near = True
                    d_prev[p] = dn
                if near:
                    for p in range(nP):
                        if _segment_hits(p0, r, c_lo[p], c_hi[p]):
                            hits[i, p] = True
                rng_min = min(rng_min, math.sqrt(r[0] ** 2 + r[1] ** 2 + r[2] ** 2))
                C[:, :] = C1
            if not failed and not (math.isfinite(r[0]) and math.isfinite(r[1])
                                   and math.isfinite(r[2]) and math.isfinite(v[0])
                                   and math.isfinite(v[1]) and math.isfinite(v[2])):
                failed = True
                r[:] = 0.0  # frozen; flagged, its outputs are not to be used
                v[:] = 0.0
        row = sc[i]
        row[0], row[1], row[2], row[3], row[4], row[5] = (bad_e, bad_settle, bad_v, bad_s2,
                                                          bad_speed, bad_u)
        row[6], row[7], row[8] = pos_final, speed_final, speed_max
        row[9], row[10], row[11] = sp_ax[0], sp_ax[1], sp_ax[2]
        row[12], row[13] = u_mx, u_conv
        row[14], row[15], row[16] = u_lo[0], u_lo[1], u_lo[2]
        row[17], row[18], row[19] = u_hi[0], u_hi[1], u_hi[2]
        row[20], row[21], row[22] = dv, pen, rng_min
        row[23], row[24], row[25] = n_guard, n_bad, 1.0 if failed else 0.0


def run_closed_loop_numba(plant, controller_plant, law, geometry, x0, settings,
                          thrust_scale=None, noise_keys=None):
    """:func:`.closed_loop.run_closed_loop` through the compiled kernel (same arguments and
    result)."""
    from .closed_loop import LoopRun, scalar_results

    st = settings
    x0 = np.ascontiguousarray(x0, dtype=float)
    n = x0.shape[0]
    N, dt = st.n_steps, st.dt
    if st.thrust_noise > 0 and noise_keys is None:
        raise ValueError("a per-period thrust noise needs the samples' noise keys")
    V = law.potential.V
    if V.c.ndim != 1:
        raise ValueError("the compiled kernel needs one GMM for the whole batch")
    h = dt / st.n_sub
    sched = plant.stage_schedule(N * st.n_sub, h)
    ctl = plant if controller_plant is None else controller_plant
    T = N // st.record_every + 1
    rec = {k: np.empty((n, T, 3)) for k in ("r", "v", "u", "r_l", "v_l", "u_l", "u_eq32_l")}
    rec_s2 = np.empty((n, T))
    rec_dv = np.empty((n, T))
    P_ = len(geometry.parts)
    clearance = np.empty((n, P_))
    hits = np.zeros((n, P_), dtype=np.bool_)
    sc = np.empty((n, len(SCALAR_COLUMNS)))
    scale = np.ones((n, 3)) if thrust_scale is None else np.ascontiguousarray(thrust_scale,
                                                                               dtype=float)
    keys = np.zeros(n, dtype=np.uint64) if noise_keys is None else np.ascontiguousarray(
        noise_keys, dtype=np.uint64)
    is_solid = np.array([p.kind == "solid" for p in geometry.parts])
    reach = float(np.sqrt(3.0) * np.max(np.abs(geometry.collision_lo - geometry.skeleton_lo))
                  + 1e-9)
    g = law.gains
    simulate(
        x0, np.ascontiguousarray(plant.w), np.ascontiguousarray(ctl.w), plant.C0,
        controller_plant is not None, plant.printed, ctl.printed, sched.times, sched.A,
        sched.B, law.r_f, law.potential.P, law.potential.M, V.c, V.mu, V.L, g.alpha1, g.beta1,
        g.lambda1, g.lambda2, float(g.zeta1), float(g.zeta2), g.k_s, float(law.det_guard),
        scale, float(st.thrust_noise), keys, geometry.skeleton_lo, geometry.skeleton_hi,
        geometry.collision_lo, geometry.collision_hi, is_solid, reach, float(dt),
        int(st.n_sub), int(N), int(st.record_every), float(st.converge_tol),
        float(st.settle_tol), float(st.velocity_tol), float(st.s2_tol),
        int(np.ceil(st.t_check / dt - 1e-9)), float(st.u_max),
        rec["r"], rec["v"], rec["u"], rec["r_l"], rec["v_l"], rec["u_l"], rec["u_eq32_l"],
        rec_s2, rec_dv, clearance, hits, sc)
    col = {name: sc[:, j] for j, name in enumerate(SCALAR_COLUMNS)}
    scalars = scalar_results(
        bad={k: col[k].astype(int) for k in SCALAR_COLUMNS[:6]}, dt=dt, t_final=st.t_final,
        n_steps=N, pos_final=col["pos_error_final"], speed_final=col["speed_final"],
        speed_max=col["speed_max"],
        speed_axes=np.stack([col["speed_max_x"], col["speed_max_y"], col["speed_max_z"]], 1),
        u_max=col["u_max"], u_conv=col["u_conv"],
        u_lo=np.stack([col["u_lo_x"], col["u_lo_y"], col["u_lo_z"]], 1),
        u_hi=np.stack([col["u_hi_x"], col["u_hi_y"], col["u_hi_z"]], 1),
        u_last=rec["u"][:, -1], delta_v=col["delta_v"], clearance=clearance,
        penetration=col["penetration"], hits=hits, range_min=col["range_min"],
        n_guarded=col["n_guarded"], n_nonfinite=col["n_nonfinite"])
    return LoopRun(time=np.arange(T) * dt * st.record_every, goal=law.r_f, s2=rec_s2,
                   dv_cum=rec_dv, scalars=scalars, failed=col["failed"] > 0, **rec)
