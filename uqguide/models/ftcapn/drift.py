"""Zero-effort miss: the closest approach of the uncontrolled drift after the stop.

Straight-line, parabolic (a constant target acceleration) and Hill drift:
docs/simulators.md#ftcapn-the-zero-effort-miss. All functions take ``r, v, a`` of shape
``(m, 3)`` and return ``(miss (m,), t_miss (m,))``.
"""

from __future__ import annotations

import numpy as np

from ..dynamics.hill import cw_propagate, hill_acceleration


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def _parabola(r, v, a, t):
    """Position and velocity of ``r + v t + a t^2 / 2`` at ``t (m, c)`` for ``r (m, 3)``."""
    tt = t[..., None]
    return r[:, None] + v[:, None] * tt + 0.5 * a[:, None] * tt * tt, v[:, None] + a[:, None] * tt


def _cubic_real_roots(coef: np.ndarray) -> np.ndarray:
    """Real roots of ``c3 t^3 + c2 t^2 + c1 t + c0`` (``coef (m, 4)``, ``c3 != 0``), NaN-padded
    to ``(m, 3)``: eigenvalues of the stacked companion matrices (robust for any scaling)."""
    m = coef.shape[0]
    comp = np.zeros((m, 3, 3))
    comp[:, 0, :] = -coef[:, 1:] / coef[:, :1]
    comp[:, 1, 0] = 1.0
    comp[:, 2, 1] = 1.0
    lam = np.linalg.eigvals(comp)
    real = np.abs(lam.imag) <= 1e-7 * (1.0 + np.abs(lam.real))
    return np.where(real, lam.real, np.nan)


def miss_straight(r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest approach of ``r + v t``, ``t >= 0`` (``|r x v| / |v|`` when closing)."""
    vv = _dot(v, v)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(vv > 0.0, np.maximum(-_dot(r, v) / vv, 0.0), 0.0)
    rt = r + v * t[:, None]
    return np.sqrt(_dot(rt, rt)), t


def miss_parabola(r: np.ndarray, v: np.ndarray, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closest approach of ``r + v t + a t^2 / 2``, ``t >= 0``.

    The stationary points of ``|r(t)|^2`` are the real roots of the cubic
    ``|a|^2/2 t^3 + 3/2 (a.v) t^2 + (|v|^2 + a.r) t + r.v``; each is polished by two Newton
    steps, and the minimum over them, ``t = 0`` and the straight-line point is kept.
    """
    miss, t_miss = miss_straight(r, v)
    has_a = _dot(a, a) > 0.0
    if not has_a.any():
        return miss, t_miss
    rr, vv, aa = r[has_a], v[has_a], a[has_a]
    coef = np.stack([0.5 * _dot(aa, aa), 1.5 * _dot(aa, vv), _dot(vv, vv) + _dot(aa, rr),
                     _dot(rr, vv)], axis=1)
    cand = np.concatenate([_cubic_real_roots(coef), t_miss[has_a, None],
                           np.zeros((rr.shape[0], 1))], axis=1)
    for _ in range(2):
        p, dp = _parabola(rr, vv, aa, cand)
        g = _dot(p, dp)
        dg = _dot(dp, dp) + _dot(p, np.broadcast_to(aa[:, None], p.shape))
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dg > 0.0, g / dg, 0.0)
        cand = np.where(cand > 0.0, cand - step, cand)
    cand = np.where(np.isfinite(cand) & (cand >= 0.0), cand, 0.0)
    p, _ = _parabola(rr, vv, aa, cand)
    dist = np.sqrt(_dot(p, p))
    best = np.argmin(dist, axis=1)
    rows = np.arange(rr.shape[0])
    miss[has_a] = dist[rows, best]
    t_miss[has_a] = cand[rows, best]
    return miss, t_miss


def miss_hill(
    r: np.ndarray, v: np.ndarray, a: np.ndarray, n: float, iterations: int = 8
) -> tuple[np.ndarray, np.ndarray]:
    """Closest approach of the CW drift (with constant LVLH acceleration ``a``) near the
    gravity-free one.

    Newton on ``d/dt |r(t)|^2 / 2 = r . v`` with ``d/dt (r . v) = |v|^2 + r . (g + a)``,
    starting from the gravity-free stationary points and ``t = 0``. Over the ~10 s of a close
    pass the Hill terms bend the parabola only slightly, so the close pass is the one found;
    the next approaches an orbit period later are not considered.
    """
    m = r.shape[0]
    _, t0 = miss_parabola(r, v, a)
    _, t_line = miss_straight(r, v)
    cand = np.stack([t0, t_line], axis=1)
    for _ in range(iterations):
        rt, vt = cw_propagate(np.repeat(r, 2, axis=0), np.repeat(v, 2, axis=0), n,
                              cand.ravel(), np.repeat(a, 2, axis=0))
        g = _dot(rt, vt)
        dg = _dot(vt, vt) + _dot(rt, hill_acceleration(rt, vt, n) + np.repeat(a, 2, axis=0))
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(dg > 0.0, g / dg, 0.0)
        cand = np.maximum(cand - step.reshape(m, 2), 0.0)
    rt, _ = cw_propagate(np.repeat(r, 2, axis=0), np.repeat(v, 2, axis=0), n, cand.ravel(),
                         np.repeat(a, 2, axis=0))
    dist = np.sqrt(_dot(rt, rt)).reshape(m, 2)
    d0 = np.sqrt(_dot(r, r))
    best = np.argmin(dist, axis=1)
    rows = np.arange(m)
    miss = np.minimum(dist[rows, best], d0)
    t_miss = np.where(dist[rows, best] <= d0, cand[rows, best], 0.0)
    return miss, t_miss
