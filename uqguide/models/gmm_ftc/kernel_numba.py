"""Compiled GMM-FTC closed loop in blocks of samples (:mod:`.loop`: its settings and result).

One compiled function runs the sampled-data loop; it agrees with the NumPy oracle
``tests/oracles/gmm_ftc.py`` to rounding (``tests/test_gmm_ftc_kernel.py``), and a sample's
numbers do not depend on its block, its lane, the thread count or the batch. The layout and why:
docs/performance.md#the-gmm-ftc-kernel; the potential's passes:
docs/simulators.md#gmm-ftc-the-potential-in-the-kernel. The per-sample scalar results are the
columns :data:`SCALAR_COLUMNS` of ``sc``.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from ..kernels import njit
from ..record_rows import put_lane
from .loop import LoopRun, scalar_results

SCALAR_COLUMNS: tuple[str, ...] = (
    "bad_e", "bad_settle", "bad_v", "bad_s2", "bad_speed", "bad_u", "pos_error_final",
    "speed_final", "speed_max", "speed_max_x", "speed_max_y", "speed_max_z", "u_max", "u_conv",
    "u_lo_x", "u_lo_y", "u_lo_z", "u_hi_x", "u_hi_y", "u_hi_z", "delta_v", "penetration",
    "range_min", "n_guarded", "n_nonfinite", "failed",
)
COL = {name: i for i, name in enumerate(SCALAR_COLUMNS)}
N_COL = len(SCALAR_COLUMNS)
C_DV, C_PEN, C_RANGE = COL["delta_v"], COL["penetration"], COL["range_min"]
C_GUARDED, C_NONFINITE, C_FAILED = COL["n_guarded"], COL["n_nonfinite"], COL["failed"]

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


BLOCK = 64
"""Samples per parallel task; they advance in lockstep (see :func:`_simulate_block`)."""

# rows of the potential's accumulator ``acc (N_ACC, m)``: value, gradient, Hessian (row by row)
# and the third derivative contracted twice with the velocity
A_V, A_G, A_H, A_T = 0, 1, 4, 13
N_ACC = 16

# how |x|^a is evaluated (chosen once per run): pow, sqrt, |x| sqrt(|x|)
POW_GENERAL, POW_HALF, POW_THREE_HALVES = 0, 1, 2


@njit(cache=True)
def pow_mode(a: float) -> int:
    """How ``|x|^a`` is evaluated: :data:`POW_HALF` for ``a = 0.5``, :data:`POW_THREE_HALVES`
    for 1.5, else :data:`POW_GENERAL` (docs/simulators.md#gmm-ftc-the-potential-in-the-kernel)."""
    if a == 0.5:
        return POW_HALF
    if a == 1.5:
        return POW_THREE_HALVES
    return POW_GENERAL


@njit(cache=True, error_model="numpy", inline="always")
def _abs_pow(x: float, a: float, mode: int) -> float:  # pragma: no cover - compiled
    # |x|^a for x >= 0; sqrt is correctly rounded, pow within an ulp: the forms agree to round-off
    if mode == POW_THREE_HALVES:
        return x * math.sqrt(x)
    if mode == POW_HALF:
        return math.sqrt(x)
    return x**a


@njit(cache=True, error_model="numpy", inline="always")
def _sig2(x: float, a1: float, m1: int, a2: float, m2: int) -> tuple[float, float]:
    # (sig^a1(x), sig^a2(x)) with sig^a(x) = sign(x) |x|^a
    if x > 0.0:
        return _abs_pow(x, a1, m1), _abs_pow(x, a2, m2)
    if x < 0.0:
        return -_abs_pow(-x, a1, m1), -_abs_pow(-x, a2, m2)
    return 0.0, 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _rotation(w0, w1, w2, t, C0):  # pragma: no cover - compiled
    # C0 exp(t [w x]) (Rodrigues), its nine entries row by row
    rate = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
    R00, R01, R02 = 1.0, 0.0, 0.0
    R10, R11, R12 = 0.0, 1.0, 0.0
    R20, R21, R22 = 0.0, 0.0, 1.0
    if rate > 0.0:
        k0, k1, k2 = w0 / rate, w1 / rate, w2 / rate
        s = math.sin(rate * t)
        c1 = 1.0 - math.cos(rate * t)
        # I + s K + c1 K^2 with K = [k x]
        R00 = 1.0 + c1 * (-(k2 * k2) - k1 * k1)
        R01 = -(s * k2) + c1 * (k1 * k0)
        R02 = s * k1 + c1 * (k2 * k0)
        R10 = s * k2 + c1 * (k0 * k1)
        R11 = 1.0 + c1 * (-(k2 * k2) - k0 * k0)
        R12 = -(s * k0) + c1 * (k2 * k1)
        R20 = -(s * k1) + c1 * (k0 * k2)
        R21 = s * k0 + c1 * (k1 * k2)
        R22 = 1.0 + c1 * (-(k1 * k1) - k0 * k0)
    return (C0[0, 0] * R00 + C0[0, 1] * R10 + C0[0, 2] * R20,
            C0[0, 0] * R01 + C0[0, 1] * R11 + C0[0, 2] * R21,
            C0[0, 0] * R02 + C0[0, 1] * R12 + C0[0, 2] * R22,
            C0[1, 0] * R00 + C0[1, 1] * R10 + C0[1, 2] * R20,
            C0[1, 0] * R01 + C0[1, 1] * R11 + C0[1, 2] * R21,
            C0[1, 0] * R02 + C0[1, 1] * R12 + C0[1, 2] * R22,
            C0[2, 0] * R00 + C0[2, 1] * R10 + C0[2, 2] * R20,
            C0[2, 0] * R01 + C0[2, 1] * R11 + C0[2, 2] * R21,
            C0[2, 0] * R02 + C0[2, 1] * R12 + C0[2, 2] * R22)


@njit(cache=True, error_model="numpy")
def _attitudes(m, w, shared, t, C0, out):  # pragma: no cover - compiled
    """Attitude rows ``out (9, m)`` at time ``t``: computed once and copied to every lane when
    the spin is common (``shared``), else per lane; the same arithmetic either way, so a
    sample's bits do not depend on its batch."""
    R = _rotation(w[0, 0], w[1, 0], w[2, 0], t, C0)
    for l in range(m):
        if l > 0 and not shared:
            R = _rotation(w[0, l], w[1, l], w[2, l], t, C0)
        for q in range(9):
            out[q, l] = R[q]


@njit(cache=True, error_model="numpy")
def _plant(m, A_st, B_st, j, C, w, printed, x, out):  # pragma: no cover - compiled
    """``A21 r + A22 v`` of every lane into ``out (3, m)``; ``x (6, m)`` holds ``r``, ``v``.

    A21 r + A22 v = C^T (A C r + B C (v + w x r)) - w x (w x r) - 2 w x v  (corrected [C 7]);
    printed: A C r + B (v + w x r) - w x (w x r) - 2 w x v.
    """
    a00, a01, a02 = A_st[j, 0, 0], A_st[j, 0, 1], A_st[j, 0, 2]
    a10, a11, a12 = A_st[j, 1, 0], A_st[j, 1, 1], A_st[j, 1, 2]
    a20, a21, a22 = A_st[j, 2, 0], A_st[j, 2, 1], A_st[j, 2, 2]
    b00, b01, b02 = B_st[j, 0, 0], B_st[j, 0, 1], B_st[j, 0, 2]
    b10, b11, b12 = B_st[j, 1, 0], B_st[j, 1, 1], B_st[j, 1, 2]
    b20, b21, b22 = B_st[j, 2, 0], B_st[j, 2, 1], B_st[j, 2, 2]
    for l in range(m):
        w0, w1, w2 = w[0, l], w[1, l], w[2, l]
        r0, r1, r2 = x[0, l], x[1, l], x[2, l]
        v0, v1, v2 = x[3, l], x[4, l], x[5, l]
        wr0 = w1 * r2 - w2 * r1
        wr1 = w2 * r0 - w0 * r2
        wr2 = w0 * r1 - w1 * r0
        f0 = (w1 * wr2 - w2 * wr1) + 2.0 * (w1 * v2 - w2 * v1)
        f1 = (w2 * wr0 - w0 * wr2) + 2.0 * (w2 * v0 - w0 * v2)
        f2 = (w0 * wr1 - w1 * wr0) + 2.0 * (w0 * v1 - w1 * v0)
        c00, c01, c02 = C[0, l], C[1, l], C[2, l]
        c10, c11, c12 = C[3, l], C[4, l], C[5, l]
        c20, c21, c22 = C[6, l], C[7, l], C[8, l]
        Cr0 = c00 * r0 + c01 * r1 + c02 * r2
        Cr1 = c10 * r0 + c11 * r1 + c12 * r2
        Cr2 = c20 * r0 + c21 * r1 + c22 * r2
        t0 = a00 * Cr0 + a01 * Cr1 + a02 * Cr2
        t1 = a10 * Cr0 + a11 * Cr1 + a12 * Cr2
        t2 = a20 * Cr0 + a21 * Cr1 + a22 * Cr2
        s0, s1, s2 = v0 + wr0, v1 + wr1, v2 + wr2
        if printed:
            out[0, l] = t0 + (b00 * s0 + b01 * s1 + b02 * s2) - f0
            out[1, l] = t1 + (b10 * s0 + b11 * s1 + b12 * s2) - f1
            out[2, l] = t2 + (b20 * s0 + b21 * s1 + b22 * s2) - f2
        else:
            Cs0 = c00 * s0 + c01 * s1 + c02 * s2
            Cs1 = c10 * s0 + c11 * s1 + c12 * s2
            Cs2 = c20 * s0 + c21 * s1 + c22 * s2
            t0 += b00 * Cs0 + b01 * Cs1 + b02 * Cs2
            t1 += b10 * Cs0 + b11 * Cs1 + b12 * Cs2
            t2 += b20 * Cs0 + b21 * Cs1 + b22 * Cs2
            out[0, l] = (c00 * t0 + c10 * t1 + c20 * t2) - f0
            out[1, l] = (c01 * t0 + c11 * t1 + c21 * t2) - f1
            out[2, l] = (c02 * t0 + c12 * t1 + c22 * t2) - f2


EXP_ZERO = -746.0
"""``exp(x)`` is 0 in double precision below this: not evaluated there."""


@njit(cache=True, error_model="numpy")
def _weights(m, ck, arg, out):  # pragma: no cover - compiled
    """``out = ck exp(arg)`` of every lane; 0 without the call where ``exp`` underflows
    (docs/simulators.md#gmm-ftc-the-potential-in-the-kernel)."""
    for l in range(m):
        out[l] = 0.0
    for l in range(m):
        a = arg[l]
        if not a <= EXP_ZERO:  # NaN passes: exp(NaN) = NaN, as the reference
            out[l] = ck * math.exp(a)


@njit(cache=True, inline="always")
def _zero(acc, m):  # pragma: no cover - compiled
    for a in range(acc.shape[0]):
        for l in range(m):
            acc[a, l] = 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _add_value_gradient(m, ex, th, acc):  # pragma: no cover - compiled
    # one kernel's weight ``ex`` and ``-ex L (r - mu)`` (``th``) into the value and gradient rows;
    # a weight that underflowed to 0 adds nothing, as the reference skips the kernel
    for l in range(m):
        e = ex[l]
        live = e != 0.0
        t0, t1, t2 = th[0, l], th[1, l], th[2, l]
        acc[A_V, l] += e if live else 0.0
        acc[A_G, l] -= e * t0 if live else 0.0
        acc[A_G + 1, l] -= e * t1 if live else 0.0
        acc[A_G + 2, l] -= e * t2 if live else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _add_hessian(m, Lk, ex, th, acc):  # pragma: no cover - compiled
    # one kernel's ``e (th th^T - L)`` into the Hessian rows, a pass per row of H. A zero entry
    # of L subtracts nothing: x - 0 is x, and the sums start at +0, so even a zero's sign is kept
    for a in range(3):
        for l in range(m):
            e = ex[l]
            live = e != 0.0
            ta = th[a, l]
            for b in range(3):
                acc[A_H + 3 * a + b, l] += e * (ta * th[b, l] - Lk[a, b]) if live else 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _add_third(acc, l, e, th, y0, y1, y2, Ly0, Ly1, Ly2):  # pragma: no cover - compiled
    # one kernel's D3V[y, y] at lane l into the third-derivative rows (``Ly = L y``)
    t0, t1, t2 = th[0, l], th[1, l], th[2, l]
    yLy = y0 * Ly0 + y1 * Ly1 + y2 * Ly2
    ty = t0 * y0 + t1 * y1 + t2 * y2
    b = yLy - ty * ty
    live = e != 0.0
    acc[A_T, l] += e * (b * t0 + 2.0 * ty * Ly0) if live else 0.0
    acc[A_T + 1, l] += e * (b * t1 + 2.0 * ty * Ly1) if live else 0.0
    acc[A_T + 2, l] += e * (b * t2 + 2.0 * ty * Ly2) if live else 0.0


@njit(cache=True, error_model="numpy")
def _potential_diagonal(m, x, c, mu, L, acc, th, eta, ex):  # pragma: no cover - compiled
    """:func:`_potential` for kernels whose ``L`` has zero off-diagonal entries: the same
    numbers for a third of the work (docs/simulators.md#gmm-ftc-the-potential-in-the-kernel)."""
    _zero(acc, m)
    for k in range(mu.shape[0]):
        m0, m1, m2 = mu[k, 0], mu[k, 1], mu[k, 2]
        L00, L11, L22 = L[k, 0, 0], L[k, 1, 1], L[k, 2, 2]
        ck = c[k]
        for l in range(m):
            d0, d1, d2 = x[0, l] - m0, x[1, l] - m1, x[2, l] - m2
            t0, t1, t2 = L00 * d0, L11 * d1, L22 * d2
            th[0, l], th[1, l], th[2, l] = t0, t1, t2
            eta[l] = -0.5 * (d0 * t0 + d1 * t1 + d2 * t2)
        _weights(m, ck, eta, ex)
        _add_value_gradient(m, ex, th, acc)
        _add_hessian(m, L[k], ex, th, acc)
        for l in range(m):
            y0, y1, y2 = x[3, l], x[4, l], x[5, l]
            _add_third(acc, l, ex[l], th, y0, y1, y2, L00 * y0, L11 * y1, L22 * y2)


@njit(cache=True, error_model="numpy")
def _potential(m, x, c, mu, L, acc, th, eta, ex):  # pragma: no cover - compiled
    """The GMM sum's value, gradient, Hessian and third derivative along ``v`` (twice) at every
    lane's ``r`` into ``acc (N_ACC, m)``, in passes over the lanes
    (docs/simulators.md#gmm-ftc-the-potential-in-the-kernel)."""
    _zero(acc, m)
    for k in range(mu.shape[0]):
        m0, m1, m2 = mu[k, 0], mu[k, 1], mu[k, 2]
        L00, L01, L02 = L[k, 0, 0], L[k, 0, 1], L[k, 0, 2]
        L10, L11, L12 = L[k, 1, 0], L[k, 1, 1], L[k, 1, 2]
        L20, L21, L22 = L[k, 2, 0], L[k, 2, 1], L[k, 2, 2]
        ck = c[k]
        for l in range(m):
            d0, d1, d2 = x[0, l] - m0, x[1, l] - m1, x[2, l] - m2
            t0 = L00 * d0 + L01 * d1 + L02 * d2
            t1 = L10 * d0 + L11 * d1 + L12 * d2
            t2 = L20 * d0 + L21 * d1 + L22 * d2
            th[0, l], th[1, l], th[2, l] = t0, t1, t2
            eta[l] = -0.5 * (d0 * t0 + d1 * t1 + d2 * t2)
        _weights(m, ck, eta, ex)
        _add_value_gradient(m, ex, th, acc)
        _add_hessian(m, L[k], ex, th, acc)
        for l in range(m):
            y0, y1, y2 = x[3, l], x[4, l], x[5, l]
            _add_third(acc, l, ex[l], th, y0, y1, y2, L00 * y0 + L01 * y1 + L02 * y2,
                       L10 * y0 + L11 * y1 + L12 * y2, L20 * y0 + L21 * y1 + L22 * y2)


@njit(cache=True, error_model="numpy", inline="always")
def _det3(a00, a01, a02, a10, a11, a12, a20, a21, a22):  # pragma: no cover - compiled
    return (a00 * (a11 * a22 - a12 * a21)
            - a01 * (a10 * a22 - a12 * a20)
            + a02 * (a10 * a21 - a11 * a20))


# rows of the law's work array ``lw (N_LW, m)``: Lambda y2 (then the right-hand side), k_s gamma,
# I + k_s H (row by row)
W_LY, W_KG, W_J = 0, 3, 6
N_LW = 15


@njit(cache=True, error_model="numpy")
def _law(m, x, acc, pa, r_f, P, M, alpha1, beta1, lam1, lam2, zeta1, mode1, zeta2, mode2, k_s,
         det_guard, u, s2, guarded, lw):  # pragma: no cover - compiled
    """GMM-FTC command ``u`` and ``s2`` (each (3, m)) of every lane from the potential's
    derivatives ``acc``; ``guarded[l]`` is 1 where ``I + k_s H`` was singular."""
    P00, P01, P02 = P[0, 0], P[0, 1], P[0, 2]
    P10, P11, P12 = P[1, 0], P[1, 1], P[1, 2]
    P20, P21, P22 = P[2, 0], P[2, 1], P[2, 2]
    M00, M01, M02 = M[0, 0], M[0, 1], M[0, 2]
    M10, M11, M12 = M[1, 0], M[1, 1], M[1, 2]
    M20, M21, M22 = M[2, 0], M[2, 1], M[2, 2]
    ks0, ks1, ks2 = k_s[0], k_s[1], k_s[2]
    for l in range(m):
        y0, y1, y2 = x[3, l], x[4, l], x[5, l]
        e0, e1, e2 = x[0, l] - r_f[0], x[1, l] - r_f[1], x[2, l] - r_f[2]
        Vv = acc[A_V, l]
        gV0, gV1, gV2 = acc[A_G, l], acc[A_G + 1, l], acc[A_G + 2, l]
        h00, h01, h02 = acc[A_H, l], acc[A_H + 1, l], acc[A_H + 2, l]
        h10, h11, h12 = acc[A_H + 3, l], acc[A_H + 4, l], acc[A_H + 5, l]
        h20, h21, h22 = acc[A_H + 6, l], acc[A_H + 7, l], acc[A_H + 8, l]
        T0, T1, T2 = acc[A_T, l], acc[A_T + 1, l], acc[A_T + 2, l]
        Me0 = M00 * e0 + M01 * e1 + M02 * e2
        Me1 = M10 * e0 + M11 * e1 + M12 * e2
        Me2 = M20 * e0 + M21 * e1 + M22 * e2
        Pe0 = P00 * e0 + P01 * e1 + P02 * e2
        Pe1 = P10 * e0 + P11 * e1 + P12 * e2
        Pe2 = P20 * e0 + P21 * e1 + P22 * e2
        My0 = M00 * y0 + M01 * y1 + M02 * y2
        My1 = M10 * y0 + M11 * y1 + M12 * y2
        My2 = M20 * y0 + M21 * y1 + M22 * y2
        hy0 = h00 * y0 + h01 * y1 + h02 * y2
        hy1 = h10 * y0 + h11 * y1 + h12 * y2
        hy2 = h20 * y0 + h21 * y1 + h22 * y2
        qe = e0 * Me0 + e1 * Me1 + e2 * Me2
        gy = gV0 * y0 + gV1 * y1 + gV2 * y2
        yhy = y0 * hy0 + y1 * hy1 + y2 * hy2
        eMy = e0 * My0 + e1 * My1 + e2 * My2
        yMy = y0 * My0 + y1 * My1 + y2 * My2
        hq = 0.5 * qe
        g0 = Pe0 + Vv * Me0 + hq * gV0
        g1 = Pe1 + Vv * Me1 + hq * gV1
        g2 = Pe2 + Vv * Me2 + hq * gV2
        gam0 = 2.0 * gy * My0 + yhy * Me0 + 2.0 * eMy * hy0 + yMy * gV0 + hq * T0
        gam1 = 2.0 * gy * My1 + yhy * Me1 + 2.0 * eMy * hy1 + yMy * gV1 + hq * T1
        gam2 = 2.0 * gy * My2 + yhy * Me2 + 2.0 * eMy * hy2 + yMy * gV2 + hq * T2
        H00 = P00 + Vv * M00 + Me0 * gV0 + gV0 * Me0 + hq * h00
        H01 = P01 + Vv * M01 + Me0 * gV1 + gV0 * Me1 + hq * h01
        H02 = P02 + Vv * M02 + Me0 * gV2 + gV0 * Me2 + hq * h02
        H10 = P10 + Vv * M10 + Me1 * gV0 + gV1 * Me0 + hq * h10
        H11 = P11 + Vv * M11 + Me1 * gV1 + gV1 * Me1 + hq * h11
        H12 = P12 + Vv * M12 + Me1 * gV2 + gV1 * Me2 + hq * h12
        H20 = P20 + Vv * M20 + Me2 * gV0 + gV2 * Me0 + hq * h20
        H21 = P21 + Vv * M21 + Me2 * gV1 + gV2 * Me1 + hq * h21
        H22 = P22 + Vv * M22 + Me2 * gV2 + gV2 * Me2 + hq * h22
        Hv0 = H00 * y0 + H01 * y1 + H02 * y2
        Hv1 = H10 * y0 + H11 * y1 + H12 * y2
        Hv2 = H20 * y0 + H21 * y1 + H22 * y2
        s10 = e0 + ks0 * g0
        s11 = e1 + ks1 * g1
        s12 = e2 + ks2 * g2
        Jv0 = y0 + ks0 * Hv0
        Jv1 = y1 + ks1 * Hv1
        Jv2 = y2 + ks2 * Hv2
        s20 = y0 + alpha1[0] * s10 + beta1[0] * (s10 * s10 * s10) + ks0 * Hv0
        s21 = y1 + alpha1[1] * s11 + beta1[1] * (s11 * s11 * s11) + ks1 * Hv1
        s22 = y2 + alpha1[2] * s12 + beta1[2] * (s12 * s12 * s12) + ks2 * Hv2
        s2[0, l], s2[1, l], s2[2, l] = s20, s21, s22
        lw[W_LY, l] = (alpha1[0] + 3.0 * beta1[0] * s10 * s10) * Jv0
        lw[W_LY + 1, l] = (alpha1[1] + 3.0 * beta1[1] * s11 * s11) * Jv1
        lw[W_LY + 2, l] = (alpha1[2] + 3.0 * beta1[2] * s12 * s12) * Jv2
        lw[W_KG, l] = ks0 * gam0
        lw[W_KG + 1, l] = ks1 * gam1
        lw[W_KG + 2, l] = ks2 * gam2
        lw[W_J, l], lw[W_J + 1, l], lw[W_J + 2, l] = 1.0 + ks0 * H00, ks0 * H01, ks0 * H02
        lw[W_J + 3, l], lw[W_J + 4, l], lw[W_J + 5, l] = ks1 * H10, 1.0 + ks1 * H11, ks1 * H12
        lw[W_J + 6, l], lw[W_J + 7, l], lw[W_J + 8, l] = ks2 * H20, ks2 * H21, 1.0 + ks2 * H22
    # the reaching law's fractional powers: calls, so a pass of their own
    for a in range(3):
        la1, la2 = lam1[a], lam2[a]
        for l in range(m):
            p1, p2 = _sig2(s2[a, l], zeta1, mode1, zeta2, mode2)
            lw[W_LY + a, l] = ((-la1 * p1 - la2 * p2) - lw[W_LY + a, l]) - lw[W_KG + a, l]
    # u = (I + k_s H)^-1 rhs - plant: Cramer's rule, or rhs - plant where the determinant is
    # guarded (selects: both are computed, the division's inf or NaN is never selected)
    for l in range(m):
        J00, J01, J02 = lw[W_J, l], lw[W_J + 1, l], lw[W_J + 2, l]
        J10, J11, J12 = lw[W_J + 3, l], lw[W_J + 4, l], lw[W_J + 5, l]
        J20, J21, J22 = lw[W_J + 6, l], lw[W_J + 7, l], lw[W_J + 8, l]
        rhs0, rhs1, rhs2 = lw[W_LY, l], lw[W_LY + 1, l], lw[W_LY + 2, l]
        det = _det3(J00, J01, J02, J10, J11, J12, J20, J21, J22)
        ok = abs(det) >= det_guard
        guarded[l] = 0.0 if ok else 1.0
        u[0, l] = (_det3(rhs0, J01, J02, rhs1, J11, J12, rhs2, J21, J22) / det if ok
                   else rhs0) - pa[0, l]
        u[1, l] = (_det3(J00, rhs0, J02, J10, rhs1, J12, J20, rhs2, J22) / det if ok
                   else rhs1) - pa[1, l]
        u[2, l] = (_det3(J00, J01, rhs0, J10, J11, rhs1, J20, J21, rhs2) / det if ok
                   else rhs2) - pa[2, l]


@njit(cache=True, error_model="numpy", inline="always")
def _box_distance(x0, x1, x2, lo, hi, p) -> float:  # pragma: no cover - compiled
    g0 = max(lo[p, 0] - x0, x0 - hi[p, 0], 0.0)
    g1 = max(lo[p, 1] - x1, x1 - hi[p, 1], 0.0)
    g2 = max(lo[p, 2] - x2, x2 - hi[p, 2], 0.0)
    return math.sqrt(g0 * g0 + g1 * g1 + g2 * g2)


@njit(cache=True, error_model="numpy", inline="always")
def _depth(x0, x1, x2, lo, hi, p) -> float:  # pragma: no cover - compiled
    d = min(np.inf, x0 - lo[p, 0], hi[p, 0] - x0)
    d = min(d, x1 - lo[p, 1], hi[p, 1] - x1)
    d = min(d, x2 - lo[p, 2], hi[p, 2] - x2)
    return max(d, 0.0)


@njit(cache=True, error_model="numpy")
def _segment_hits(p0, l, x, lo, hi, p) -> bool:  # pragma: no cover - compiled
    # slab test of gmm.geometry.segment_box_hits, segment p0[:, l] -> x[:3, l]
    t_enter = -np.inf
    t_exit = np.inf
    for a in range(3):
        a0 = p0[a, l]
        d = x[a, l] - a0
        if d != 0.0:
            t1 = (lo[p, a] - a0) / d
            t2 = (hi[p, a] - a0) / d
            t_enter = max(t_enter, min(t1, t2))
            t_exit = min(t_exit, max(t1, t2))
        elif not (lo[p, a] <= a0 <= hi[p, a]):
            return False
    return t_enter <= t_exit and t_exit >= 0.0 and t_enter <= 1.0


@njit(cache=True, error_model="numpy", parallel=True)
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
    Blocks of :data:`BLOCK` samples run in parallel threads (:func:`_simulate_block`).
    """
    n = x0.shape[0]
    for b in nb.prange((n + BLOCK - 1) // BLOCK):
        _simulate_block(b * BLOCK, min(n, (b + 1) * BLOCK), x0, W, Wc, C0, ctl_separate,
                        plant_printed, ctl_printed, times, A_st, B_st, r_f, P, M, c, mu, L,
                        alpha1, beta1, lam1, lam2, zeta1, zeta2, k_s, det_guard, scale,
                        noise_w, keys, s_lo, s_hi, c_lo, c_hi, is_solid, reach, dt, n_sub, N,
                        record_every, converge_tol, settle_tol, velocity_tol, s2_tol, k_check,
                        u_max, rec_r, rec_v, rec_u, rec_rl, rec_vl, rec_ul, rec_u32, rec_s2,
                        rec_dv, clearance, hits, sc)


@njit(cache=True, error_model="numpy")
def _simulate_block(i0, i1, x0, W, Wc, C0, ctl_separate, plant_printed, ctl_printed, times,
                    A_st, B_st, r_f, P, M, c, mu, L, alpha1, beta1, lam1, lam2, zeta1, zeta2,
                    k_s, det_guard, scale, noise_w, keys, s_lo, s_hi, c_lo, c_hi, is_solid,
                    reach, dt, n_sub, N, record_every, converge_tol, settle_tol, velocity_tol,
                    s2_tol, k_check, u_max, rec_r, rec_v, rec_u, rec_rl, rec_vl, rec_ul,
                    rec_u32, rec_s2, rec_dv, clearance, hits, sc):  # pragma: no cover
    """Samples ``i0 .. i1-1`` in lockstep, one control period at a time (module docstring)."""
    m = i1 - i0
    nP = s_lo.shape[0]
    h = dt / n_sub
    shared = W.shape[0] == 1
    shared_c = Wc.shape[0] == 1
    mode1 = pow_mode(zeta1)
    mode2 = pow_mode(zeta2)
    diagonal = True
    for k in range(L.shape[0]):
        for a in range(3):
            for b in range(3):
                if a != b and L[k, a, b] != 0.0:
                    diagonal = False
    x = np.empty((6, m))  # r, v
    xs = np.empty((6, m))  # RK4 stage state
    w = np.empty((3, m))
    wc = np.empty((3, m))
    C = np.empty((9, m))
    Ch = np.empty((9, m))
    C1 = np.empty((9, m))
    Cc = np.empty((9, m))
    pa = np.empty((3, m))
    u = np.empty((3, m))
    s2 = np.empty((3, m))
    guarded = np.empty(m)
    acc = np.empty((N_ACC, m))
    th = np.empty((3, m))
    eta = np.empty(m)
    ex = np.empty(m)
    lw = np.empty((N_LW, m))
    kv = np.empty((12, m))  # k1v, k2v, k3v, k4v
    kr = np.empty((9, m))  # k2r, k3r, k4r (k1r = v)
    p0 = np.empty((3, m))
    d_prev = np.empty((nP, m))
    clr = np.empty((nP, m))
    half = np.empty(m)
    flag = np.empty(m)
    mt = np.empty((N_COL, m))  # the scalar results, a row per column of ``sc``
    for l in range(m):
        for q in range(6):
            mt[q, l] = -1.0  # bad_*: last step that violated the threshold
        for q in range(6, 14):
            mt[q, l] = 0.0
        for q in range(14, 17):
            mt[q, l] = np.inf
        for q in range(17, 20):
            mt[q, l] = -np.inf
        for q in range(20, N_COL):
            mt[q, l] = 0.0
    dv, pen, rng_min = mt[C_DV], mt[C_PEN], mt[C_RANGE]
    nrm = np.empty((4, m))  # |r - r_f|, |v|, |u|, |s2| at t_k
    for l in range(m):
        i = i0 + l
        iw = 0 if shared else i
        iwc = 0 if shared_c else i
        for a in range(3):
            x[a, l] = x0[i, a]
            x[3 + a, l] = x0[i, 3 + a]
            w[a, l] = W[iw, a]
            wc[a, l] = Wc[iwc, a]
        for p in range(nP):
            dn = _box_distance(x[0, l], x[1, l], x[2, l], s_lo, s_hi, p)
            clr[p, l] = dn
            d_prev[p, l] = dn
            hits[i, p] = False
            if is_solid[p]:
                pen[l] = max(pen[l], _depth(x[0, l], x[1, l], x[2, l], s_lo, s_hi, p))
        rng_min[l] = math.sqrt(x[0, l] ** 2 + x[1, l] ** 2 + x[2, l] ** 2)
    _attitudes(m, w, shared, times[0], C0, C)
    for k in range(N + 1):
        j0 = 2 * k * n_sub
        if ctl_separate:
            _attitudes(m, wc, shared_c, times[j0], C0, Cc)
            _plant(m, A_st, B_st, j0, Cc, wc, ctl_printed, x, pa)
        else:
            _plant(m, A_st, B_st, j0, C, w, plant_printed, x, pa)
        if diagonal:
            _potential_diagonal(m, x, c, mu, L, acc, th, eta, ex)
        else:
            _potential(m, x, c, mu, L, acc, th, eta, ex)
        _law(m, x, acc, pa, r_f, P, M, alpha1, beta1, lam1, lam2, zeta1, mode1, zeta2, mode2,
             k_s, det_guard, u, s2, guarded, lw)
        _shape_thrust(m, i0, k, u, guarded, scale, noise_w, keys, u_max, mt)
        _metrics(m, k, x, u, s2, r_f, converge_tol, settle_tol, velocity_tol, s2_tol, k_check,
                 nrm, mt)
        if k % record_every == 0:
            ir = k // record_every
            for l in range(m):
                _record(i0 + l, l, ir, x, u, s2, w, C, dv, rec_r, rec_v, rec_u, rec_rl,
                        rec_vl, rec_ul, rec_u32, rec_s2, rec_dv)
        if k == N:
            break
        for l in range(m):
            dv[l] += nrm[2, l] * dt
        for s in range(n_sub):
            j = j0 + 2 * s
            _attitudes(m, w, shared, times[j + 1], C0, Ch)
            _attitudes(m, w, shared, times[j + 2], C0, C1)
            _plant(m, A_st, B_st, j, C, w, plant_printed, x, kv[0:3])
            for a in range(3):
                for l in range(m):
                    kv[a, l] += u[a, l]
                    xs[a, l] = x[a, l] + 0.5 * h * x[3 + a, l]
                    xs[3 + a, l] = x[3 + a, l] + 0.5 * h * kv[a, l]
            _plant(m, A_st, B_st, j + 1, Ch, w, plant_printed, xs, kv[3:6])
            for a in range(3):
                for l in range(m):
                    kr[a, l] = xs[3 + a, l]
                    kv[3 + a, l] += u[a, l]
                    xs[a, l] = x[a, l] + 0.5 * h * kr[a, l]
                    xs[3 + a, l] = x[3 + a, l] + 0.5 * h * kv[3 + a, l]
            _plant(m, A_st, B_st, j + 1, Ch, w, plant_printed, xs, kv[6:9])
            for a in range(3):
                for l in range(m):
                    kr[3 + a, l] = xs[3 + a, l]
                    kv[6 + a, l] += u[a, l]
                    xs[a, l] = x[a, l] + h * kr[3 + a, l]
                    xs[3 + a, l] = x[3 + a, l] + h * kv[6 + a, l]
            _plant(m, A_st, B_st, j + 2, C1, w, plant_printed, xs, kv[9:12])
            for a in range(3):
                for l in range(m):
                    p0[a, l] = x[a, l]
                    kv[9 + a, l] += u[a, l]
                    x[a, l] = x[a, l] + (h / 6.0) * (
                        x[3 + a, l] + 2 * kr[a, l] + 2 * kr[3 + a, l] + xs[3 + a, l])
                    x[3 + a, l] = x[3 + a, l] + (h / 6.0) * (
                        kv[a, l] + 2 * kv[3 + a, l] + 2 * kv[6 + a, l] + kv[9 + a, l])
            _geometry(m, x, p0, s_lo, s_hi, reach, d_prev, clr, half, flag, rng_min)
            for l in range(m):
                if flag[l] != 0.0:
                    _geometry_events(i0 + l, l, x, p0, s_lo, s_hi, c_lo, c_hi, is_solid,
                                     d_prev, flag, pen, hits)
            C, C1 = C1, C
        for l in range(m):
            if mt[C_FAILED, l] == 0.0 and not (
                    math.isfinite(x[0, l]) and math.isfinite(x[1, l]) and math.isfinite(x[2, l])
                    and math.isfinite(x[3, l]) and math.isfinite(x[4, l])
                    and math.isfinite(x[5, l])):
                mt[C_FAILED, l] = 1.0
                for q in range(6):
                    x[q, l] = 0.0  # frozen; flagged, its outputs are not to be used
    for l in range(m):
        for q in range(N_COL):
            sc[i0 + l, q] = mt[q, l]
        for p in range(nP):
            clearance[i0 + l, p] = clr[p, l]


@njit(cache=True, error_model="numpy")
def _shape_thrust(m, i0, k, u, guarded, scale, noise_w, keys, u_max, mt
                  ):  # pragma: no cover - compiled
    """Thrust limit, thrust factors and per-period noise on every lane's command."""
    for l in range(m):
        i = i0 + l
        mt[C_GUARDED, l] += guarded[l]
        u0, u1, u2 = u[0, l], u[1, l], u[2, l]
        if not (math.isfinite(u0) and math.isfinite(u1) and math.isfinite(u2)):
            u0 = u1 = u2 = 0.0
            mt[C_NONFINITE, l] += 1.0
        if math.isfinite(u_max):
            un = math.sqrt(u0 ** 2 + u1 ** 2 + u2 ** 2)
            f = min(1.0, u_max / max(un, 1e-300))
            u0 *= f
            u1 *= f
            u2 *= f
        u0 *= scale[i, 0]
        u1 *= scale[i, 1]
        u2 *= scale[i, 2]
        if noise_w > 0.0:
            u0 *= 1.0 + noise_w * (2.0 * _uniform(keys[i], 3 * k) - 1.0)
            u1 *= 1.0 + noise_w * (2.0 * _uniform(keys[i], 3 * k + 1) - 1.0)
            u2 *= 1.0 + noise_w * (2.0 * _uniform(keys[i], 3 * k + 2) - 1.0)
        u[0, l], u[1, l], u[2, l] = u0, u1, u2


@njit(cache=True, error_model="numpy")
def _metrics(m, k, x, u, s2, r_f, converge_tol, settle_tol, velocity_tol, s2_tol, k_check, nrm,
             mt):  # pragma: no cover - compiled
    """The metrics at ``t_k`` of every lane: norms, then the threshold and extremum updates as
    selects (branch-free passes of at most a few rows each, which the compiler vectorises).
    ``nrm`` gets the norms; ``s2[0]`` becomes ``|s2|`` (the record needs only the norm)."""
    kf = float(k)
    for l in range(m):
        nrm[0, l] = math.sqrt((x[0, l] - r_f[0]) ** 2 + (x[1, l] - r_f[1]) ** 2
                              + (x[2, l] - r_f[2]) ** 2)
        nrm[1, l] = math.sqrt(x[3, l] ** 2 + x[4, l] ** 2 + x[5, l] ** 2)
    for l in range(m):
        nrm[2, l] = math.sqrt(u[0, l] ** 2 + u[1, l] ** 2 + u[2, l] ** 2)
        s2n = math.sqrt(s2[0, l] ** 2 + s2[1, l] ** 2 + s2[2, l] ** 2)
        nrm[3, l] = s2n
        s2[0, l] = s2n
    for l in range(m):
        e_norm, speed = nrm[0, l], nrm[1, l]
        mt[0, l] = mt[0, l] if e_norm < converge_tol else kf
        mt[1, l] = mt[1, l] if e_norm < settle_tol else kf
        mt[2, l] = mt[2, l] if speed < velocity_tol else kf
    for l in range(m):
        speed, un, s2n = nrm[1, l], nrm[2, l], nrm[3, l]
        mt[3, l] = mt[3, l] if s2n < s2_tol else kf
        mt[4, l] = mt[4, l] if speed < 0.15 else kf
        mt[5, l] = mt[5, l] if un < 0.06 else kf
    for l in range(m):
        e_norm, speed, un = nrm[0, l], nrm[1, l], nrm[2, l]
        mt[8, l] = max(mt[8, l], speed)
        mt[12, l] = max(mt[12, l], un)
        mt[13, l] = max(mt[13, l], un) if e_norm < converge_tol else 0.0
    for a in range(3):
        for l in range(m):
            mt[9 + a, l] = max(mt[9 + a, l], abs(x[3 + a, l]))
    if k >= k_check:
        for l in range(m):
            mt[6, l] = max(mt[6, l], nrm[0, l])
            mt[7, l] = max(mt[7, l], nrm[1, l])
        for a in range(3):
            for l in range(m):
                mt[14 + a, l] = min(mt[14 + a, l], u[a, l])
                mt[17 + a, l] = max(mt[17 + a, l], u[a, l])


@njit(cache=True, error_model="numpy", inline="always")
def _record(i, l, ir, x, u, s2, w, C, dv, rec_r, rec_v, rec_u, rec_rl, rec_vl, rec_ul, rec_u32,
            rec_s2, rec_dv):  # pragma: no cover - compiled
    """Lane ``l``'s state, thrust and their LVLH forms on record row ``ir``."""
    r0, r1, r2 = x[0, l], x[1, l], x[2, l]
    v0, v1, v2 = x[3, l], x[4, l], x[5, l]
    u0, u1, u2 = u[0, l], u[1, l], u[2, l]
    w0, w1, w2 = w[0, l], w[1, l], w[2, l]
    wr0 = w1 * r2 - w2 * r1
    wr1 = w2 * r0 - w0 * r2
    wr2 = w0 * r1 - w1 * r0
    # eq (32): u + 2 w x v + w x (w x r)
    e0 = (u0 + 2.0 * (w1 * v2 - w2 * v1)) + (w1 * wr2 - w2 * wr1)
    e1 = (u1 + 2.0 * (w2 * v0 - w0 * v2)) + (w2 * wr0 - w0 * wr2)
    e2 = (u2 + 2.0 * (w0 * v1 - w1 * v0)) + (w0 * wr1 - w1 * wr0)
    q0, q1, q2 = v0 + wr0, v1 + wr1, v2 + wr2
    put_lane(rec_r, i, ir, 0, x, 0, 3, l)
    put_lane(rec_v, i, ir, 0, x, 3, 3, l)
    put_lane(rec_u, i, ir, 0, u, 0, 3, l)
    for a in range(3):
        ca0, ca1, ca2 = C[3 * a, l], C[3 * a + 1, l], C[3 * a + 2, l]
        rec_rl[i, ir, a] = ca0 * r0 + ca1 * r1 + ca2 * r2
        rec_vl[i, ir, a] = ca0 * q0 + ca1 * q1 + ca2 * q2
        rec_ul[i, ir, a] = ca0 * u0 + ca1 * u1 + ca2 * u2
        rec_u32[i, ir, a] = ca0 * e0 + ca1 * e1 + ca2 * e2
    rec_s2[i, ir] = s2[0, l]
    rec_dv[i, ir] = dv[l]


@njit(cache=True, error_model="numpy")
def _geometry(m, x, p0, s_lo, s_hi, reach, d_prev, clr, half, flag, rng_min
              ):  # pragma: no cover - compiled
    """Clearance and range of every lane after a sub-step, branch-free; ``flag[l]`` > 0 when
    lane ``l`` is inside a part or its last segment may reach a collision box (then
    :func:`_geometry_events` looks closer)."""
    for l in range(m):
        r0, r1, r2 = x[0, l], x[1, l], x[2, l]
        half[l] = 0.5 * math.sqrt((r0 - p0[0, l]) ** 2 + (r1 - p0[1, l]) ** 2
                                  + (r2 - p0[2, l]) ** 2)
        rng_min[l] = min(rng_min[l], math.sqrt(r0 ** 2 + r1 ** 2 + r2 ** 2))
        flag[l] = 0.0
    for p in range(s_lo.shape[0]):
        for l in range(m):
            dn = _box_distance(x[0, l], x[1, l], x[2, l], s_lo, s_hi, p)
            clr[p, l] = min(clr[p, l], dn)
            # the segment can reach the box only if an end is within half its length plus the
            # box's inflation of the skeleton
            near = min(d_prev[p, l], dn) <= half[l] + reach
            flag[l] = max(flag[l], 2.0 if near else (1.0 if dn == 0.0 else 0.0))
            d_prev[p, l] = dn


@njit(cache=True, error_model="numpy")
def _geometry_events(i, l, x, p0, s_lo, s_hi, c_lo, c_hi, is_solid, d_prev, flag, pen, hits
                     ):  # pragma: no cover - compiled
    """Penetration of the solid parts and the swept collision test of a flagged lane."""
    r0, r1, r2 = x[0, l], x[1, l], x[2, l]
    for p in range(s_lo.shape[0]):
        if is_solid[p] and d_prev[p, l] == 0.0:
            pen[l] = max(pen[l], _depth(r0, r1, r2, s_lo, s_hi, p))
    if flag[l] >= 2.0:
        for p in range(s_lo.shape[0]):
            if _segment_hits(p0, l, x, c_lo, c_hi, p):
                hits[i, p] = True


def run_closed_loop_numba(plant, controller_plant, law, geometry, x0, settings,
                          thrust_scale=None, noise_keys=None):
    """Simulate a batch of servicers under GMM-FTC; the result's ``scalars`` are
    :func:`.loop.scalar_results`.

    ``plant``: the true body-frame dynamics, its spin rate common (``m = 1``) or per sample;
    ``controller_plant``: the dynamics the law cancels (None: the true plant); ``law``: one GMM
    for the whole batch; ``x0 (n, 6)``: the initial body-frame ``[r (m), r' (m/s)]``;
    ``thrust_scale (n, 3)``: per-axis thrust factors (1: exact); ``noise_keys (n,)``: the keys
    of the per-period thrust noise streams (:mod:`.noise`), needed when
    ``settings.thrust_noise > 0``.
    """
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
