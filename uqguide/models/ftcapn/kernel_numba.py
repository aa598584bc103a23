"""FTCAPN closed loop, compiled with Numba.

Same algorithm and same arrays as its NumPy oracle ``tests/oracles/ftcapn.py`` (see it for the
equations); the test suite holds both to ~1e-9 relative. The layout of blocks, lanes and passes
(:func:`_simulate_block`), and why: docs/performance.md#the-ftcapn-kernel.
"""

from __future__ import annotations

import math

import numpy as np
from numba import prange

from ..kernels import njit
from ..record_rows import put_lanes

from .layout import (
    K_ACMAX, K_DV, K_RS, K_TFAIL, K_TSETTLE, K_TSTOP, K_TSURF, K_VS, P_ASAT, P_BETA, P_C,
    P_CONTROL, P_DELTA, P_ROTATING, P_DT, P_EPS, P_ETA, P_N, P_NMEAN, P_RSTOP, P_SETTLE, S_AC,
    S_ACLOS, S_DV, S_OMEGA, S_POS, S_R, S_RDOT, S_S, S_SPEED, S_VEL, S_W, ST_NONFINITE, ST_OK,
    ST_TMAX,
)

EPS = float(np.finfo(np.float64).eps)


@njit(cache=True, inline="always")
def _put(buf, c, i, k, value):
    """Series column ``c`` of sample ``i`` at grid row ``k``; nothing when not recorded."""
    if c >= 0:
        buf[c, i, k] = value


@njit(cache=True, inline="always")
def _put3(buf, c, i, k, a, b, d):
    """Columns ``c .. c+2`` (a three-component series) of sample ``i`` at grid row ``k``."""
    if c >= 0:
        buf[c, i, k] = a
        buf[c + 1, i, k] = b
        buf[c + 2, i, k] = d


@njit(cache=True, inline="always")
def _los_rate(x, y, z, vx, vy, vz, R):
    """The LOS rate vector ``r x v / R^2`` (series ``w``)."""
    R2 = R * R
    return (y * vz - z * vy) / R2, (z * vx - x * vz) / R2, (x * vy - y * vx) / R2


@njit(cache=True, inline="always")
def _speed(vx, vy, vz):
    return math.sqrt(vx * vx + vy * vy + vz * vz)


@njit(cache=True, error_model="numpy")
def _record(buf, i, k0, k1, col, x, y, z, vx, vy, vz, R, Rdot, om, s, a0, a1, a2, acr, act, dv):
    """Write the grid rows ``k0 .. k1-1`` of sample ``i`` (same values on every row). Scalars,
    not array rows: a row view costs an atomic reference-count pair in the hot loop."""
    w0, w1, w2 = _los_rate(x, y, z, vx, vy, vz, R)
    speed = _speed(vx, vy, vz)
    for k in range(k0, k1):
        _put(buf, col[S_OMEGA], i, k, om)
        _put3(buf, col[S_W], i, k, w0, w1, w2)
        _put(buf, col[S_R], i, k, R)
        _put(buf, col[S_RDOT], i, k, Rdot)
        _put(buf, col[S_S], i, k, s)
        _put3(buf, col[S_AC], i, k, a0, a1, a2)
        _put3(buf, col[S_ACLOS], i, k, acr, act, 0.0)
        _put(buf, col[S_DV], i, k, dv)
        _put3(buf, col[S_POS], i, k, x, y, z)
        _put3(buf, col[S_VEL], i, k, vx, vy, vz)
        _put(buf, col[S_SPEED], i, k, speed)


@njit(cache=True, error_model="numpy")
def _derivatives(st, f, nm, D):
    """Taylor coefficients ``D[k]`` = k-th time derivative of the state (k = 0..4) under
    ``r'' = g(r, v) + f`` with constant ``f`` (``g`` = Hill terms, zero when ``nm == 0``)."""
    for q in range(6):
        D[0, q] = st[q]
    n2 = nm * nm
    for k in range(1, 5):
        D[k, 0] = D[k - 1, 3]
        D[k, 1] = D[k - 1, 4]
        D[k, 2] = D[k - 1, 5]
        D[k, 3] = 3.0 * n2 * D[k - 1, 0] + 2.0 * nm * D[k - 1, 4]
        D[k, 4] = -2.0 * nm * D[k - 1, 3]
        D[k, 5] = -n2 * D[k - 1, 2]
        if k == 1:  # before D[2..4] are derived from D[1]
            D[1, 3] += f[0]
            D[1, 4] += f[1]
            D[1, 5] += f[2]


@njit(cache=True, error_model="numpy")
def _eval(D, tau, out):
    """State at ``tau`` from the Taylor coefficients (Horner), and r'(tau), r''(tau)."""
    for q in range(6):
        out[q] = D[0, q] + tau * (D[1, q] + tau / 2.0 * (D[2, q] + tau / 3.0 * (
            D[3, q] + tau / 4.0 * D[4, q])))
    for q in range(3):
        out[6 + q] = D[1, q] + tau * (D[2, q] + tau / 2.0 * (D[3, q] + tau / 3.0 * D[4, q]))
        out[9 + q] = D[2, q] + tau * (D[3, q] + tau / 2.0 * D[4, q])


@njit(cache=True, error_model="numpy")
def _newton_cross(D, lo, hi, rs2, out):
    """First root of ``F(tau) = |r(tau)|^2 - r_stop^2`` in ``(lo, hi]`` (F(lo) > 0 >= F(hi)):
    Newton from the regula-falsi point, kept inside the shrinking bracket."""
    _eval(D, lo, out)
    f_lo = out[0] ** 2 + out[1] ** 2 + out[2] ** 2 - rs2
    _eval(D, hi, out)
    f_hi = out[0] ** 2 + out[1] ** 2 + out[2] ** 2 - rs2
    tau = lo + (hi - lo) * f_lo / (f_lo - f_hi)
    for _ in range(60):
        _eval(D, tau, out)
        F = out[0] ** 2 + out[1] ** 2 + out[2] ** 2 - rs2
        dF = 2.0 * (out[0] * out[6] + out[1] * out[7] + out[2] * out[8])
        if F > 0.0:
            lo = tau
        else:
            hi = tau
        new = tau - F / dF if dF != 0.0 else 0.5 * (lo + hi)
        if not (lo <= new <= hi):
            new = 0.5 * (lo + hi)
        # F is resolved to a few ulps of r_stop^2: stop there, or at round-off step/bracket
        tol = 1e-15 * (1.0 + abs(tau))
        if abs(new - tau) <= tol or hi - lo <= tol or abs(F) <= 8.0 * EPS * rs2:
            tau = new
            break
        tau = new
    return tau


@njit(cache=True, error_model="numpy")
def _newton_min(D, hi, out):
    """Root of ``G(tau) = r . r'`` in ``(0, hi)`` with ``G(0) < 0 < G(hi)``: the time of the
    range minimum inside a step."""
    lo = 0.0
    tau = 0.5 * hi
    for _ in range(60):
        _eval(D, tau, out)
        G = out[0] * out[6] + out[1] * out[7] + out[2] * out[8]
        dG = (out[6] ** 2 + out[7] ** 2 + out[8] ** 2
              + out[0] * out[9] + out[1] * out[10] + out[2] * out[11])
        if G < 0.0:
            lo = tau
        else:
            hi = tau
        new = tau - G / dG if dG > 0.0 else 0.5 * (lo + hi)
        if not (lo <= new <= hi):
            new = 0.5 * (lo + hi)
        tol = 1e-15 * (1.0 + abs(tau))
        if abs(new - tau) <= tol or hi - lo <= tol:
            tau = new
            break
        tau = new
    return tau


BLOCK = 64
"""Samples per parallel task; they advance in lockstep (see :func:`_simulate_block`)."""

# per-sample scalars of a block, rows of ``lane (N_LANE, BLOCK)`` (the samples along a row, so
# the per-step updates of pass 2 run unit stride)
L_DV, L_ACMAX, L_TSURF, L_TSET, L_PABS, L_POM, L_THR = range(7)
N_LANE = 7


@njit(cache=True, error_model="numpy", parallel=True)
def simulate_numba(r0, v0, at, bR, bw, p, K, max_steps, col, buf, sc, status):
    """Run the FTCAPN closed loop for a batch, filling ``buf``, ``sc`` and ``status`` in place,
    in parallel blocks of ``BLOCK`` samples.

    ``r0``, ``v0 (n, 3)``: the initial line of sight ``r = target - chaser`` [m] and its rate
    [m/s]; ``at (n, 3)``: the target acceleration [m/s^2], fixed, or (``P_ROTATING``) along
    ``e_theta, e_r, e_w`` of each step's true LOS frame; ``bR``, ``bw (n,)``: range [m] and
    LOS-rate [rad/s] measurement biases; ``p``: the constants (``P_*`` of :mod:`.layout`);
    ``K``: the last grid index (grid ``k dt``); ``max_steps``: the steps before a sample fails
    for exceeding ``t_max``; ``col (N_SERIES,)``: each series' first row in ``buf (C, n, K+1)``
    (-1: not recorded), where ``buf[col[S] + q, i, k]`` is component ``q`` of series ``S`` of
    sample ``i`` at ``k dt`` (a stopped sample keeps its stop state's values).
    """
    n = r0.shape[0]
    for b in prange((n + BLOCK - 1) // BLOCK):
        _simulate_block(b * BLOCK, min(n, (b + 1) * BLOCK), r0, v0, at, bR, bw, p, K,
                        max_steps, col, buf, sc, status)


@njit(cache=True, error_model="numpy")
def _finish(i, lane, l, code, sc, status):
    status[i] = code
    sc[i, K_DV] = lane[L_DV, l]
    sc[i, K_TSURF] = lane[L_TSURF, l]
    sc[i, K_TSETTLE] = lane[L_TSET, l]
    sc[i, K_ACMAX] = lane[L_ACMAX, l]


@njit(cache=True, error_model="numpy")
def _stop_in_step(i, j, hi, st_row, f, ac_row, acr, act, acn, lane, l, p, bR_i, K, col, buf,
                  sc, D, ev):
    """The sample crosses r_stop inside step ``j`` (before ``t_j + hi``): locate the crossing,
    record the stop state on the rest of the grid, write its scalars. ``acr, act, acn``: the
    step's command along the LOS frame and its magnitude."""
    c_, delta, dt, rstop, nm = p[P_C], p[P_DELTA], p[P_DT], p[P_RSTOP], p[P_NMEAN]
    t = j * dt
    _derivatives(st_row, f, nm, D)
    tau = _newton_cross(D, 0.0, hi, rstop * rstop, ev)
    _eval(D, tau, ev)
    for q in range(6):
        st_row[q] = ev[q]
    lane[L_DV, l] += acn * tau
    lane[L_ACMAX, l] = max(lane[L_ACMAX, l], acn)
    R = math.sqrt(st_row[0] * st_row[0] + st_row[1] * st_row[1] + st_row[2] * st_row[2])
    iR = 1.0 / R
    Rdot = (st_row[0] * st_row[3] + st_row[1] * st_row[4] + st_row[2] * st_row[5]) * iR
    vpx = st_row[3] - Rdot * (st_row[0] * iR)
    vpy = st_row[4] - Rdot * (st_row[1] * iR)
    vpz = st_row[5] - Rdot * (st_row[2] * iR)
    om = math.sqrt(vpx * vpx + vpy * vpy + vpz * vpz) * iR
    s = c_ * (R + bR_i) + Rdot
    pa, po, thr = lane[L_PABS, l], lane[L_POM, l], lane[L_THR, l]
    if lane[L_TSURF, l] != lane[L_TSURF, l] and abs(s) <= delta:
        lane[L_TSURF, l] = t + tau * (pa - delta) / (pa - abs(s))
    if om > thr:
        lane[L_TSET, l] = np.nan
    elif po > thr:
        lane[L_TSET, l] = t + tau * (po - thr) / (po - om)
    if j + 1 <= K:
        _record(buf, i, j + 1, K + 1, col, st_row[0], st_row[1], st_row[2], st_row[3],
                st_row[4], st_row[5], R, Rdot, om, s, ac_row[0], ac_row[1], ac_row[2],
                acr, act, lane[L_DV, l])
    sc[i, K_TSTOP] = t + tau
    for q in range(3):
        sc[i, K_RS + q] = st_row[q]
        sc[i, K_VS + q] = st_row[3 + q]


# rows of the per-step work array ``W (N_W, m)`` of a block (structure of arrays: one row per
# quantity, the samples along it, so the branch-free pass below reads and writes unit stride)
(W_R, W_IR, W_RDOT, W_ERX, W_ERY, W_ERZ, W_VPX, W_VPY, W_VPZ, W_VT, W_OM, W_S, W_ABS,
 W_POW, W_ACR, W_ACT, W_ACN, W_IV, W_FX, W_FY, W_FZ) = range(21)
N_W = 21


# Pass 1 is written as short loops, each storing at most three work rows: the loop
# vectoriser checks at run time that a loop's stores do not overlap its loads, and gives up
# beyond a few pointers (one fused loop storing all rows ran 4x slower than this split).
@njit(cache=True, error_model="numpy")
def _kinematics(m, st, W, bR, i0, c_):
    """LOS quantities of every lane's state (branch-free, unit stride: vectorised)."""
    for l in range(m):
        x, y, z = st[0, l], st[1, l], st[2, l]
        R = math.sqrt(x * x + y * y + z * z)
        iR = 1.0 / R
        W[W_R, l] = R
        W[W_IR, l] = iR
        W[W_RDOT, l] = (x * st[3, l] + y * st[4, l] + z * st[5, l]) * iR
    for l in range(m):
        iR = W[W_IR, l]
        W[W_ERX, l] = st[0, l] * iR
        W[W_ERY, l] = st[1, l] * iR
        W[W_ERZ, l] = st[2, l] * iR
    for l in range(m):
        Rdot = W[W_RDOT, l]
        W[W_VPX, l] = st[3, l] - Rdot * W[W_ERX, l]
        W[W_VPY, l] = st[4, l] - Rdot * W[W_ERY, l]
        W[W_VPZ, l] = st[5, l] - Rdot * W[W_ERZ, l]
    for l in range(m):
        vpx, vpy, vpz = W[W_VPX, l], W[W_VPY, l], W[W_VPZ, l]
        Vt = math.sqrt(vpx * vpx + vpy * vpy + vpz * vpz)
        W[W_VT, l] = Vt
        W[W_OM, l] = Vt * W[W_IR, l]
    for l in range(m):
        s = c_ * (W[W_R, l] + bR[i0 + l]) + W[W_RDOT, l]
        W[W_S, l] = s
        W[W_ABS, l] = abs(s)


@njit(cache=True, error_model="numpy")
def _command(m, W, ac, bR, bw, i0, c_, eps, beta, Nn, asat, delta, idelta):
    """The saturated FTCAPN command of every lane (selects, not branches)."""
    for l in range(m):
        s = W[W_S, l]
        sg = s * idelta if W[W_ABS, l] < delta else (1.0 if s > 0.0 else -1.0)
        Rm = W[W_R, l] + bR[i0 + l]
        omm = W[W_OM, l] + bw[i0 + l]
        Rdot = W[W_RDOT, l]
        u = -c_ * Rdot - eps * sg - beta * W[W_POW, l] * sg - Rm * omm * omm
        u = asat if u > asat else (-asat if u < -asat else u)
        W[W_ACR, l] = -u
        W[W_ACT, l] = -Nn * Rdot * omm if W[W_VT, l] > 0.0 else 0.0
    # one store per loop: with the three components in one loop it ran scalar
    for l in range(m):
        Vt = W[W_VT, l]
        W[W_IV, l] = W[W_ACT, l] / Vt if Vt > 0.0 else 0.0
    for q in range(3):
        for l in range(m):
            a = W[W_ACR, l] * W[W_ERX + q, l]
            ac[q, l] = a + W[W_IV, l] * W[W_VPX + q, l] if W[W_VT, l] > 0.0 else a
    for l in range(m):
        acr, act = W[W_ACR, l], W[W_ACT, l]
        W[W_ACN, l] = math.sqrt(acr * acr + act * act)


@njit(cache=True, error_model="numpy")
def _forcing(m, W, ac, at, i0, rotating):
    """Net forcing ``f = a_t - a_c`` held over the step, every lane."""
    if rotating:
        for l in range(m):
            i = i0 + l
            erx, ery, erz = W[W_ERX, l], W[W_ERY, l], W[W_ERZ, l]
            # components along e_theta, e_r, e_w of this step's LOS frame (e_w = e_r x
            # e_theta); without a transverse velocity only the radial part is defined
            a_t, a_r, a_w = at[i, 0], at[i, 1], at[i, 2]
            tx, ty, tz = a_r * erx, a_r * ery, a_r * erz
            Vt = W[W_VT, l]
            if Vt > 0.0:
                iVt = 1.0 / Vt
                etx, ety, etz = W[W_VPX, l] * iVt, W[W_VPY, l] * iVt, W[W_VPZ, l] * iVt
                tx += a_t * etx + a_w * (ery * etz - erz * ety)
                ty += a_t * ety + a_w * (erz * etx - erx * etz)
                tz += a_t * etz + a_w * (erx * ety - ery * etx)
            W[W_FX, l] = tx - ac[0, l]
            W[W_FY, l] = ty - ac[1, l]
            W[W_FZ, l] = tz - ac[2, l]
    else:
        for l in range(m):
            i = i0 + l
            W[W_FX, l] = at[i, 0] - ac[0, l]
            W[W_FY, l] = at[i, 1] - ac[1, l]
            W[W_FZ, l] = at[i, 2] - ac[2, l]


@njit(cache=True, error_model="numpy")
def _propagate(m, st, nst, W, dt, hdt, nm, nx, f, D, ev):
    """State ``nst`` at the step's end for every lane: the exact quadratic without gravity
    (vectorisable), the Taylor polynomial of the Hill flow otherwise."""
    if nm == 0.0:
        for l in range(m):
            nst[0, l] = st[0, l] + dt * (st[3, l] + hdt * W[W_FX, l])
            nst[1, l] = st[1, l] + dt * (st[4, l] + hdt * W[W_FY, l])
            nst[2, l] = st[2, l] + dt * (st[5, l] + hdt * W[W_FZ, l])
        for l in range(m):
            nst[3, l] = st[3, l] + dt * W[W_FX, l]
            nst[4, l] = st[4, l] + dt * W[W_FY, l]
            nst[5, l] = st[5, l] + dt * W[W_FZ, l]
    else:
        for l in range(m):
            for q in range(6):
                nx[q] = st[q, l]
            f[0], f[1], f[2] = W[W_FX, l], W[W_FY, l], W[W_FZ, l]
            _derivatives(nx, f, nm, D)
            _eval(D, dt, ev)
            for q in range(6):
                nst[q, l] = ev[q]


@njit(cache=True, error_model="numpy")
def _record_step(buf, i0, m, j, col, st, W, ac, lane, running):
    """Grid row ``j`` of every running lane, one loop per series component: the same values
    as :func:`_record`, without its per-sample dispatch on the series."""
    c = col[S_W]
    if c >= 0:
        for l in range(m):
            if running[l]:
                w0, w1, w2 = _los_rate(st[0, l], st[1, l], st[2, l], st[3, l], st[4, l],
                                       st[5, l], W[W_R, l])
                _put3(buf, c, i0 + l, j, w0, w1, w2)
    for sr, wr in ((S_OMEGA, W_OM), (S_R, W_R), (S_RDOT, W_RDOT), (S_S, W_S)):
        put_lanes(buf, col[sr], i0, j, W, wr, 1, m, running)
    put_lanes(buf, col[S_AC], i0, j, ac, 0, 3, m, running)
    c = col[S_ACLOS]
    if c >= 0:
        for l in range(m):
            if running[l]:
                _put3(buf, c, i0 + l, j, W[W_ACR, l], W[W_ACT, l], 0.0)
    put_lanes(buf, col[S_DV], i0, j, lane, L_DV, 1, m, running)
    put_lanes(buf, col[S_POS], i0, j, st, 0, 3, m, running)
    put_lanes(buf, col[S_VEL], i0, j, st, 3, 3, m, running)
    c = col[S_SPEED]
    if c >= 0:
        for l in range(m):
            if running[l]:
                buf[c, i0 + l, j] = _speed(st[3, l], st[4, l], st[5, l])


@njit(cache=True, error_model="numpy")
def _end_of_step(i, l, j, st, nst, W, ac, lane, p, bR, K, col, buf, sc, status, nx, f, D,
                 ev, acr_l):
    """The end of step ``j`` of running lane ``l`` (sample ``i``; ``st`` the state at the step's
    start, ``nst`` at its end): the failure test, the stop inside the step (``st`` <- the stop
    state), else the step's delta-v. True if it stopped."""
    dt, rstop, nm = p[P_DT], p[P_RSTOP], p[P_NMEAN]
    rs2 = rstop * rstop
    t = j * dt
    n0, n1, n2 = nst[0, l], nst[1, l], nst[2, l]
    n3, n4, n5 = nst[3, l], nst[4, l], nst[5, l]
    Rn2 = n0 * n0 + n1 * n1 + n2 * n2
    # one test for all six: a NaN or infinity anywhere makes the sum non-finite
    if not math.isfinite(Rn2 + n3 * n3 + n4 * n4 + n5 * n5):
        sc[i, K_TFAIL] = t + dt
        for k in range(j + 1, K + 1):
            for q in range(buf.shape[0]):
                buf[q, i, k] = np.nan
        _finish(i, lane, l, ST_NONFINITE, sc, status)
        return True
    cross = Rn2 <= rs2
    hi = dt
    passing = W[W_RDOT, l] < 0.0 and (n0 * n3 + n1 * n4 + n2 * n5) > 0.0
    if cross or passing:
        for q in range(6):
            nx[q] = st[q, l]
        f[0], f[1], f[2] = W[W_FX, l], W[W_FY, l], W[W_FZ, l]
    if not cross and passing:
        # The range has a minimum inside the step: a pass that may dip below r_stop.
        _derivatives(nx, f, nm, D)
        tm = _newton_min(D, dt, ev)
        _eval(D, tm, ev)
        if ev[0] ** 2 + ev[1] ** 2 + ev[2] ** 2 <= rs2:
            cross = True
            hi = tm
    if cross:
        for q in range(3):
            acr_l[q] = ac[q, l]
        _stop_in_step(i, j, hi, nx, f, acr_l, W[W_ACR, l], W[W_ACT, l], W[W_ACN, l], lane, l,
                      p, bR[i], K, col, buf, sc, D, ev)
        for q in range(6):
            st[q, l] = nx[q]
        _finish(i, lane, l, ST_OK, sc, status)
        return True
    lane[L_DV, l] += W[W_ACN, l] * dt
    lane[L_ACMAX, l] = max(lane[L_ACMAX, l], W[W_ACN, l])
    return False


@njit(cache=True, error_model="numpy")
def _simulate_block(i0, i1, r0, v0, at, bR, bw, p, K, max_steps, col, buf, sc, status):
    """Samples ``i0 .. i1-1`` in lockstep, one step at a time in two passes: pass 1 branch-free
    over every lane on structure-of-arrays work rows, pass 2 the running lanes' events, records
    and stop tests (docs/performance.md#the-ftcapn-kernel)."""
    c_, eps, beta, eta, Nn = p[P_C], p[P_EPS], p[P_BETA], p[P_ETA], p[P_N]
    asat, delta, dt, rstop = p[P_ASAT], p[P_DELTA], p[P_DT], p[P_RSTOP]
    nm, settle, control = p[P_NMEAN], p[P_SETTLE], p[P_CONTROL] != 0.0
    rotating = p[P_ROTATING] != 0.0
    rs2 = rstop * rstop
    hdt = 0.5 * dt
    idelta = 1.0 / delta
    m = i1 - i0
    st = np.empty((6, m))
    nst = np.empty((6, m))
    ac = np.zeros((3, m))
    # zeros: without control the command rows stay zero, the held command of the records
    W = np.zeros((N_W, m))
    lane = np.zeros((N_LANE, m))
    running = np.ones(m, dtype=np.bool_)
    flag = np.zeros(m, dtype=np.bool_)
    nx = np.empty(6)
    f = np.empty(3)
    D = np.zeros((5, 6))
    ev = np.empty(12)
    acr_l = np.empty(3)
    nan = np.nan
    for l in range(m):
        i = i0 + l
        for q in range(3):
            st[q, l] = r0[i, q]
            st[3 + q, l] = v0[i, q]
        sc[i, :] = nan
        lane[L_TSURF, l] = nan
        lane[L_TSET, l] = nan
    n_running = m
    for j in range(max_steps + 1):
        t = j * dt
        # ---- pass 1: every lane, no branches on the sample
        _kinematics(m, st, W, bR, i0, c_)
        if control:
            for l in range(m):
                W[W_POW, l] = W[W_ABS, l] ** eta
            _command(m, W, ac, bR, bw, i0, c_, eps, beta, Nn, asat, delta, idelta)
        _forcing(m, W, ac, at, i0, rotating)
        _propagate(m, st, nst, W, dt, hdt, nm, nx, f, D, ev)
        # ---- pass 2: the running lanes' events, records and stop tests
        if 0 < j < max_steps:
            # Every lane, selects instead of branches; the values of stopped lanes are
            # computed and dropped (their lane rows are no longer read).
            for l in range(m):
                abs_s = W[W_ABS, l]
                pa = lane[L_PABS, l]
                ts = lane[L_TSURF, l]
                cand = t - dt + dt * (pa - delta) / (pa - abs_s)
                lane[L_TSURF, l] = cand if (ts != ts) & (abs_s <= delta) else ts
                lane[L_PABS, l] = abs_s
            for l in range(m):
                om = W[W_OM, l]
                thr = lane[L_THR, l]
                po = lane[L_POM, l]
                cand = t - dt + dt * (po - thr) / (po - om)
                lane[L_TSET, l] = nan if om > thr else (cand if po > thr else lane[L_TSET, l])
                lane[L_POM, l] = om
            if j <= K:
                _record_step(buf, i0, m, j, col, st, W, ac, lane, running)
            n_flag = 0
            for l in range(m):
                n0, n1, n2 = nst[0, l], nst[1, l], nst[2, l]
                n3, n4, n5 = nst[3, l], nst[4, l], nst[5, l]
                Rn2 = n0 * n0 + n1 * n1 + n2 * n2
                # not finite (NaN compares false), in the stop range, or past the range minimum
                odd = ((not (abs(Rn2 + n3 * n3 + n4 * n4 + n5 * n5) < math.inf))
                       | (Rn2 <= rs2)
                       | ((W[W_RDOT, l] < 0.0) & ((n0 * n3 + n1 * n4 + n2 * n5) > 0.0)))
                r_ = running[l]
                flag[l] = r_ & odd
                n_flag += r_ & odd
                u_ = r_ & (not odd)
                acn = W[W_ACN, l]
                dv = lane[L_DV, l]
                amax = lane[L_ACMAX, l]
                lane[L_DV, l] = dv + acn * dt if u_ else dv
                lane[L_ACMAX, l] = max(amax, acn) if u_ else amax
            if n_flag > 0:
                for l in range(m):
                    if flag[l]:
                        if _end_of_step(i0 + l, l, j, st, nst, W, ac, lane, p, bR, K, col, buf, sc,
                                        status, nx, f, D, ev, acr_l):
                            running[l] = False
                            n_running -= 1
        else:
            for l in range(m):
                if not running[l]:
                    continue
                i = i0 + l
                x, y, z = st[0, l], st[1, l], st[2, l]
                vx, vy, vz = st[3, l], st[4, l], st[5, l]
                R = W[W_R, l]
                Rdot = W[W_RDOT, l]
                om = W[W_OM, l]
                s = W[W_S, l]
                abs_s = W[W_ABS, l]
                if j == 0:
                    lane[L_THR, l] = settle * om
                    if abs_s <= delta:
                        lane[L_TSURF, l] = 0.0
                    if om <= lane[L_THR, l]:
                        lane[L_TSET, l] = 0.0
                    if R <= rstop:
                        # Already inside the stop range: stopped at t = 0, no control applied.
                        _record(buf, i, 0, K + 1, col, x, y, z, vx, vy, vz, R, Rdot, om, s,
                                0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
                        sc[i, K_TSTOP] = 0.0
                        for q in range(3):
                            sc[i, K_RS + q] = st[q, l]
                            sc[i, K_VS + q] = st[3 + q, l]
                        _finish(i, lane, l, ST_OK, sc, status)
                        running[l] = False
                        n_running -= 1
                        continue
                else:
                    if lane[L_TSURF, l] != lane[L_TSURF, l] and abs_s <= delta:
                        pa = lane[L_PABS, l]
                        lane[L_TSURF, l] = t - dt + dt * (pa - delta) / (pa - abs_s)
                    thr = lane[L_THR, l]
                    po = lane[L_POM, l]
                    if om > thr:
                        lane[L_TSET, l] = nan
                    elif po > thr:
                        lane[L_TSET, l] = t - dt + dt * (po - thr) / (po - om)
                lane[L_PABS, l] = abs_s
                lane[L_POM, l] = om
                if j <= K:
                    _record(buf, i, j, j + 1, col, x, y, z, vx, vy, vz, R, Rdot, om, s,
                            ac[0, l], ac[1, l], ac[2, l], W[W_ACR, l], W[W_ACT, l],
                            lane[L_DV, l])
                if j >= max_steps:
                    sc[i, K_TFAIL] = t
                    _finish(i, lane, l, ST_TMAX, sc, status)
                    running[l] = False
                    n_running -= 1
                    continue
                if _end_of_step(i, l, j, st, nst, W, ac, lane, p, bR, K, col, buf, sc, status,
                                nx, f, D, ev, acr_l):
                    running[l] = False
                    n_running -= 1
        if n_running == 0:
            break
        # The new state is the next step's; a stopped lane keeps its frozen state (the
        # running ones were advanced in nst, which beats a masked copy of six rows).
        for l in range(m):
            if not running[l]:
                for q in range(6):
                    nst[q, l] = st[q, l]
        st, nst = nst, st
