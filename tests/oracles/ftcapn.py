"""NumPy oracle of the FTCAPN closed loop (``uqguide/models/ftcapn/kernel_numba.py``),
vectorised over the samples of a chunk.

Per step ``j`` (time ``t_j = j dt``), for every sample still running:

1. LOS quantities of the true state (spec section 1): ``R = |r|``, ``Rdot = r.v / R``,
   transverse velocity ``v_perp = v - Rdot e_r``, ``omega_s = |v_perp| / R``,
   ``e_theta = v_perp / |v_perp|`` (the rotating LOS frame of eq 1).
2. Measured ``R_m = R + b_R``, ``omega_m = omega_s + b_w``; sliding variable
   ``s = c R_m + Rdot`` (eq 4 with ``r_f = rdot_f = 0``).
3. Command (spec section 3, eqs 5, 6, 13, 14)::

       u = clip(-c Rdot - eps sgn_d(s) - beta |s|^eta sgn_d(s) - R_m omega_m^2, +-A_sat)
       a_c = -u e_r - N Rdot omega_m e_theta           (zero transverse part if omega_s = 0)

   The target's acceleration ``at`` is a fixed vector, or (``P_ROTATING``) its components
   along ``e_theta, e_r, e_w`` of the step's true LOS frame, held over the step like the command.
4. Zero-order hold over the step, RK4 on ``r'' = a_t - a_c + g(r, v)``. For this linear system
   with constant forcing RK4 *is* the degree-4 Taylor polynomial of the exact flow, computed
   from the state derivatives ``D_k`` (:func:`_derivatives`); with ``g = 0`` it is the exact
   quadratic ``r + v dt + f dt^2 / 2``. The same polynomial in ``tau in [0, dt]`` is the
   motion inside the step, used to locate the stop.
5. Stop: the first ``tau`` with ``|r(tau)| = r_stop`` -- safeguarded Newton on
   ``|r(tau)|^2 - r_stop^2``, bracketed by the step end or, when the range has a minimum inside
   the step (``Rdot`` changes sign), by that minimum. The sample is then frozen: its series keep
   the stop state's values (range, range rate, LOS rate, ``s``) and the last held command.

Arrays (see :mod:`uqguide.models.ftcapn.layout`): ``r0, v0, at (n, 3)``, ``bR, bw (n,)``,
``p (N_PARAMS,)``, ``col (N_SERIES,)``; outputs ``buf (C, n, K+1)``, ``sc (n, N_KSCALARS)``,
``status (n,)``, filled in place. ``K`` is the last grid index (grid ``k dt``, ``k = 0..K``),
``max_steps`` the number of steps before a sample fails for exceeding ``t_max``.
"""

from __future__ import annotations

import numpy as np

from uqguide.models.ftcapn.layout import (
    K_ACMAX, K_DV, K_RS, K_TFAIL, K_TSETTLE, K_TSTOP, K_TSURF, K_VS, P_ASAT, P_BETA, P_C,
    P_CONTROL, P_DELTA, P_ROTATING, P_DT, P_EPS, P_ETA, P_N, P_NMEAN, P_RSTOP, P_SETTLE, S_AC,
    S_ACLOS, S_DV, S_OMEGA, S_POS, S_R, S_RDOT, S_S, S_SPEED, S_VEL, S_W, ST_NONFINITE, ST_OK,
    ST_TMAX,
)

CHUNK = 8192
"""Samples per chunk. Measured on a 2-core EPYC: 512 -> 20k, 2048 -> 34k, 8192 -> 41k
samples/s (per-call overhead dominates below ~4k; ~40 work arrays of 64 kB stay in cache)."""


def _derivatives(X: np.ndarray, f: np.ndarray, nm: float) -> np.ndarray:
    """Taylor coefficients ``D (5, 6, m)``: k-th time derivatives of the state ``X (6, m)``
    under ``r'' = g(r, v) + f`` (``f (3, m)`` constant, ``g`` the Hill terms; zero if nm = 0)."""
    D = np.empty((5,) + X.shape)
    D[0] = X
    n2 = nm * nm
    for k in range(1, 5):
        P = D[k - 1]
        D[k, 0:3] = P[3:6]
        D[k, 3] = 3.0 * n2 * P[0] + 2.0 * nm * P[4]
        D[k, 4] = -2.0 * nm * P[3]
        D[k, 5] = -n2 * P[2]
        if k == 1:
            D[1, 3:6] += f  # before D[2..4] are derived from D[1]
    return D


def _eval(D: np.ndarray, tau: np.ndarray | float):
    """State ``(6, m)``, ``r'(tau)`` and ``r''(tau)`` ``(3, m)`` from the coefficients (Horner)."""
    X = D[0] + tau * (D[1] + tau / 2.0 * (D[2] + tau / 3.0 * (D[3] + tau / 4.0 * D[4])))
    d1 = D[1, 0:3] + tau * (D[2, 0:3] + tau / 2.0 * (D[3, 0:3] + tau / 3.0 * D[4, 0:3]))
    d2 = D[2, 0:3] + tau * (D[3, 0:3] + tau / 2.0 * D[4, 0:3])
    return X, d1, d2


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _newton_cross(D: np.ndarray, lo: np.ndarray, hi: np.ndarray, rs2: float) -> np.ndarray:
    """First root of ``|r(tau)|^2 - r_stop^2`` in ``(lo, hi]`` for each column of ``D``."""
    lo, hi = lo.copy(), hi.copy()
    X, _, _ = _eval(D, lo)
    f_lo = _dot(X, X) - rs2
    X, _, _ = _eval(D, hi)
    f_hi = _dot(X, X) - rs2
    tau = lo + (hi - lo) * f_lo / (f_lo - f_hi)
    done = np.zeros(tau.shape, dtype=bool)
    for _ in range(60):
        X, d1, _ = _eval(D, tau)
        F = _dot(X, X) - rs2
        dF = 2.0 * _dot(X, d1)
        pos = F > 0.0
        lo = np.where(pos & ~done, tau, lo)
        hi = np.where(~pos & ~done, tau, hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = np.where(dF != 0.0, tau - F / dF, 0.5 * (lo + hi))
        new = np.where((lo <= new) & (new <= hi), new, 0.5 * (lo + hi))
        # F is resolved to a few ulps of r_stop^2 (|r| to ~1e-14 m): stop there, or when the
        # step or the bracket is at round-off level
        tol = 1e-15 * (1.0 + np.abs(tau))
        conv = ((np.abs(new - tau) <= tol) | (hi - lo <= tol)
                | (np.abs(F) <= 8.0 * np.finfo(float).eps * rs2))
        tau = np.where(done, tau, new)
        done |= conv
        if done.all():
            break
    return tau


def _newton_min(D: np.ndarray, hi: float) -> np.ndarray:
    """Root of ``r . r'`` in ``(0, hi)`` (the range minimum inside the step) per column."""
    m = D.shape[2]
    lo = np.zeros(m)
    hi_ = np.full(m, hi)
    tau = 0.5 * hi_
    done = np.zeros(m, dtype=bool)
    for _ in range(60):
        X, d1, d2 = _eval(D, tau)
        G = _dot(X, d1)
        dG = _dot(d1, d1) + _dot(X, d2)
        neg = G < 0.0
        lo = np.where(neg & ~done, tau, lo)
        hi_ = np.where(~neg & ~done, tau, hi_)
        with np.errstate(divide="ignore", invalid="ignore"):
            new = np.where(dG > 0.0, tau - G / dG, 0.5 * (lo + hi_))
        new = np.where((lo <= new) & (new <= hi_), new, 0.5 * (lo + hi_))
        tol = 1e-15 * (1.0 + np.abs(tau))
        conv = (np.abs(new - tau) <= tol) | (hi_ - lo <= tol)
        tau = np.where(done, tau, new)
        done |= conv
        if done.all():
            break
    return tau


def _record(buf, rows, k, col, X, R, Rdot, om, s, ac, acr, act, dv) -> None:
    """Write grid row(s) ``k`` (int or slice) of the samples ``rows``; values are ``(m,)``."""
    kk = k if isinstance(k, slice) else slice(k, k + 1)

    def put(c: int, val) -> None:
        buf[c, rows, kk] = np.asarray(val)[:, None]

    x, y, z, vx, vy, vz = X
    if col[S_OMEGA] >= 0:
        put(col[S_OMEGA], om)
    if col[S_W] >= 0:
        R2 = R * R
        put(col[S_W], (y * vz - z * vy) / R2)
        put(col[S_W] + 1, (z * vx - x * vz) / R2)
        put(col[S_W] + 2, (x * vy - y * vx) / R2)
    if col[S_R] >= 0:
        put(col[S_R], R)
    if col[S_RDOT] >= 0:
        put(col[S_RDOT], Rdot)
    if col[S_S] >= 0:
        put(col[S_S], s)
    if col[S_AC] >= 0:
        for q in range(3):
            put(col[S_AC] + q, ac[q])
    if col[S_ACLOS] >= 0:
        put(col[S_ACLOS], acr)
        put(col[S_ACLOS] + 1, act)
        put(col[S_ACLOS] + 2, np.zeros_like(acr))
    if col[S_DV] >= 0:
        put(col[S_DV], dv)
    if col[S_POS] >= 0:
        for q in range(3):
            put(col[S_POS] + q, X[q])
    if col[S_VEL] >= 0:
        for q in range(3):
            put(col[S_VEL] + q, X[3 + q])
    if col[S_SPEED] >= 0:
        put(col[S_SPEED], np.sqrt(vx * vx + vy * vy + vz * vz))


def _los(X: np.ndarray, bR: np.ndarray, c_: float):
    """R, Rdot, e_r (3, m), v_perp (3, m), |v_perp|, omega_s and s of states ``X (6, m)``."""
    R = np.sqrt(_dot(X[0:3], X[0:3]))
    iR = 1.0 / R
    Rdot = _dot(X[0:3], X[3:6]) * iR
    er = X[0:3] * iR
    vp = X[3:6] - Rdot * er
    Vt = np.sqrt(_dot(vp, vp))
    om = Vt * iR
    s = c_ * (R + bR) + Rdot
    return R, Rdot, er, vp, Vt, om, s


def simulate_numpy(r0, v0, at, bR, bw, p, K, max_steps, col, buf, sc, status, chunk=CHUNK):
    """Run the FTCAPN closed loop for a batch, filling ``buf``, ``sc`` and ``status`` in place.

    Parameters
    ----------
    r0, v0 : ndarray, shape (n, 3)
        Initial line of sight ``r = target - chaser`` [m] and its rate [m/s].
    at : ndarray, shape (n, 3)
        Target acceleration [m/s^2], constant in the simulation frame.
    bR, bw : ndarray, shape (n,)
        Range [m] and LOS-rate [rad/s] measurement biases.
    p : ndarray, shape (N_PARAMS,)
        Constants (indices ``P_*`` of :mod:`.layout`).
    K, max_steps : int
        Last grid index; number of steps allowed (``t_max / dt``).
    col : ndarray of int, shape (N_SERIES,)
        First row of each series in ``buf`` (-1: not recorded).
    buf : ndarray, shape (C, n, K+1)
        Series columns: ``buf[col[S] + q, i, k]`` is component ``q`` of series ``S`` of
        sample ``i`` at grid time ``k dt``.
    sc : ndarray, shape (n, N_KSCALARS)
    status : ndarray of int8, shape (n,)
    """
    n = r0.shape[0]
    for lo in range(0, n, chunk):
        hi = min(n, lo + chunk)
        _simulate_chunk(np.arange(lo, hi), r0[lo:hi], v0[lo:hi], at[lo:hi], bR[lo:hi],
                        bw[lo:hi], p, K, max_steps, col, buf, sc, status)


def _simulate_chunk(idx, r0, v0, at, bR, bw, p, K, max_steps, col, buf, sc, status) -> None:
    c_, eps, beta, eta, Nn = p[P_C], p[P_EPS], p[P_BETA], p[P_ETA], p[P_N]
    asat, delta, dt, rstop = p[P_ASAT], p[P_DELTA], p[P_DT], p[P_RSTOP]
    nm, settle, control = p[P_NMEAN], p[P_SETTLE], p[P_CONTROL] != 0.0
    rotating = p[P_ROTATING] != 0.0
    rs2 = rstop * rstop
    hdt = 0.5 * dt
    m = idx.shape[0]
    X = np.concatenate([r0.T, v0.T])  # (6, m): one contiguous row per component
    at = np.ascontiguousarray(at.T)
    sc[idx] = np.nan
    status[idx] = ST_TMAX
    dv = np.zeros(m)
    acmax = np.zeros(m)
    t_surf = np.full(m, np.nan)
    t_set = np.full(m, np.nan)
    prev_abs_s = np.zeros(m)
    prev_om = np.zeros(m)
    thr = np.zeros(m)
    ac = np.zeros((3, m))
    acr = np.zeros(m)
    act = np.zeros(m)
    acn = np.zeros(m)

    def keep(mask: np.ndarray) -> None:
        nonlocal idx, X, at, bR, bw, dv, acmax, t_surf, t_set, prev_abs_s, prev_om, thr
        idx, X, at, bR, bw = idx[mask], X[:, mask], at[:, mask], bR[mask], bw[mask]
        dv, acmax, t_surf, t_set = dv[mask], acmax[mask], t_surf[mask], t_set[mask]
        prev_abs_s, prev_om, thr = prev_abs_s[mask], prev_om[mask], thr[mask]

    def finish(mask: np.ndarray) -> None:
        rows = idx[mask]
        sc[rows, K_DV] = dv[mask]
        sc[rows, K_TSURF] = t_surf[mask]
        sc[rows, K_TSETTLE] = t_set[mask]
        sc[rows, K_ACMAX] = acmax[mask]

    j = 0
    while idx.size:
        t = j * dt
        R, Rdot, er, vp, Vt, om, s = _los(X, bR, c_)
        abs_s = np.abs(s)
        if j == 0:
            thr = settle * om
            t_surf = np.where(abs_s <= delta, 0.0, t_surf)
            t_set = np.where(om <= thr, 0.0, t_set)
            inside = R <= rstop
            if inside.any():
                # Already inside the stop range: stopped at t = 0, no control applied.
                z = np.zeros(int(inside.sum()))
                rows = idx[inside]
                _record(buf, rows, slice(0, K + 1), col, X[:, inside], R[inside],
                        Rdot[inside], om[inside], s[inside], np.zeros((3, z.size)), z, z, z)
                sc[rows, K_TSTOP] = 0.0
                sc[rows, K_RS:K_RS + 3] = X[0:3, inside].T
                sc[rows, K_VS:K_VS + 3] = X[3:6, inside].T
                status[rows] = ST_OK
                finish(inside)
                out = ~inside
                keep(out)
                R, Rdot, er, vp, Vt, om, s, abs_s = (
                    a[..., out] for a in (R, Rdot, er, vp, Vt, om, s, abs_s))
                if not idx.size:
                    break
        else:
            with np.errstate(divide="ignore", invalid="ignore"):
                t_in = t - dt + dt * (prev_abs_s - delta) / (prev_abs_s - abs_s)
                t_dn = t - dt + dt * (prev_om - thr) / (prev_om - om)
            t_surf = np.where(np.isnan(t_surf) & (abs_s <= delta), t_in, t_surf)
            t_set = np.where(om > thr, np.nan, np.where(prev_om > thr, t_dn, t_set))
        prev_abs_s = abs_s
        prev_om = om
        if control:
            Rm = R + bR
            omm = om + bw
            sg = np.where(abs_s < delta, s * (1.0 / delta), np.sign(s))
            u = -c_ * Rdot - eps * sg - beta * abs_s**eta * sg - Rm * omm * omm
            np.clip(u, -asat, asat, out=u)
            acr = -u
            has_t = Vt > 0.0
            act = np.where(has_t, -Nn * Rdot * omm, 0.0)
            with np.errstate(divide="ignore", invalid="ignore"):
                iV = np.where(has_t, act / Vt, 0.0)
            ac = acr * er + iV * vp
            acn = np.sqrt(acr * acr + act * act)
        else:
            z = np.zeros(idx.size)
            ac, acr, act, acn = np.zeros((3, idx.size)), z, z, z
        if j <= K:
            # a slice while no sample of the chunk has stopped: no fancy-index scatter
            rows = slice(idx[0], idx[-1] + 1) if idx[-1] - idx[0] + 1 == idx.size else idx
            _record(buf, rows, j, col, X, R, Rdot, om, s, ac, acr, act, dv)
        if j >= max_steps:
            sc[idx, K_TFAIL] = t
            finish(np.ones(idx.size, dtype=bool))
            break
        if rotating:
            # components along e_theta, e_r, e_w of this step's LOS frame (e_w = e_r x
            # e_theta); without a transverse velocity only the radial part is defined
            with np.errstate(divide="ignore", invalid="ignore"):
                et = np.where(Vt > 0.0, vp * (1.0 / Vt), 0.0)
            ew = np.stack([er[1] * et[2] - er[2] * et[1], er[2] * et[0] - er[0] * et[2],
                           er[0] * et[1] - er[1] * et[0]])
            f = (at[1] * er + (at[0] * et + at[2] * ew)) - ac
        else:
            f = at - ac
        if nm == 0.0:
            Xn = np.empty_like(X)
            Xn[0:3] = X[0:3] + dt * (X[3:6] + hdt * f)
            Xn[3:6] = X[3:6] + dt * f
        else:
            Xn, _, _ = _eval(_derivatives(X, f, nm), dt)
        Rn2 = _dot(Xn[0:3], Xn[0:3])
        # one test for all six components (as the numba kernel): NaN or inf makes the sum so
        bad = ~np.isfinite(Rn2 + _dot(Xn[3:6], Xn[3:6]))
        cross = (Rn2 <= rs2) & ~bad
        hi = np.full(idx.size, dt)
        pass_ = ~cross & ~bad & (Rdot < 0.0) & (_dot(Xn[0:3], Xn[3:6]) > 0.0)
        if pass_.any():
            # The range has a minimum inside the step: a pass that may dip below r_stop.
            Dp = _derivatives(X[:, pass_], f[:, pass_], nm)
            tm = _newton_min(Dp, dt)
            Xm, _, _ = _eval(Dp, tm)
            dips = _dot(Xm[0:3], Xm[0:3]) <= rs2
            where = np.flatnonzero(pass_)[dips]
            cross[where] = True
            hi[where] = tm[dips]
        if bad.any():
            rows = idx[bad]
            sc[rows, K_TFAIL] = t + dt
            status[rows] = ST_NONFINITE
            buf[:, rows, j + 1:K + 1] = np.nan
            finish(bad)
        if cross.any():
            Dc = _derivatives(X[:, cross], f[:, cross], nm)
            tau = _newton_cross(Dc, np.zeros(hi[cross].shape), hi[cross], rs2)
            Xs, _, _ = _eval(Dc, tau)
            dv[cross] += acn[cross] * tau
            acmax[cross] = np.maximum(acmax[cross], acn[cross])
            Rs, Rds, _, _, _, oms, ss = _los(Xs, bR[cross], c_)
            a_s = np.abs(ss)
            ps, po, th = prev_abs_s[cross], prev_om[cross], thr[cross]
            ts, tt = t_surf[cross], t_set[cross]
            with np.errstate(divide="ignore", invalid="ignore"):
                ts = np.where(np.isnan(ts) & (a_s <= delta),
                              t + tau * (ps - delta) / (ps - a_s), ts)
                tt = np.where(oms > th, np.nan,
                              np.where(po > th, t + tau * (po - th) / (po - oms), tt))
            t_surf[cross], t_set[cross] = ts, tt
            rows = idx[cross]
            if j + 1 <= K:
                _record(buf, rows, slice(j + 1, K + 1), col, Xs, Rs, Rds, oms, ss,
                        ac[:, cross], acr[cross], act[cross], dv[cross])
            sc[rows, K_TSTOP] = t + tau
            sc[rows, K_RS:K_RS + 3] = Xs[0:3].T
            sc[rows, K_VS:K_VS + 3] = Xs[3:6].T
            status[rows] = ST_OK
            finish(cross)
        run = ~(cross | bad)
        dv += acn * dt
        acmax = np.maximum(acmax, acn)
        X = Xn
        if not run.all():
            keep(run)
        j += 1
