"""Compiled (numba) integration of a batch of FT-AS closed loops with per-step metrics.

The same equations as the numpy reference ``closed_loop.py`` (ft-as-controller.md sections
3-9), written per sample on scalars and small scratch arrays so that one RK4 step of one sample
costs a few microseconds instead of the ~2 ms per batch step of numpy's per-call overhead. The
model's accuracy floors are set by the sampling rate (section 12.3), so the spec's h = 0.01 s
over 3000 s (3e5 steps) is what a reported run needs; only a compiled loop makes that, and
Monte Carlo over it, affordable. ``tests/test_ft_as_kernel.py`` checks this kernel against
:func:`closed_loop.rk4_step` to rounding level.

Metrics (section 10) are accumulated at every step, so they do not depend on the output grid:
settling times (last time a norm exceeds each tolerance), final-window maxima, peaks of the
applied and commanded inputs, and the integrals of ``|u_k|``.
"""

from __future__ import annotations

import math

import numpy as np
from ..kernels import njit

from .setup import (
    CASE1,
    CASE2,
    K_A,
    K_AT,
    K_B,
    K_BOUNDARY,
    K_C,
    K_EPS,
    K_ETA1,
    K_ETA2,
    K_GAMMA,
    K_LAM1,
    K_LAM2,
    K_LAM3,
    K_M0,
    K_MU,
    K_NT,
    K_NU1,
    K_NU2,
    K_OBS_P,
    K_OBS_PER_CHANNEL,
    K_R2,
    K_RHO2,
    K_U0,
)

# Recorded channel groups: name -> width. The caller asks for a subset through offsets.
RECORD_GROUPS: dict[str, int] = {
    "r_e": 3,
    "v_e": 3,
    "sigma_e": 3,
    "omega_e": 3,
    "s": 6,  # sliding variable on the true errors
    "u_command": 6,  # u_c (Case 2: u_T) at the grid instant
    "u_applied_min": 6,  # envelope of the applied input over the output interval
    "u_applied_max": 6,
    "eps1": 6,  # psi1 - e2
    "eps2": 6,  # psi2 - d_obs (true)
    "d_hat": 6,
    "d_obs": 6,
    "chi1": 6,
}
GROUP_INDEX = {name: i for i, name in enumerate(RECORD_GROUPS)}
# Order of the norms whose settling times are tracked (section 10) and of their tolerance rows.
SETTLE_QUANTITIES = ("r_e", "v_e", "sigma_e", "omega_e", "eps1", "s_trans", "s_rot")


@njit(cache=True)
def _sig(x: float, p: float) -> float:
    if x > 0.0:
        return x**p
    if x < 0.0:
        return -((-x) ** p)
    return 0.0


@njit(cache=True)
def _sign(x: float) -> float:
    return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)


@njit(cache=True)
def _mrp_matrices(x, G, Gi, C):
    """G(sigma), G(sigma)^-1 and C(sigma) of sigma = x[6:9] (section 1.1)."""
    s0, s1, s2 = x[6], x[7], x[8]
    q = s0 * s0 + s1 * s1 + s2 * s2
    a = 0.25 * (1.0 - q)
    G[0, 0] = a + 0.5 * s0 * s0
    G[0, 1] = 0.5 * (-s2 + s0 * s1)
    G[0, 2] = 0.5 * (s1 + s0 * s2)
    G[1, 0] = 0.5 * (s2 + s1 * s0)
    G[1, 1] = a + 0.5 * s1 * s1
    G[1, 2] = 0.5 * (-s0 + s1 * s2)
    G[2, 0] = 0.5 * (-s1 + s2 * s0)
    G[2, 1] = 0.5 * (s0 + s2 * s1)
    G[2, 2] = a + 0.5 * s2 * s2
    k = 16.0 / (1.0 + q) ** 2
    d = 1.0 / (1.0 + q) ** 2
    w = 4.0 * (1.0 - q)
    s = (s0, s1, s2)
    # S(sigma) entries
    S = ((0.0, -s2, s1), (s2, 0.0, -s0), (-s1, s0, 0.0))
    for i in range(3):
        for j in range(3):
            Gi[i, j] = k * G[j, i]
            eye = 1.0 if i == j else 0.0
            C[i, j] = eye + d * (8.0 * (s[i] * s[j] - q * eye) - w * S[i][j])


@njit(cache=True)
def _matvec(A, v0: float, v1: float, v2: float, out, o: int):
    for i in range(3):
        out[o + i] = A[i, 0] * v0 + A[i, 1] * v1 + A[i, 2] * v2


@njit(cache=True)
def _terms(t, x, c, J0, J0i, P, Q, G, Gi, C, e1, e2, h, w3):
    """Tracking model at state x (section 5): fills e1, e2, h (6,) and G, G^-1, C.

    ``w3`` (3,) receives omega_e. Returns nothing; all outputs are written in place.
    """
    _mrp_matrices(x, G, Gi, C)
    nt = c[K_NT]
    w0 = x[9] - C[0, 2] * nt  # omega_e = omega - C omega_t, omega_t = [0, 0, n_t]
    w1 = x[10] - C[1, 2] * nt
    w2 = x[11] - C[2, 2] * nt
    w3[0], w3[1], w3[2] = w0, w1, w2
    s0, s1, s2 = x[6], x[7], x[8]
    sd0 = G[0, 0] * w0 + G[0, 1] * w1 + G[0, 2] * w2
    sd1 = G[1, 0] * w0 + G[1, 1] * w1 + G[1, 2] * w2
    sd2 = G[2, 0] * w0 + G[2, 1] * w1 + G[2, 2] * w2
    # Gdot omega_e = 1/2 [-(s.sd) we + sd x we + sd (s.we) + s (sd.we)]
    ssd = s0 * sd0 + s1 * sd1 + s2 * sd2
    swe = s0 * w0 + s1 * w1 + s2 * w2
    sdwe = sd0 * w0 + sd1 * w1 + sd2 * w2
    gd0 = 0.5 * (-ssd * w0 + (sd1 * w2 - sd2 * w1) + sd0 * swe + s0 * sdwe)
    gd1 = 0.5 * (-ssd * w1 + (sd2 * w0 - sd0 * w2) + sd1 * swe + s1 * sdwe)
    gd2 = 0.5 * (-ssd * w2 + (sd0 * w1 - sd1 * w0) + sd2 * swe + s2 * sdwe)
    om0, om1, om2 = x[9], x[10], x[11]
    j0 = J0[0, 0] * om0 + J0[0, 1] * om1 + J0[0, 2] * om2
    j1 = J0[1, 0] * om0 + J0[1, 1] * om1 + J0[1, 2] * om2
    j2 = J0[2, 0] * om0 + J0[2, 1] * om1 + J0[2, 2] * om2
    g0 = -(om1 * j2 - om2 * j1)  # -omega x J0 omega
    g1 = -(om2 * j0 - om0 * j2)
    g2 = -(om0 * j1 - om1 * j0)
    a0 = J0i[0, 0] * g0 + J0i[0, 1] * g1 + J0i[0, 2] * g2
    a1 = J0i[1, 0] * g0 + J0i[1, 1] * g1 + J0i[1, 2] * g2
    a2 = J0i[2, 0] * g0 + J0i[2, 1] * g1 + J0i[2, 2] * g2
    wt0, wt1, wt2 = C[0, 2] * nt, C[1, 2] * nt, C[2, 2] * nt
    a0 += w1 * wt2 - w2 * wt1  # + omega_e x (C omega_t)
    a1 += w2 * wt0 - w0 * wt2
    a2 += w0 * wt1 - w1 * wt0
    h[3] = gd0 + G[0, 0] * a0 + G[0, 1] * a1 + G[0, 2] * a2
    h[4] = gd1 + G[1, 0] * a0 + G[1, 1] * a1 + G[1, 2] * a2
    h[5] = gd2 + G[2, 0] * a0 + G[2, 1] * a1 + G[2, 2] * a2
    # differential gravity, cancellation-free (see closed_loop.differential_gravity)
    u = c[K_U0] + nt * t
    cu, su = math.cos(u), math.sin(u)
    at = c[K_AT]
    rt0 = at * (cu * P[0] + su * Q[0])
    rt1 = at * (cu * P[1] + su * Q[1])
    rt2 = at * (cu * P[2] + su * Q[2])
    re0, re1, re2 = x[0], x[1], x[2]
    rtn2 = rt0 * rt0 + rt1 * rt1 + rt2 * rt2
    q = (2.0 * (re0 * rt0 + re1 * rt1 + re2 * rt2) + re0 * re0 + re1 * re1 + re2 * re2) / rtn2
    km1 = math.expm1(-1.5 * math.log1p(q))
    f = -c[K_MU] / rtn2**1.5
    h[0] = f * ((1.0 + km1) * re0 + km1 * rt0)
    h[1] = f * ((1.0 + km1) * re1 + km1 * rt1)
    h[2] = f * ((1.0 + km1) * re2 + km1 * rt2)
    for i in range(3):
        e1[i] = x[i]
        e1[3 + i] = x[6 + i]
        e2[i] = x[3 + i]
    e2[3], e2[4], e2[5] = sd0, sd1, sd2


@njit(cache=True)
def _apply_M(u, G, J0i, m0, out):
    """out = M u = [u_f / m0 ; G J0^-1 u_tau] (section 5)."""
    for i in range(3):
        out[i] = u[i] / m0
    b0 = J0i[0, 0] * u[3] + J0i[0, 1] * u[4] + J0i[0, 2] * u[5]
    b1 = J0i[1, 0] * u[3] + J0i[1, 1] * u[4] + J0i[1, 2] * u[5]
    b2 = J0i[2, 0] * u[3] + J0i[2, 1] * u[4] + J0i[2, 2] * u[5]
    _matvec(G, b0, b1, b2, out, 3)


@njit(cache=True)
def _true_body_acc(t, x, tau0, tau1, tau2, J0, inertia_err, a_tau, out):
    """out[0:3] = J(t)^-1 (-omega x J omega + tau + d_tau) (eq 2, [A6]), body [rad/s^2]."""
    k = 1.0 + inertia_err
    J00 = k * J0[0, 0] + 0.1 + 0.01 * math.sin(0.1 * t)
    J11 = k * J0[1, 1] + 0.1 + 0.01 * math.sin(0.2 * t)
    J22 = k * J0[2, 2] + 0.1 + 0.01 * math.sin(0.3 * t)
    J01, J02, J12 = k * J0[0, 1], k * J0[0, 2], k * J0[1, 2]
    om0, om1, om2 = x[9], x[10], x[11]
    j0 = J00 * om0 + J01 * om1 + J02 * om2
    j1 = J01 * om0 + J11 * om1 + J12 * om2
    j2 = J02 * om0 + J12 * om1 + J22 * om2
    b0 = -(om1 * j2 - om2 * j1) + tau0 + 2.0 * a_tau * math.sin(0.1 * t)
    b1 = -(om2 * j0 - om0 * j2) + tau1 + 2.0 * a_tau * math.cos(0.2 * t)
    b2 = -(om0 * j1 - om1 * j0) + tau2 + 2.0 * a_tau * math.sin(0.3 * t)
    # symmetric 3x3 solve by the adjugate
    c00 = J11 * J22 - J12 * J12
    c01 = J02 * J12 - J01 * J22
    c02 = J01 * J12 - J02 * J11
    c11 = J00 * J22 - J02 * J02
    c12 = J01 * J02 - J00 * J12
    c22 = J00 * J11 - J01 * J01
    det = J00 * c00 + J01 * c01 + J02 * c02
    out[0] = (c00 * b0 + c01 * b1 + c02 * b2) / det
    out[1] = (c01 * b0 + c11 * b1 + c12 * b2) / det
    out[2] = (c02 * b0 + c12 * b1 + c22 * b2) / det


@njit(cache=True)
def _rhs(t, X, dX, u_app, u_obs, du, m_off, inertia_err, a_f, a_tau, omega_chi, c, J0, J0i,
         P, Q, G, Gi, C, e1, e2, h, w3, v6, a3):  # fmt: skip
    """dX/dt of one sample with held inputs (sections 3.2, 6, 8.3)."""
    _terms(t, X, c, J0, J0i, P, Q, G, Gi, C, e1, e2, h, w3)
    m = c[K_M0] + 1.0 + 0.1 * math.sin(0.1 * t) + m_off
    dX[0], dX[1], dX[2] = X[3], X[4], X[5]
    dX[3] = h[0] + (u_app[0] + a_f * math.sin(0.1 * t)) / m
    dX[4] = h[1] + (u_app[1] + a_f * math.cos(0.2 * t)) / m
    dX[5] = h[2] + (u_app[2] + a_f * math.sin(0.3 * t)) / m
    dX[6], dX[7], dX[8] = e2[3], e2[4], e2[5]
    _true_body_acc(t, X, u_app[3], u_app[4], u_app[5], J0, inertia_err, a_tau, a3)
    dX[9], dX[10], dX[11] = a3[0], a3[1], a3[2]
    # FT-DO (eq 18-20)
    _apply_M(u_obs, G, J0i, c[K_M0], v6)
    for i in range(6):
        v6[i] += h[i]
        e1[i] = X[12 + i] - e2[i]  # e1 reused as eps1
    if c[K_OBS_PER_CHANNEL] > 0.0:
        n_t = math.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2)
        n_r = math.sqrt(e1[3] ** 2 + e1[4] ** 2 + e1[5] ** 2)
    else:
        n_t = math.sqrt(e1[0] ** 2 + e1[1] ** 2 + e1[2] ** 2 + e1[3] ** 2 + e1[4] ** 2 + e1[5] ** 2)
        n_r = n_t
    lam1, lam2, lam3, p = c[K_LAM1], c[K_LAM2], c[K_LAM3], c[K_OBS_P]
    # gain of unit(eps1): lam1 |eps1|^(1/2) + lam2 |eps1|^p, once per norm (pow is costly)
    g_t = lam1 * math.sqrt(n_t) + lam2 * n_t**p
    g_r = g_t if n_r == n_t else lam1 * math.sqrt(n_r) + lam2 * n_r**p
    for i in range(6):
        nrm = n_t if i < 3 else n_r
        unit = e1[i] / nrm if nrm > 0.0 else 0.0
        dX[12 + i] = -(g_t if i < 3 else g_r) * unit + X[18 + i] + v6[i]
        dX[18 + i] = -lam3 * unit
    # Case 2 auxiliary system (section 8.3); du = 0 for the other controllers
    _apply_M(du, G, J0i, c[K_M0], v6)
    k1, k2 = omega_chi * omega_chi, 2.0 * omega_chi
    for i in range(6):
        dX[24 + i] = X[30 + i]
        dX[30 + i] = -k1 * X[24 + i] - k2 * X[30 + i] + v6[i]


@njit(cache=True)
def _law(z1, z2, hbar, dhat, Gi, J0, m0, switch_input, c, u, s, v):
    """FT-NTSM command u (eq 29 / 42) and sliding variable s (eq 26-27) from z1, z2 (6,)."""
    a, b, cc = c[K_A], c[K_B], c[K_C]
    nu1, eta1, nu2, eta2 = c[K_NU1], c[K_ETA1], c[K_NU2], c[K_ETA2]
    gamma, eps, bl = c[K_GAMMA], c[K_EPS], c[K_BOUNDARY]
    for k in range(6):
        e1k, e2k = z1[k], z2[k]
        base = nu1 * abs(e1k) ** b + eta1  # 1 / kappa
        kappa = 1.0 / base
        sk = e1k + _sig(kappa * e2k, a)
        s[k] = sk
        reach = nu2 * _sig(sk, c[K_R2]) + eta2 * _sig(sk, c[K_RHO2])
        if e2k == 0.0:
            g = 1.0  # [A9]
        else:
            f = abs(e2k) ** (a - 1.0)
            phi = math.sin(math.pi * f / (2.0 * eps)) if f < eps else 1.0
            g = phi / f
        k_a = base**a  # kappa^-a
        v[k] = (
            nu1 * b * kappa * _sig(e1k, b - 1.0) * e2k * e2k
            - cc * k_a * _sig(e2k, 2.0 - a)
            - cc * k_a * g * reach
            - hbar[k]
            - dhat[k]
        )
        sw = math.tanh(sk / bl) if bl > 0.0 else _sign(sk)
        if not switch_input:
            v[k] -= gamma * sw
    for i in range(3):
        u[i] = m0 * v[i]
    b0 = Gi[0, 0] * v[3] + Gi[0, 1] * v[4] + Gi[0, 2] * v[5]
    b1 = Gi[1, 0] * v[3] + Gi[1, 1] * v[4] + Gi[1, 2] * v[5]
    b2 = Gi[2, 0] * v[3] + Gi[2, 1] * v[4] + Gi[2, 2] * v[5]
    _matvec(J0, b0, b1, b2, u, 3)
    if switch_input:
        for k in range(6):
            u[k] -= gamma * (math.tanh(s[k] / bl) if bl > 0.0 else _sign(s[k]))


@njit(cache=True)
def _observed_disturbance(t, X, u_app, u_obs, m_off, inertia_err, a_f, a_tau, c, J0, J0i, G,
                          a3, v6, dm, out):  # fmt: skip
    """out = d_obs = d(u_app) + M (u_app - u_obs): what the FT-DO sees (sections 5-6)."""
    m0 = c[K_M0]
    m = m0 + 1.0 + 0.1 * math.sin(0.1 * t) + m_off
    d_f = (math.sin(0.1 * t), math.cos(0.2 * t), math.sin(0.3 * t))
    for i in range(3):
        out[i] = (1.0 / m - 1.0 / m0) * u_app[i] + a_f * d_f[i] / m
    _true_body_acc(t, X, u_app[3], u_app[4], u_app[5], J0, inertia_err, a_tau, a3)
    om0, om1, om2 = X[9], X[10], X[11]
    j0 = J0[0, 0] * om0 + J0[0, 1] * om1 + J0[0, 2] * om2
    j1 = J0[1, 0] * om0 + J0[1, 1] * om1 + J0[1, 2] * om2
    j2 = J0[2, 0] * om0 + J0[2, 1] * om1 + J0[2, 2] * om2
    g0 = -(om1 * j2 - om2 * j1) + u_app[3]
    g1 = -(om2 * j0 - om0 * j2) + u_app[4]
    g2 = -(om0 * j1 - om1 * j0) + u_app[5]
    b0 = a3[0] - (J0i[0, 0] * g0 + J0i[0, 1] * g1 + J0i[0, 2] * g2)
    b1 = a3[1] - (J0i[1, 0] * g0 + J0i[1, 1] * g1 + J0i[1, 2] * g2)
    b2 = a3[2] - (J0i[2, 0] * g0 + J0i[2, 1] * g1 + J0i[2, 2] * g2)
    _matvec(G, b0, b1, b2, out, 3)
    for i in range(6):
        v6[i] = u_app[i] - u_obs[i]
    _apply_M(v6, G, J0i, m0, dm)
    for i in range(6):
        out[i] += dm[i]


@njit(cache=True)
def _norm(x, lo: int, hi: int) -> float:
    acc = 0.0
    for i in range(lo, hi):
        acc += x[i] * x[i]
    return math.sqrt(acc)


@njit(cache=True)
def simulate(x0, mass_off, inertia_err, force_amp, torque_amp, ctrl, obs_applied, psi2_bound,
             omega_chi, switch_input, c, J0, J0i, P, Q, limits, dt, n_steps, rec_every,
             final_start, late_start, tols, rec, offsets, settle, final_max, peak_app, peak_cmd,
             peak_late, impulse, failed):  # fmt: skip
    """Integrate every sample of a batch and accumulate its metrics (section 9-10).

    Parameters
    ----------
    x0 : ndarray, shape (n, 36)
        Initial states. The per-sample arrays ``mass_off`` ... ``switch_input`` are those of
        :class:`setup.Batch` (shape (n,)).
    c : ndarray, shape (N_CONST,)
        Constants packed by :func:`setup.pack_constants`.
    J0, J0i : ndarray, shape (3, 3)
        Nominal inertia [kg m^2] and its inverse.
    P, Q : ndarray, shape (3,)
        In-plane unit vectors of the reference orbit (ECI).
    limits : ndarray, shape (6,)
        Actuator limits [N, N m].
    dt : float
        Step [s]; ``n_steps`` steps are taken.
    rec_every : int
        Record every ``rec_every`` steps into ``rec`` (n, n_rec, n_channels), the groups of
        ``RECORD_GROUPS`` at column ``offsets[g]`` (-1: not recorded).
    final_start, late_start : int
        First step of the final-accuracy window and of the "late" peak window.
    tols : ndarray, shape (7, n_tol)
        Settling tolerances per ``SETTLE_QUANTITIES`` row (entries <= 0 unused).

    Outputs (written in place, zero-initialised by the caller)
    -----------------------------------------------------------
    settle : (n, 7, n_tol) last time [s] each norm exceeded each tolerance.
    final_max : (n, 4, 3) max |x_k| over the final window for r_e, v_e, sigma_e, omega_e.
    peak_app, peak_cmd, peak_late : (n, 6) max |u_k| applied, commanded, applied after late_start.
    impulse : (n, 6) integral of |u_applied,k| dt [N s, N m s].
    failed : (n,) True where the state became non-finite (the sample stops there).
    """
    n = x0.shape[0]
    n_rec = rec.shape[1]
    n_tol = tols.shape[1]
    m0 = c[K_M0]
    X, Xs = np.empty(36), np.empty(36)
    k1, k2, k3, k4 = np.empty(36), np.empty(36), np.empty(36), np.empty(36)
    G, Gi, C = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3))
    six = np.empty((16, 6))  # scratch 6-vectors, one row each
    e1, e2, h, v6 = six[0], six[1], six[2], six[3]
    z1, z2, hbar, u_c = six[4], six[5], six[6], six[7]
    u_app, u_obs, du, s = six[8], six[9], six[10], six[11]
    s_true, env_lo, env_hi, dobs = six[12], six[13], six[14], six[15]
    dm = np.empty(6)
    w3, a3 = np.empty(3), np.empty(3)
    norms = np.empty(7)
    for i in range(n):
        X[:] = x0[i]
        ci = ctrl[i]
        case2 = ci == CASE2
        kc1, kc2 = omega_chi[i] ** 2, 2.0 * omega_chi[i]
        env_lo[:] = np.inf
        env_hi[:] = -np.inf
        j = 0
        for ks in range(n_steps + 1):
            t = ks * dt
            # --- controller at t (zero-order hold over the step)
            _terms(t, X, c, J0, J0i, P, Q, G, Gi, C, e1, e2, h, w3)
            for q in range(6):
                if case2:
                    z1[q] = e1[q] - X[24 + q]
                    z2[q] = e2[q] - X[30 + q]
                    hbar[q] = h[q] + kc1 * X[24 + q] + kc2 * X[30 + q]
                else:
                    z1[q], z2[q], hbar[q] = e1[q], e2[q], h[q]
            _law(z1, z2, hbar, X[18:24], Gi, J0, m0, switch_input[i], c, u_c, s, v6)
            for q in range(6):
                if ci == CASE1:
                    u_app[q] = u_c[q]
                    u_obs[q] = u_c[q]
                else:
                    u_app[q] = limits[q] * math.tanh(u_c[q] / limits[q])
                    u_obs[q] = u_app[q] if (case2 or obs_applied[i]) else u_c[q]
                du[q] = u_app[q] - u_c[q] if case2 else 0.0
            if case2:  # s on the true errors (metric of claim C6)
                _law(e1, e2, h, X[18:24], Gi, J0, m0, switch_input[i], c, v6, s_true, z1)
            else:
                s_true[:] = s
            # --- metrics at t
            norms[0] = _norm(X, 0, 3)
            norms[1] = _norm(X, 3, 6)
            norms[2] = _norm(X, 6, 9)
            norms[3] = _norm(w3, 0, 3)
            acc = 0.0
            for q in range(6):
                acc += (X[12 + q] - e2[q]) ** 2
            norms[4] = math.sqrt(acc)
            norms[5] = _norm(s_true, 0, 3)
            norms[6] = _norm(s_true, 3, 6)
            for qi in range(7):
                for ti in range(n_tol):
                    if tols[qi, ti] > 0.0 and norms[qi] > tols[qi, ti]:
                        settle[i, qi, ti] = t
            if ks >= final_start:
                for q in range(3):
                    final_max[i, 0, q] = max(final_max[i, 0, q], abs(X[q]))
                    final_max[i, 1, q] = max(final_max[i, 1, q], abs(X[3 + q]))
                    final_max[i, 2, q] = max(final_max[i, 2, q], abs(X[6 + q]))
                    final_max[i, 3, q] = max(final_max[i, 3, q], abs(w3[q]))
            if ks < n_steps:
                for q in range(6):
                    peak_app[i, q] = max(peak_app[i, q], abs(u_app[q]))
                    peak_cmd[i, q] = max(peak_cmd[i, q], abs(u_c[q]))
                    if ks >= late_start:
                        peak_late[i, q] = max(peak_late[i, q], abs(u_app[q]))
                    impulse[i, q] += abs(u_app[q]) * dt
            for q in range(6):
                env_lo[q] = min(env_lo[q], u_app[q])
                env_hi[q] = max(env_hi[q], u_app[q])
            # --- recording
            if ks % rec_every == 0 and j < n_rec:
                row = rec[i, j]
                o = offsets[0]
                if o >= 0:
                    row[o : o + 3] = X[0:3]
                o = offsets[1]
                if o >= 0:
                    row[o : o + 3] = X[3:6]
                o = offsets[2]
                if o >= 0:
                    row[o : o + 3] = X[6:9]
                o = offsets[3]
                if o >= 0:
                    row[o : o + 3] = w3
                o = offsets[4]
                if o >= 0:
                    row[o : o + 6] = s_true
                o = offsets[5]
                if o >= 0:
                    row[o : o + 6] = u_c
                o = offsets[6]
                if o >= 0:
                    row[o : o + 6] = env_lo
                o = offsets[7]
                if o >= 0:
                    row[o : o + 6] = env_hi
                o = offsets[8]
                if o >= 0:
                    for q in range(6):
                        row[o + q] = X[12 + q] - e2[q]
                if offsets[9] >= 0 or offsets[11] >= 0:
                    _observed_disturbance(t, X, u_app, u_obs, mass_off[i], inertia_err[i],
                                          force_amp[i], torque_amp[i], c, J0, J0i, G, a3, v6,
                                          dm, dobs)  # fmt: skip
                    o = offsets[9]
                    if o >= 0:
                        for q in range(6):
                            row[o + q] = X[18 + q] - dobs[q]
                    o = offsets[11]
                    if o >= 0:
                        row[o : o + 6] = dobs
                o = offsets[10]
                if o >= 0:
                    row[o : o + 6] = X[18:24]
                o = offsets[12]
                if o >= 0:
                    row[o : o + 6] = X[24:30]
                j += 1
                env_lo[:] = np.inf
                env_hi[:] = -np.inf
            if ks == n_steps:
                break
            # --- classical RK4 with held inputs (section 9 step 3)
            mo, ie, oc = mass_off[i], inertia_err[i], omega_chi[i]
            af, at = force_amp[i], torque_amp[i]
            _rhs(t, X, k1, u_app, u_obs, du, mo, ie, af, at, oc, c, J0, J0i, P, Q, G, Gi, C,
                 e1, e2, h, w3, v6, a3)  # fmt: skip
            for q in range(36):
                Xs[q] = X[q] + 0.5 * dt * k1[q]
            _rhs(t + 0.5 * dt, Xs, k2, u_app, u_obs, du, mo, ie, af, at, oc, c, J0, J0i, P, Q,
                 G, Gi, C, e1, e2, h, w3, v6, a3)  # fmt: skip
            for q in range(36):
                Xs[q] = X[q] + 0.5 * dt * k2[q]
            _rhs(t + 0.5 * dt, Xs, k3, u_app, u_obs, du, mo, ie, af, at, oc, c, J0, J0i, P, Q,
                 G, Gi, C, e1, e2, h, w3, v6, a3)  # fmt: skip
            for q in range(36):
                Xs[q] = X[q] + dt * k3[q]
            _rhs(t + dt, Xs, k4, u_app, u_obs, du, mo, ie, af, at, oc, c, J0, J0i, P, Q,
                 G, Gi, C, e1, e2, h, w3, v6, a3)  # fmt: skip
            finite = True
            for q in range(36):
                X[q] += dt / 6.0 * (k1[q] + 2.0 * k2[q] + 2.0 * k3[q] + k4[q])
                if not math.isfinite(X[q]):
                    finite = False
            if not finite:
                failed[i] = True
                break
            sq = X[6] * X[6] + X[7] * X[7] + X[8] * X[8]
            if sq > 1.0:  # MRP shadow set
                for q in range(6, 9):
                    X[q] = -X[q] / sq
            bound = psi2_bound[i]
            for q in range(18, 24):
                X[q] = min(max(X[q], -bound), bound)
        # a sample that stopped early keeps its last recorded values on the rest of the grid
        for jj in range(max(j, 1), n_rec):
            rec[i, jj] = rec[i, j - 1] if j > 0 else rec[i, 0]
