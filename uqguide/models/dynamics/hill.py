"""Hill / Clohessy-Wiltshire relative motion about a circular orbit.

In the target's LVLH frame (x radial outward, y along-track, z orbit normal), rotating at the
mean motion ``n`` (:func:`mean_motion`). uqguide's guidance models use the line of sight
``r = r_target - r_chaser``; the gravity terms keep their form for it,
``g(r, v) = [3 n^2 x + 2 n v_y, -2 n v_x, -n^2 z]`` (:func:`hill_acceleration`), and only the
thrust terms flip. :func:`cw_stm` and :func:`cw_propagate` are the closed-form solutions.
Everything is vectorised over leading axes: ``r``, ``v`` of shape ``(..., 3)``.

The sign convention, derived: docs/papers.md#ftcapn-frames-and-choices.
"""

from __future__ import annotations

import numpy as np

MU_EARTH = 3.986004418e14
"""Earth's gravitational parameter [m^3/s^2] (WGS-84 / EGM-96 value)."""


def mean_motion(semi_major_axis: float, mu: float = MU_EARTH) -> float:
    """Mean motion ``n = sqrt(mu / a^3)`` [rad/s] of a circular orbit of radius ``a`` [m] > 0."""
    if not semi_major_axis > 0:
        raise ValueError(f"semi-major axis must be positive, got {semi_major_axis} m")
    return float(np.sqrt(mu / semi_major_axis**3))


def hill_acceleration(r: np.ndarray, v: np.ndarray, n: float) -> np.ndarray:
    """Gravity and frame (Coriolis, centrifugal) relative acceleration
    ``g(r, v) = [3 n^2 x + 2 n v_y, -2 n v_x, -n^2 z]`` [m/s^2] for LVLH ``r`` [m], ``v`` [m/s]
    (either sign convention) and the mean motion ``n`` [rad/s]."""
    r = np.asarray(r, dtype=float)
    v = np.asarray(v, dtype=float)
    g = np.empty(np.broadcast_shapes(r.shape, v.shape))
    g[..., 0] = 3.0 * n * n * r[..., 0] + 2.0 * n * v[..., 1]
    g[..., 1] = -2.0 * n * v[..., 0]
    g[..., 2] = -n * n * r[..., 2]
    return g


def hill_matrix(n: float) -> np.ndarray:
    """System matrix ``A`` (6, 6) of the Hill equations ``d/dt [r, v] = A [r, v]`` [rad/s]."""
    A = np.zeros((6, 6))
    A[0:3, 3:6] = np.eye(3)
    A[3, 0] = 3.0 * n * n
    A[3, 4] = 2.0 * n
    A[4, 3] = -2.0 * n
    A[5, 2] = -n * n
    return A


def cw_stm(n: float, t: np.ndarray | float) -> np.ndarray:
    """Closed-form CW state transition matrix ``Phi(t)``, ``[r(t), v(t)] = Phi(t) [r(0), v(0)]``,
    state ordered ``x, y, z, vx, vy, vz``: (m, 6, 6) for times ``t`` (m,) [s], (6, 6) for a
    scalar ``t``; mean motion ``n`` > 0 [rad/s]."""
    scalar = np.ndim(t) == 0
    t = np.atleast_1d(np.asarray(t, dtype=float))
    nt = n * t
    s, c = np.sin(nt), np.cos(nt)
    P = np.zeros(t.shape + (6, 6))
    P[:, 0, 0] = 4.0 - 3.0 * c
    P[:, 0, 3] = s / n
    P[:, 0, 4] = 2.0 * (1.0 - c) / n
    P[:, 1, 0] = 6.0 * (s - nt)
    P[:, 1, 1] = 1.0
    P[:, 1, 3] = -2.0 * (1.0 - c) / n
    P[:, 1, 4] = (4.0 * s - 3.0 * nt) / n
    P[:, 2, 2] = c
    P[:, 2, 5] = s / n
    P[:, 3, 0] = 3.0 * n * s
    P[:, 3, 3] = c
    P[:, 3, 4] = 2.0 * s
    P[:, 4, 0] = -6.0 * n * (1.0 - c)
    P[:, 4, 3] = -2.0 * s
    P[:, 4, 4] = 4.0 * c - 3.0
    P[:, 5, 2] = -n * s
    P[:, 5, 5] = c
    return P[0] if scalar else P


def _particular(n: float, a: np.ndarray, t: np.ndarray) -> np.ndarray:
    """A particular solution ``p(t)`` (..., 6) for a constant acceleration ``a``: substituting
    ``x = X0 + X1 t``, ``y = Y2 t^2``, ``z = Z0`` into the forced CW equations gives
    ``X1 = 2 a_y / n``, ``Y2 = -3 a_y / 2``, ``X0 = -a_x / (3 n^2)``, ``Z0 = a_z / n^2``."""
    p = np.zeros(np.broadcast_shapes(a.shape[:-1], np.shape(t)) + (6,))
    p[..., 0] = -a[..., 0] / (3.0 * n * n) + 2.0 * a[..., 1] / n * t
    p[..., 1] = -1.5 * a[..., 1] * t * t
    p[..., 2] = a[..., 2] / (n * n)
    p[..., 3] = 2.0 * a[..., 1] / n
    p[..., 4] = -3.0 * a[..., 1] * t
    return p


def cw_propagate(
    r: np.ndarray, v: np.ndarray, n: float, t: np.ndarray | float, accel: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form CW propagation of ``r`` [m], ``v`` [m/s] (m, 3) over the elapsed times ``t``
    [s] per sample, optionally with a constant (LVLH-fixed) acceleration.

    ``accel`` (m, 3) or (3,) [m/s^2] is added to ``g(r, v)`` (``a_target - a_chaser`` for
    ``r = target - chaser``). The forced solution is ``x(t) = Phi(t) (x0 - p(0)) + p(t)``
    (:func:`_particular`); its terms of size ``|a| / n^2`` cancel, which costs about
    ``1e-16 |a| / n^2`` (1e-11 m for 0.1 m/s^2 in LEO) of absolute accuracy.
    """
    r = np.atleast_2d(np.asarray(r, dtype=float))
    v = np.atleast_2d(np.asarray(v, dtype=float))
    t = np.broadcast_to(np.asarray(t, dtype=float), (r.shape[0],))
    x0 = np.concatenate([r, v], axis=-1)
    P = cw_stm(n, t)
    if accel is None:
        x = np.einsum("mij,mj->mi", P, x0)
    else:
        a = np.broadcast_to(np.asarray(accel, dtype=float), r.shape)
        x = np.einsum("mij,mj->mi", P, x0 - _particular(n, a, np.zeros_like(t))) + _particular(
            n, a, t
        )
    return x[:, :3], x[:, 3:]
