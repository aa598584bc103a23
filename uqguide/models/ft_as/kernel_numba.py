"""Compiled (numba) integration of a batch of FT-AS closed loops with per-step metrics.

The equations of the NumPy oracle ``tests/oracles/ft_as_equations.py`` written per sample on
scalars; ``tests/test_ft_as_model.py`` checks the kernel against the oracle to rounding level.
Blocks of samples advance in lockstep, one thread per block: what depends on time only is
evaluated once per block (:func:`_clock`), the controller per sample on local floats, the RK4
stages on the whole block as structure of arrays (:func:`_rhs_block`). Every sample runs the
same code whatever block it lands in, so its numbers are the same bits whatever the batch split
and the thread count. The layout, and why: docs/performance.md#the-ft-as-kernel; the metrics,
accumulated at every step: docs/simulators.md#ft-as-what-the-kernel-accumulates.
"""

from __future__ import annotations

import math
from dataclasses import fields

import numpy as np
from numba import prange

from ..kernels import njit
from ..record_rows import put_vector

from .setup import (
    CASE1, CASE2, K_A, K_AT, K_B, K_BOUNDARY, K_C, K_EPS, K_ETA1, K_ETA2, K_GAMMA, K_LAM1, K_LAM2,
    K_LAM3, K_M0, K_MU, K_NT, K_NU1, K_NU2, K_OBS_P, K_OBS_PER_CHANNEL, K_R2, K_RHO2, K_U0,
    Batch, Gains, Plant, pack_constants,
)

MAX_BLOCK = 16
"""Most samples per parallel block (docs/performance.md#the-ft-as-kernel: why 16)."""
MIN_SPLIT = 8
"""Fewest samples per block when a batch is split over threads (the same page: why 8)."""


def block_size(n: int, threads: int) -> int:
    """Samples per block for ``n`` samples on ``threads`` threads: one block per thread when
    each gets at least :data:`MIN_SPLIT` samples, at most :data:`MAX_BLOCK` per block. Any value
    gives the same numbers (only the speed changes)."""
    n = max(n, 1)
    blocks = max(1, min(threads, n // MIN_SPLIT))
    return max(1, min(MAX_BLOCK, -(-n // blocks)))


@njit(cache=True, error_model="numpy")
def _sig(x: float, p: float) -> float:
    if x > 0.0:
        return x**p
    if x < 0.0:
        return -((-x) ** p)
    return 0.0


@njit(cache=True, error_model="numpy")
def _sign(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@njit(cache=True, error_model="numpy")
def _clock(t, c, P, Q):
    """What depends on time alone, shared by every sample at ``t``.

    Returns ``(sin 0.1t, sin 0.2t, sin 0.3t, cos 0.2t, r_t (3), |r_t|^2, -mu / |r_t|^3)``: the
    mass, inertia and disturbance sinusoids (scenario [A2]-[A6]) and the reference orbit.
    """
    u = c[K_U0] + c[K_NT] * t
    cu, su = math.cos(u), math.sin(u)
    at = c[K_AT]
    rt0 = at * (cu * P[0] + su * Q[0])
    rt1 = at * (cu * P[1] + su * Q[1])
    rt2 = at * (cu * P[2] + su * Q[2])
    rtn2 = rt0 * rt0 + rt1 * rt1 + rt2 * rt2
    f = -c[K_MU] / rtn2**1.5
    return (math.sin(0.1 * t), math.sin(0.2 * t), math.sin(0.3 * t), math.cos(0.2 * t),
            rt0, rt1, rt2, rtn2, f)  # fmt: skip


@njit(cache=True, error_model="numpy", inline="always")
def _tracking(s0, s1, s2, om0, om1, om2, re0, re1, re2, nt, J0, J0i, ck):
    """:func:`_terms` on scalars: MRP ``s``, rate ``om`` [rad/s], position error ``re`` [m]."""
    q = s0 * s0 + s1 * s1 + s2 * s2
    a = 0.25 * (1.0 - q)
    G00 = a + 0.5 * s0 * s0
    G01 = 0.5 * (-s2 + s0 * s1)
    G02 = 0.5 * (s1 + s0 * s2)
    G10 = 0.5 * (s2 + s1 * s0)
    G11 = a + 0.5 * s1 * s1
    G12 = 0.5 * (-s0 + s1 * s2)
    G20 = 0.5 * (-s1 + s2 * s0)
    G21 = 0.5 * (s0 + s2 * s1)
    G22 = a + 0.5 * s2 * s2
    d = 1.0 / (1.0 + q) ** 2
    k = 16.0 * d  # 16 / (1 + q)^2 to the bit
    w = 4.0 * (1.0 - q)
    # third column of C(sigma): omega_t = [0, 0, n_t]
    C02 = d * (8.0 * (s0 * s2) - w * s1)
    C12 = d * (8.0 * (s1 * s2) + w * s0)
    C22 = 1.0 + d * (8.0 * (s2 * s2 - q))
    wt0, wt1, wt2 = C02 * nt, C12 * nt, C22 * nt
    w0 = om0 - wt0  # omega_e = omega - C omega_t
    w1 = om1 - wt1
    w2 = om2 - wt2
    sd0 = G00 * w0 + G01 * w1 + G02 * w2
    sd1 = G10 * w0 + G11 * w1 + G12 * w2
    sd2 = G20 * w0 + G21 * w1 + G22 * w2
    # Gdot omega_e = 1/2 [-(s.sd) we + sd x we + sd (s.we) + s (sd.we)]
    ssd = s0 * sd0 + s1 * sd1 + s2 * sd2
    swe = s0 * w0 + s1 * w1 + s2 * w2
    sdwe = sd0 * w0 + sd1 * w1 + sd2 * w2
    gd0 = 0.5 * (-ssd * w0 + (sd1 * w2 - sd2 * w1) + sd0 * swe + s0 * sdwe)
    gd1 = 0.5 * (-ssd * w1 + (sd2 * w0 - sd0 * w2) + sd1 * swe + s1 * sdwe)
    gd2 = 0.5 * (-ssd * w2 + (sd0 * w1 - sd1 * w0) + sd2 * swe + s2 * sdwe)
    j0 = J0[0, 0] * om0 + J0[0, 1] * om1 + J0[0, 2] * om2
    j1 = J0[1, 0] * om0 + J0[1, 1] * om1 + J0[1, 2] * om2
    j2 = J0[2, 0] * om0 + J0[2, 1] * om1 + J0[2, 2] * om2
    g0 = -(om1 * j2 - om2 * j1)  # -omega x J0 omega
    g1 = -(om2 * j0 - om0 * j2)
    g2 = -(om0 * j1 - om1 * j0)
    a0 = J0i[0, 0] * g0 + J0i[0, 1] * g1 + J0i[0, 2] * g2
    a1 = J0i[1, 0] * g0 + J0i[1, 1] * g1 + J0i[1, 2] * g2
    a2 = J0i[2, 0] * g0 + J0i[2, 1] * g1 + J0i[2, 2] * g2
    a0 += w1 * wt2 - w2 * wt1  # + omega_e x (C omega_t)
    a1 += w2 * wt0 - w0 * wt2
    a2 += w0 * wt1 - w1 * wt0
    h3 = gd0 + G00 * a0 + G01 * a1 + G02 * a2
    h4 = gd1 + G10 * a0 + G11 * a1 + G12 * a2
    h5 = gd2 + G20 * a0 + G21 * a1 + G22 * a2
    # differential gravity without cancellation: (1 + q)^-1.5 - 1 = -q (2 + q + r) / (r (1 + r)
    # (1 + q)), r = sqrt(1 + q), exact algebra (the oracle's differential_gravity)
    rt0, rt1, rt2, rtn2, f = ck[4], ck[5], ck[6], ck[7], ck[8]
    qg = (2.0 * (re0 * rt0 + re1 * rt1 + re2 * rt2) + re0 * re0 + re1 * re1 + re2 * re2) / rtn2
    r = math.sqrt(1.0 + qg)
    km1 = -qg * (2.0 + qg + r) / (r * (1.0 + r) * (1.0 + qg))
    h0 = f * ((1.0 + km1) * re0 + km1 * rt0)
    h1 = f * ((1.0 + km1) * re1 + km1 * rt1)
    h2 = f * ((1.0 + km1) * re2 + km1 * rt2)
    return (h0, h1, h2, h3, h4, h5, sd0, sd1, sd2, w0, w1, w2,
            G00, G01, G02, G10, G11, G12, G20, G21, G22, k)  # fmt: skip


@njit(cache=True, error_model="numpy")
def _terms(ck, x, nt, J0, J0i):
    """Tracking model at state ``x`` (section 5) with the clock ``ck`` of its time.

    Returns ``(h (6), sigma_dot (3), omega_e (3), G (9, row-major), k)`` with
    ``G^-1 = k G^T`` (section 1.1).
    """
    return _tracking(x[6], x[7], x[8], x[9], x[10], x[11], x[0], x[1], x[2], nt, J0, J0i, ck)


@njit(cache=True, error_model="numpy", inline="always")
def _apply_M(tr, J0i, m0, u0, u1, u2, u3, u4, u5):
    """``M u = [u_f / m0 ; G J0^-1 u_tau]`` (section 5), G from the terms ``tr``."""
    b0 = J0i[0, 0] * u3 + J0i[0, 1] * u4 + J0i[0, 2] * u5
    b1 = J0i[1, 0] * u3 + J0i[1, 1] * u4 + J0i[1, 2] * u5
    b2 = J0i[2, 0] * u3 + J0i[2, 1] * u4 + J0i[2, 2] * u5
    return (u0 / m0, u1 / m0, u2 / m0,
            tr[12] * b0 + tr[13] * b1 + tr[14] * b2,
            tr[15] * b0 + tr[16] * b1 + tr[17] * b2,
            tr[18] * b0 + tr[19] * b1 + tr[20] * b2)  # fmt: skip


@njit(cache=True, error_model="numpy", inline="always")
def _true_body_acc(ck, om0, om1, om2, tau0, tau1, tau2, J0, inertia_err, a_tau):
    """``J(t)^-1 (-omega x J omega + tau + d_tau)`` (eq 2, [A6]), body [rad/s^2]."""
    s1t, s2t, s3t, c2t = ck[0], ck[1], ck[2], ck[3]
    kk = 1.0 + inertia_err
    J00 = kk * J0[0, 0] + 0.1 + 0.01 * s1t
    J11 = kk * J0[1, 1] + 0.1 + 0.01 * s2t
    J22 = kk * J0[2, 2] + 0.1 + 0.01 * s3t
    J01, J02, J12 = kk * J0[0, 1], kk * J0[0, 2], kk * J0[1, 2]
    j0 = J00 * om0 + J01 * om1 + J02 * om2
    j1 = J01 * om0 + J11 * om1 + J12 * om2
    j2 = J02 * om0 + J12 * om1 + J22 * om2
    b0 = -(om1 * j2 - om2 * j1) + tau0 + 2.0 * a_tau * s1t
    b1 = -(om2 * j0 - om0 * j2) + tau1 + 2.0 * a_tau * c2t
    b2 = -(om0 * j1 - om1 * j0) + tau2 + 2.0 * a_tau * s3t
    # symmetric 3x3 solve by the adjugate
    c00 = J11 * J22 - J12 * J12
    c01 = J02 * J12 - J01 * J22
    c02 = J01 * J12 - J02 * J11
    c11 = J00 * J22 - J02 * J02
    c12 = J01 * J02 - J00 * J12
    c22 = J00 * J11 - J01 * J01
    inv_det = 1.0 / (J00 * c00 + J01 * c01 + J02 * c02)
    return ((c00 * b0 + c01 * b1 + c02 * b2) * inv_det,
            (c01 * b0 + c11 * b1 + c12 * b2) * inv_det,
            (c02 * b0 + c12 * b1 + c22 * b2) * inv_det)  # fmt: skip


@njit(cache=True, error_model="numpy")
def _rhs_block(ck, XT, KT, UT, m_off, inertia_err, a_f, a_tau, c, J0, J0i, W, nw):
    """``d/dt`` of the states of ``nw`` lanes of a block (sections 3.2, 6) with held inputs,
    rows 0-23: plant and FT-DO; rows 24-35 (Case 2's auxiliary system) are left to
    :func:`_aux_block`. The tracking terms are :func:`_tracking`'s, as in :func:`_terms`.

    ``XT``, ``KT`` (36, nw): states and derivatives, a row per component; ``UT`` (12, nw): the
    applied and the observed inputs; ``m_off`` ... ``a_tau`` (nw,): the lanes' dispersions;
    ``W`` (16, nw): scratch. The observer's gain (sqrt, log, exp) is a scalar pass between the
    loops over the lanes (docs/performance.md#the-ft-as-kernel).
    """
    nt, m0 = c[K_NT], c[K_M0]
    lam1, lam2, lam3, p = c[K_LAM1], c[K_LAM2], c[K_LAM3], c[K_OBS_P]
    per_channel = c[K_OBS_PER_CHANNEL] > 0.0
    s1t, s3t, c2t = ck[0], ck[2], ck[3]
    x0r, x1r, x2r, x3r, x4r, x5r = XT[0], XT[1], XT[2], XT[3], XT[4], XT[5]
    x6r, x7r, x8r, x9r, x10r, x11r = XT[6], XT[7], XT[8], XT[9], XT[10], XT[11]
    x12r, x13r, x14r, x15r, x16r, x17r = XT[12], XT[13], XT[14], XT[15], XT[16], XT[17]
    k0r, k1r, k2r, k3r, k4r, k5r = KT[0], KT[1], KT[2], KT[3], KT[4], KT[5]
    k6r, k7r, k8r, k9r, k10r, k11r = KT[6], KT[7], KT[8], KT[9], KT[10], KT[11]
    u0r, u1r, u2r, u3r, u4r, u5r = UT[0], UT[1], UT[2], UT[3], UT[4], UT[5]
    o0r, o1r, o2r, o3r, o4r, o5r = UT[6], UT[7], UT[8], UT[9], UT[10], UT[11]
    p0r, p1r, p2r, p3r, p4r, p5r = W[0], W[1], W[2], W[3], W[4], W[5]  # eps1
    v0r, v1r, v2r, v3r, v4r, v5r = W[6], W[7], W[8], W[9], W[10], W[11]  # M u_obs + h
    ntr, nrr = W[12], W[13]
    for b in range(nw):
        om0, om1, om2 = x9r[b], x10r[b], x11r[b]
        tr = _tracking(x6r[b], x7r[b], x8r[b], om0, om1, om2, x0r[b], x1r[b], x2r[b], nt, J0,
                       J0i, ck)
        h0, h1, h2, h3, h4, h5 = tr[0], tr[1], tr[2], tr[3], tr[4], tr[5]
        sd0, sd1, sd2 = tr[6], tr[7], tr[8]
        # plant
        inv_m = 1.0 / (m0 + 1.0 + 0.1 * s1t + m_off[b])
        v_0, v_1, v_2 = x3r[b], x4r[b], x5r[b]
        k0r[b], k1r[b], k2r[b] = v_0, v_1, v_2
        af = a_f[b]
        k3r[b] = h0 + (u0r[b] + af * s1t) * inv_m
        k4r[b] = h1 + (u1r[b] + af * c2t) * inv_m
        k5r[b] = h2 + (u2r[b] + af * s3t) * inv_m
        k6r[b], k7r[b], k8r[b] = sd0, sd1, sd2
        k9r[b], k10r[b], k11r[b] = _true_body_acc(ck, om0, om1, om2, u3r[b], u4r[b], u5r[b],
                                                  J0, inertia_err[b], a_tau[b])
        # observer: M u_obs + h, eps1 and its norms
        m_obs = _apply_M(tr, J0i, m0, o0r[b], o1r[b], o2r[b], o3r[b], o4r[b], o5r[b])
        v0r[b], v1r[b], v2r[b] = m_obs[0] + h0, m_obs[1] + h1, m_obs[2] + h2
        v3r[b], v4r[b], v5r[b] = m_obs[3] + h3, m_obs[4] + h4, m_obs[5] + h5
        e0 = x12r[b] - v_0
        e1 = x13r[b] - v_1
        e2 = x14r[b] - v_2
        e3 = x15r[b] - sd0
        e4 = x16r[b] - sd1
        e5 = x17r[b] - sd2
        p0r[b], p1r[b], p2r[b], p3r[b], p4r[b], p5r[b] = e0, e1, e2, e3, e4, e5
        if per_channel:
            ntr[b] = math.sqrt(e0**2 + e1**2 + e2**2)
            nrr[b] = math.sqrt(e3**2 + e4**2 + e5**2)
        else:
            nn = math.sqrt(e0**2 + e1**2 + e2**2 + e3**2 + e4**2 + e5**2)
            ntr[b] = nn
            nrr[b] = nn
    gtr, grr = W[14], W[15]
    for b in range(nw):  # the observer's gains: libm, scalar
        n_t, n_r = ntr[b], nrr[b]
        g_t = lam1 * math.sqrt(n_t) + lam2 * math.exp(p * math.log(n_t)) if n_t > 0.0 else 0.0
        if n_r == n_t:
            g_r = g_t
        else:
            g_r = lam1 * math.sqrt(n_r) + lam2 * math.exp(p * math.log(n_r)) if n_r > 0.0 else 0.0
        gtr[b], grr[b] = g_t, g_r
    x18r, x19r, x20r, x21r, x22r, x23r = XT[18], XT[19], XT[20], XT[21], XT[22], XT[23]
    k12r, k13r, k14r, k15r, k16r, k17r = KT[12], KT[13], KT[14], KT[15], KT[16], KT[17]
    k18r, k19r, k20r, k21r, k22r, k23r = KT[18], KT[19], KT[20], KT[21], KT[22], KT[23]
    for b in range(nw):
        n_t, n_r = ntr[b], nrr[b]
        i_t = 1.0 / n_t if n_t > 0.0 else 0.0
        i_r = 1.0 / n_r if n_r > 0.0 else 0.0
        un0, un1, un2 = p0r[b] * i_t, p1r[b] * i_t, p2r[b] * i_t
        un3, un4, un5 = p3r[b] * i_r, p4r[b] * i_r, p5r[b] * i_r
        g_t, g_r = gtr[b], grr[b]
        k12r[b] = -g_t * un0 + x18r[b] + v0r[b]
        k13r[b] = -g_t * un1 + x19r[b] + v1r[b]
        k14r[b] = -g_t * un2 + x20r[b] + v2r[b]
        k15r[b] = -g_r * un3 + x21r[b] + v3r[b]
        k16r[b] = -g_r * un4 + x22r[b] + v4r[b]
        k17r[b] = -g_r * un5 + x23r[b] + v5r[b]
        k18r[b] = -lam3 * un0
        k19r[b] = -lam3 * un1
        k20r[b] = -lam3 * un2
        k21r[b] = -lam3 * un3
        k22r[b] = -lam3 * un4
        k23r[b] = -lam3 * un5


@njit(cache=True, error_model="numpy")
def _aux_block(ck, XT, KT, DU, omega_chi, c, J0, J0i, case2, x, nw):
    """The Case 2 auxiliary system (section 8.3) of the lanes where ``case2``: rows 24-35 of
    ``KT`` from ``XT`` and the saturation excess ``DU`` (6, >= nw); ``x`` (36) scratch."""
    nt, m0 = c[K_NT], c[K_M0]
    for b in range(nw):
        if not case2[b]:
            continue
        for q in range(36):
            x[q] = XT[q, b]
        tr = _terms(ck, x, nt, J0, J0i)
        w = _apply_M(tr, J0i, m0, DU[0, b], DU[1, b], DU[2, b], DU[3, b], DU[4, b], DU[5, b])
        oc = omega_chi[b]
        k1, k2 = oc * oc, 2.0 * oc
        for i in range(6):
            KT[24 + i, b] = x[30 + i]
            KT[30 + i, b] = -k1 * x[24 + i] - k2 * x[30 + i] + w[i]


@njit(cache=True, error_model="numpy")
def _stage(ck, XT, KT, UT, DU, mo, ie, af, at, oc, c, J0, J0i, W, case2_lane, any_case2, x, nw):
    """One RK4 stage of a block: ``KT = f(XT)`` with the held inputs."""
    _rhs_block(ck, XT, KT, UT, mo, ie, af, at, c, J0, J0i, W, nw)
    if any_case2:
        _aux_block(ck, XT, KT, DU, oc, c, J0, J0i, case2_lane, x, nw)


@njit(cache=True, error_model="numpy")
def _sliding(z, c, w):
    """``s_k = e1 + sig^a(kappa e2)`` (eq 26-27) of the six channels of ``z = (e1, e2)`` (12).

    Writes ``s`` into ``w[0]`` and keeps for the law ``1/kappa`` (``w[1]``), ``|e1|^b``
    (``w[2]``), ``f = |e2|^(a-1)`` (``w[3]``) and ``kappa^-a`` (``w[4]``); ``w`` is (8, 6)
    scratch. Each transcendental is a pass of its own over the channels, so that the core
    overlaps their calls (docs/performance.md#the-ft-as-kernel).
    """
    a, b = c[K_A], c[K_B]
    nu1, eta1 = c[K_NU1], c[K_ETA1]
    for k in range(6):
        ae1, ae2 = abs(z[k]), abs(z[6 + k])
        w[5, k] = math.log(ae1) if ae1 > 0.0 else -math.inf
        w[6, k] = math.log(ae2) if ae2 > 0.0 else -math.inf
    for k in range(6):
        w[2, k] = math.exp(b * w[5, k])  # |e1|^b; 0 at e1 = 0
        w[3, k] = math.exp((a - 1.0) * w[6, k])  # |e2|^(a-1); 0 at e2 = 0
    for k in range(6):
        base = nu1 * w[2, k] + eta1  # 1 / kappa
        w[1, k] = base
        w[7, k] = math.log(base)
    for k in range(6):
        k_a = math.exp(a * w[7, k])  # kappa^-a
        w[4, k] = k_a
        e1, e2 = z[k], z[6 + k]
        # sig^a(kappa e2) = sign(e2) |e2| |e2|^(a-1) kappa^a
        w[0, k] = e1 + math.copysign(abs(e2) * w[3, k] / k_a, e2) if e2 != 0.0 else e1


@njit(cache=True, error_model="numpy")
def _switch(s, bl):
    return math.tanh(s / bl) if bl > 0.0 else _sign(s)


@njit(cache=True, error_model="numpy")
def _law(z, hd, tr, J0, m0, switch_input, c, out, w):
    """FT-NTSM command (eq 29 / 42) from ``z = (z1 (6), z2 (6))`` and ``hd`` = (hbar, d_hat)
    (12): writes ``u`` into ``out[0:6]`` and ``s`` into ``out[6:12]``; ``w`` is (8, 6) scratch.

    The fractional powers share their logarithms (docs/performance.md#the-ft-as-kernel):
    ``sig^(b-1)(e1) = sign(e1) |e1|^b / |e1|``, ``sig^(2-a)(e2) = sign(e2) |e2| / f``, and
    ``|s|^r2``, ``|s|^rho2`` from one ``log |s|``.
    """
    b, cc, eps = c[K_B], c[K_C], c[K_EPS]
    nu1, nu2, eta2, r2, rho2 = c[K_NU1], c[K_NU2], c[K_ETA2], c[K_R2], c[K_RHO2]
    gamma, bl = c[K_GAMMA], c[K_BOUNDARY]
    _sliding(z, c, w)
    for k in range(6):
        sk = w[0, k]
        w[5, k] = math.log(abs(sk)) if sk != 0.0 else -math.inf
    for k in range(6):
        sk = w[0, k]
        ls = w[5, k]
        # sig^r2(s) and sig^rho2(s) in the reaching law; 0 at s = 0
        w[6, k] = math.copysign(nu2 * math.exp(r2 * ls) + eta2 * math.exp(rho2 * ls), sk)
    for k in range(6):
        e1k, e2k = z[k], z[6 + k]
        f, k_a = w[3, k], w[4, k]
        if e2k == 0.0:
            g = 1.0  # [A9]
            e2pow = 0.0
        else:
            phi = math.sin(math.pi * f / (2.0 * eps)) if f < eps else 1.0
            g = phi / f
            e2pow = math.copysign(abs(e2k) / f, e2k)  # sig^(2-a)(e2)
        e1pow = math.copysign(w[2, k] / abs(e1k), e1k) if e1k != 0.0 else 0.0  # sig^(b-1)
        kappa = 1.0 / w[1, k]
        v = (nu1 * b * kappa * e1pow * e2k * e2k
             - cc * k_a * e2pow
             - cc * k_a * g * w[6, k]
             - hd[k]
             - hd[6 + k])  # fmt: skip
        if not switch_input:
            v -= gamma * _switch(w[0, k], bl)
        w[7, k] = v
    v0, v1, v2 = w[7, 0], w[7, 1], w[7, 2]
    v3, v4, v5 = w[7, 3], w[7, 4], w[7, 5]
    out[0], out[1], out[2] = m0 * v0, m0 * v1, m0 * v2
    k = tr[21]  # G^-1 = k G^T
    b0 = (k * tr[12]) * v3 + (k * tr[15]) * v4 + (k * tr[18]) * v5
    b1 = (k * tr[13]) * v3 + (k * tr[16]) * v4 + (k * tr[19]) * v5
    b2 = (k * tr[14]) * v3 + (k * tr[17]) * v4 + (k * tr[20]) * v5
    out[3] = J0[0, 0] * b0 + J0[0, 1] * b1 + J0[0, 2] * b2
    out[4] = J0[1, 0] * b0 + J0[1, 1] * b1 + J0[1, 2] * b2
    out[5] = J0[2, 0] * b0 + J0[2, 1] * b1 + J0[2, 2] * b2
    for q in range(6):
        out[6 + q] = w[0, q]
    if switch_input:
        for q in range(6):
            out[q] -= gamma * _switch(out[6 + q], bl)


@njit(cache=True, error_model="numpy")
def _observed_disturbance(ck, x, tr, u, m_off, inertia_err, a_f, a_tau, c, J0, J0i, out):
    """out = d_obs = d(u_app) + M (u_app - u_obs): what the FT-DO sees (sections 5-6)."""
    m0 = c[K_M0]
    m = m0 + 1.0 + 0.1 * ck[0] + m_off
    d_f = (ck[0], ck[3], ck[2])
    for i in range(3):
        out[i] = (1.0 / m - 1.0 / m0) * u[i] + a_f * d_f[i] / m
    acc = _true_body_acc(ck, x[9], x[10], x[11], u[3], u[4], u[5], J0, inertia_err, a_tau)
    om0, om1, om2 = x[9], x[10], x[11]
    j0 = J0[0, 0] * om0 + J0[0, 1] * om1 + J0[0, 2] * om2
    j1 = J0[1, 0] * om0 + J0[1, 1] * om1 + J0[1, 2] * om2
    j2 = J0[2, 0] * om0 + J0[2, 1] * om1 + J0[2, 2] * om2
    g0 = -(om1 * j2 - om2 * j1) + u[3]
    g1 = -(om2 * j0 - om0 * j2) + u[4]
    g2 = -(om0 * j1 - om1 * j0) + u[5]
    b0 = acc[0] - (J0i[0, 0] * g0 + J0i[0, 1] * g1 + J0i[0, 2] * g2)
    b1 = acc[1] - (J0i[1, 0] * g0 + J0i[1, 1] * g1 + J0i[1, 2] * g2)
    b2 = acc[2] - (J0i[2, 0] * g0 + J0i[2, 1] * g1 + J0i[2, 2] * g2)
    out[3] = tr[12] * b0 + tr[13] * b1 + tr[14] * b2
    out[4] = tr[15] * b0 + tr[16] * b1 + tr[17] * b2
    out[5] = tr[18] * b0 + tr[19] * b1 + tr[20] * b2
    dm = _apply_M(tr, J0i, m0, u[0] - u[6], u[1] - u[7], u[2] - u[8], u[3] - u[9],
                  u[4] - u[10], u[5] - u[11])  # fmt: skip
    for i in range(6):
        out[i] += dm[i]


def simulate_numba(batch: Batch, plant: Plant, gains: Gains, dt: float, n_steps: int,
                   rec_every: int, final_start: int, late_start: int, tols: np.ndarray,
                   rec: np.ndarray, offsets: np.ndarray, settle: np.ndarray,
                   final_max: np.ndarray, peak_app: np.ndarray, peak_cmd: np.ndarray,
                   peak_late: np.ndarray, impulse: np.ndarray, failed: np.ndarray) -> None:
    """Integrate ``batch`` and fill the output arrays in place (:func:`simulate`), in blocks of
    samples over the threads numba may use now."""
    import numba

    P, Q = plant.reference.basis()
    # the batch's arrays in field order, contiguous, so that every study runs one compiled
    # specialisation (docs/simulators.md#ft-as-what-the-kernel-accumulates)
    kinds = {"controller": np.int64, "observer_on_applied": np.bool_, "switch_input": np.bool_}
    per_sample: list[np.ndarray] = [
        np.ascontiguousarray(getattr(batch, f.name), dtype=kinds.get(f.name, float))
        for f in fields(Batch)]
    simulate(
        *per_sample,
        pack_constants(plant, gains),
        np.ascontiguousarray(plant.J0, dtype=float),
        np.ascontiguousarray(plant.J0_inv),
        P, Q, np.asarray(plant.limits, dtype=float), float(dt), n_steps, rec_every,
        final_start, late_start, tols, rec, offsets, settle, final_max, peak_app,
        peak_cmd, peak_late, impulse, failed, block_size(batch.n, numba.get_num_threads()),
    )  # fmt: skip


@njit(cache=True, error_model="numpy", parallel=True)
def simulate(x0, mass_off, inertia_err, force_amp, torque_amp, ctrl, obs_applied, psi2_bound,
             omega_chi, switch_input, c, J0, J0i, P, Q, limits, dt, n_steps, rec_every,
             final_start, late_start, tols, rec, offsets, settle, final_max, peak_app, peak_cmd,
             peak_late, impulse, failed, block):  # fmt: skip
    """Integrate every sample of a batch and accumulate its metrics.

    Inputs: the initial states ``x0 (n, 36)`` and the per-sample arrays ``mass_off`` ...
    ``switch_input`` of :class:`setup.Batch`; the constants ``c`` of
    :func:`setup.pack_constants`; the nominal inertia ``J0`` [kg m^2] and its inverse ``J0i``;
    the reference orbit's in-plane unit vectors ``P``, ``Q`` (ECI); the actuator ``limits``
    (6,) [N, N m]; ``n_steps`` steps of ``dt`` [s]; every ``rec_every`` steps a record into
    ``rec (n, n_rec, n_channels)``, each group of ``layout.RECORD_GROUPS`` at column
    ``offsets[g]`` (-1: not recorded); the first steps ``final_start`` of the final-accuracy
    window and ``late_start`` of the "late" peak window; the settling tolerances ``tols (7,
    n_tol)`` per ``layout.SETTLE_QUANTITIES`` row (<= 0: unused); ``block`` samples per
    parallel block (:func:`block_size`: the speed, not the numbers).

    Outputs, in place (zeroed by the caller): ``settle (n, 7, n_tol)`` the last time [s] each
    norm exceeded each tolerance; ``final_max (n, 4, 3)`` ``max |x_k|`` over the final window
    of ``r_e, v_e, sigma_e, omega_e``; ``peak_app``, ``peak_cmd``, ``peak_late (n, 6)`` the
    peaks of ``|u_k|`` applied, commanded, applied after ``late_start``; ``impulse (n, 6)``
    ``integral |u_k| dt`` [N s, N m s]; ``failed (n,)`` where the state became non-finite (the
    sample stops there).
    """
    n = x0.shape[0]
    n_blocks = (n + block - 1) // block
    for ib in prange(n_blocks):
        lo = ib * block
        _simulate_block(lo, min(n, lo + block), x0, mass_off, inertia_err, force_amp,
                        torque_amp, ctrl, obs_applied, psi2_bound, omega_chi, switch_input, c,
                        J0, J0i, P, Q, limits, dt, n_steps, rec_every, final_start, late_start,
                        tols, rec, offsets, settle, final_max, peak_app, peak_cmd, peak_late,
                        impulse, failed)  # fmt: skip


@njit(cache=True, error_model="numpy")
def _simulate_block(lo, hi, x0, mass_off, inertia_err, force_amp, torque_amp, ctrl, obs_applied,
                    psi2_bound, omega_chi, switch_input, c, J0, J0i, P, Q, limits, dt, n_steps,
                    rec_every, final_start, late_start, tols, rec, offsets, settle, final_max,
                    peak_app, peak_cmd, peak_late, impulse, failed):  # fmt: skip
    """Samples ``lo .. hi-1`` in lockstep: per step, the clock once, then each sample's step."""
    nb = hi - lo
    n_rec = rec.shape[1]
    n_tol = tols.shape[1]
    m0 = c[K_M0]
    nt = c[K_NT]
    XT = np.empty((36, nb))  # the block's states, a row per component (structure of arrays)
    for b in range(nb):
        for q in range(36):
            XT[q, b] = x0[lo + b, q]
    XsT = np.empty((36, nb))
    K1, K2, K3, K4 = (np.zeros((36, nb)), np.zeros((36, nb)), np.zeros((36, nb)),
                      np.zeros((36, nb)))  # fmt: skip
    UT = np.zeros((12, nb))  # held applied and observed inputs
    DU = np.zeros((6, nb))  # Case 2: saturation excess
    W = np.zeros((16, nb))
    mo, ie, af, at = (mass_off[lo:hi], inertia_err[lo:hi], force_amp[lo:hi],
                      torque_amp[lo:hi])  # fmt: skip
    oc = omega_chi[lo:hi]
    case2_lane = np.empty(nb, dtype=np.bool_)
    any_case2 = False
    for b in range(nb):
        case2_lane[b] = ctrl[lo + b] == CASE2
        any_case2 = any_case2 or case2_lane[b]
    env = np.empty((nb, 12))  # applied-input envelope over the output interval: min, max
    env[:, :6] = np.inf
    env[:, 6:] = -np.inf
    jrec = np.zeros(nb, dtype=np.int64)
    alive = np.ones(nb, dtype=np.bool_)
    X = np.empty(36)
    z, hd, law = np.empty(12), np.empty(12), np.empty(12)
    wlaw = np.empty((8, 6))
    u = np.empty(18)  # applied, observed, Case 2 excess
    s_true, dobs = np.empty(6), np.empty(6)
    norms = np.empty(7)
    half = 0.5 * dt
    for ks in range(n_steps + 1):
        t = ks * dt
        ck0 = _clock(t, c, P, Q)
        last = ks == n_steps
        if not last:
            ckh = _clock(t + half, c, P, Q)
            ck1 = _clock(t + dt, c, P, Q)
        else:
            ckh = ck0
            ck1 = ck0
        record = ks % rec_every == 0
        for b in range(nb):
            if not alive[b]:
                continue
            i = lo + b
            for q in range(36):
                X[q] = XT[q, b]
            ci = ctrl[i]
            case2 = ci == CASE2
            sw_in = switch_input[i]
            # --- controller at t (zero-order hold over the step); z: the true errors (e1, e2)
            tr = _terms(ck0, X, nt, J0, J0i)
            e2_3, e2_4, e2_5 = tr[6], tr[7], tr[8]
            for q in range(3):
                z[q], z[3 + q] = X[q], X[6 + q]
                z[6 + q], z[9 + q] = X[3 + q], tr[6 + q]
            for q in range(6):
                hd[q] = tr[q]
                hd[6 + q] = X[18 + q]
            if case2:  # s on the true errors (metric of claim C6); the law sees them minus chi
                _sliding(z, c, wlaw)
                for q in range(6):
                    s_true[q] = wlaw[0, q]
                kc1, kc2 = omega_chi[i] ** 2, 2.0 * omega_chi[i]
                for q in range(6):
                    z[q] = z[q] - X[24 + q]
                    z[6 + q] = z[6 + q] - X[30 + q]
                    hd[q] = hd[q] + kc1 * X[24 + q] + kc2 * X[30 + q]
            _law(z, hd, tr, J0, m0, sw_in, c, law, wlaw)
            for q in range(6):
                uc = law[q]
                if ci == CASE1:
                    ua = uc
                    uo = uc
                else:
                    ua = limits[q] * math.tanh(uc / limits[q])
                    uo = ua if (case2 or obs_applied[i]) else uc
                u[q] = ua
                u[6 + q] = uo
                u[12 + q] = ua - uc if case2 else 0.0
                UT[q, b] = ua
                UT[6 + q, b] = uo
                DU[q, b] = u[12 + q]
            if not case2:
                for q in range(6):
                    s_true[q] = law[6 + q]
            # --- metrics at t
            w0, w1, w2 = tr[9], tr[10], tr[11]
            norms[0] = math.sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2])
            norms[1] = math.sqrt(X[3] * X[3] + X[4] * X[4] + X[5] * X[5])
            norms[2] = math.sqrt(X[6] * X[6] + X[7] * X[7] + X[8] * X[8])
            norms[3] = math.sqrt(w0 * w0 + w1 * w1 + w2 * w2)
            e0 = X[12] - X[3]
            e1 = X[13] - X[4]
            e2 = X[14] - X[5]
            e3 = X[15] - e2_3
            e4 = X[16] - e2_4
            e5 = X[17] - e2_5
            norms[4] = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2 + e3 * e3 + e4 * e4 + e5 * e5)
            norms[5] = math.sqrt(s_true[0] ** 2 + s_true[1] ** 2 + s_true[2] ** 2)
            norms[6] = math.sqrt(s_true[3] ** 2 + s_true[4] ** 2 + s_true[5] ** 2)
            for qi in range(7):
                for ti in range(n_tol):
                    if tols[qi, ti] > 0.0 and norms[qi] > tols[qi, ti]:
                        settle[i, qi, ti] = t
            if ks >= final_start:
                for q in range(3):
                    final_max[i, 0, q] = max(final_max[i, 0, q], abs(X[q]))
                    final_max[i, 1, q] = max(final_max[i, 1, q], abs(X[3 + q]))
                    final_max[i, 2, q] = max(final_max[i, 2, q], abs(X[6 + q]))
                    final_max[i, 3, q] = max(final_max[i, 3, q], abs(tr[9 + q]))
            if not last:
                for q in range(6):
                    au = abs(u[q])
                    peak_app[i, q] = max(peak_app[i, q], au)
                    peak_cmd[i, q] = max(peak_cmd[i, q], abs(law[q]))
                    if ks >= late_start:
                        peak_late[i, q] = max(peak_late[i, q], au)
                    impulse[i, q] += au * dt
            for q in range(6):
                env[b, q] = min(env[b, q], u[q])
                env[b, 6 + q] = max(env[b, 6 + q], u[q])
            # --- recording
            j = jrec[b]
            if record and j < n_rec:
                put_vector(rec, i, j, offsets[0], X, 0, 3)  # r_e
                put_vector(rec, i, j, offsets[1], X, 3, 3)  # v_e
                put_vector(rec, i, j, offsets[2], X, 6, 3)  # sigma_e
                put_vector(rec, i, j, offsets[3], tr, 9, 3)  # omega_e
                put_vector(rec, i, j, offsets[4], s_true, 0, 6)
                put_vector(rec, i, j, offsets[5], law, 0, 6)  # u_command
                put_vector(rec, i, j, offsets[6], env[b], 0, 6)  # u_applied_min
                put_vector(rec, i, j, offsets[7], env[b], 6, 6)  # u_applied_max
                o = offsets[8]
                if o >= 0:
                    rec[i, j, o], rec[i, j, o + 1], rec[i, j, o + 2] = e0, e1, e2
                    rec[i, j, o + 3], rec[i, j, o + 4], rec[i, j, o + 5] = e3, e4, e5
                if offsets[9] >= 0 or offsets[11] >= 0:
                    _observed_disturbance(ck0, X, tr, u, mass_off[i], inertia_err[i],
                                          force_amp[i], torque_amp[i], c, J0, J0i, dobs)
                    o = offsets[9]
                    if o >= 0:
                        for q in range(6):
                            rec[i, j, o + q] = X[18 + q] - dobs[q]
                    put_vector(rec, i, j, offsets[11], dobs, 0, 6)  # d_obs
                put_vector(rec, i, j, offsets[10], X, 18, 6)  # d_hat
                put_vector(rec, i, j, offsets[12], X, 24, 6)  # chi1
                jrec[b] = j + 1
                for q in range(6):
                    env[b, q] = np.inf
                    env[b, 6 + q] = -np.inf
        if last:
            break
        # --- classical RK4 with held inputs, all lanes of the block at once
        _stage(ck0, XT, K1, UT, DU, mo, ie, af, at, oc, c, J0, J0i, W, case2_lane, any_case2, X,
               nb)  # fmt: skip
        for q in range(36):
            for b in range(nb):
                XsT[q, b] = XT[q, b] + half * K1[q, b]
        _stage(ckh, XsT, K2, UT, DU, mo, ie, af, at, oc, c, J0, J0i, W, case2_lane, any_case2, X,
               nb)  # fmt: skip
        for q in range(36):
            for b in range(nb):
                XsT[q, b] = XT[q, b] + half * K2[q, b]
        _stage(ckh, XsT, K3, UT, DU, mo, ie, af, at, oc, c, J0, J0i, W, case2_lane, any_case2, X,
               nb)  # fmt: skip
        for q in range(36):
            for b in range(nb):
                XsT[q, b] = XT[q, b] + dt * K3[q, b]
        _stage(ck1, XsT, K4, UT, DU, mo, ie, af, at, oc, c, J0, J0i, W, case2_lane, any_case2, X,
               nb)  # fmt: skip
        w6 = dt / 6.0
        for b in range(nb):
            if not alive[b]:
                continue  # a failed lane keeps its last finite state
            finite = True
            for q in range(36):
                X[q] = XT[q, b] + w6 * (K1[q, b] + 2.0 * K2[q, b] + 2.0 * K3[q, b] + K4[q, b])
                if not math.isfinite(X[q]):
                    finite = False
            if not finite:
                failed[lo + b] = True
                alive[b] = False
                continue
            sq = X[6] * X[6] + X[7] * X[7] + X[8] * X[8]
            if sq > 1.0:  # MRP shadow set
                for q in range(6, 9):
                    X[q] = -X[q] / sq
            bound = psi2_bound[lo + b]
            for q in range(18, 24):
                X[q] = min(max(X[q], -bound), bound)
            for q in range(36):
                XT[q, b] = X[q]
    # a sample that stopped early keeps its last recorded values on the rest of the grid
    for b in range(nb):
        i, j = lo + b, jrec[b]
        for jj in range(max(j, 1), n_rec):
            rec[i, jj] = rec[i, j - 1] if j > 0 else rec[i, 0]
