"""Modified Rodrigues Parameters (MRP): kinematics, rotation matrices, composition.

Conventions of Schaub & Junkins (docs/papers.md#ft-as-conventions-variants-and-checks): ``sigma =
e tan(phi/4)`` for
principal axis ``e`` and angle ``phi``; ``C(sigma_{X/Y})`` maps Y-components to X-components;
``sigma_dot = G(sigma) omega`` with ``omega`` the angular velocity of X relative to Y in X
components.

Every function is batched over leading dimensions: vectors are ``(..., 3)``, matrices
``(..., 3, 3)``.
"""

from __future__ import annotations

import numpy as np


def skew(x: np.ndarray) -> np.ndarray:
    """Skew-symmetric matrix ``S(x)`` (..., 3, 3) of ``x`` (..., 3): ``S(x) y = x cross y`` (the
    paper's psi(x))."""
    x = np.asarray(x, dtype=float)
    S = np.zeros(x.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -x[..., 2], x[..., 1]
    S[..., 1, 0], S[..., 1, 2] = x[..., 2], -x[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -x[..., 1], x[..., 0]
    return S


def _outer(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., :, None] * b[..., None, :]


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def kinematics_matrix(sigma: np.ndarray) -> np.ndarray:
    """``G(sigma) = 1/4 [(1 - sigma^T sigma) I + 2 S(sigma) + 2 sigma sigma^T]`` (paper eq 3), so
    that ``sigma_dot = G(sigma) omega``."""
    sigma = np.asarray(sigma, dtype=float)
    q = _dot(sigma, sigma)[..., None, None]
    return 0.25 * ((1.0 - q) * np.eye(3) + 2.0 * skew(sigma) + 2.0 * _outer(sigma, sigma))


def kinematics_matrix_inv(sigma: np.ndarray) -> np.ndarray:
    """``G(sigma)^-1 = 16 / (1 + sigma^T sigma)^2 G(sigma)^T``."""
    sigma = np.asarray(sigma, dtype=float)
    q = _dot(sigma, sigma)[..., None, None]
    return 16.0 / (1.0 + q) ** 2 * np.swapaxes(kinematics_matrix(sigma), -1, -2)


def kinematics_matrix_dot(sigma: np.ndarray, sigma_dot: np.ndarray) -> np.ndarray:
    """Time derivative of ``G`` [1/s] for the rate ``sigma_dot`` [1/s]:
    ``1/2 [-(sigma^T sigma_dot) I + S(sigma_dot) + sigma_dot sigma^T + sigma sigma_dot^T]``."""
    sigma = np.asarray(sigma, dtype=float)
    sigma_dot = np.asarray(sigma_dot, dtype=float)
    sd = _dot(sigma, sigma_dot)[..., None, None]
    return 0.5 * (
        -sd * np.eye(3) + skew(sigma_dot) + _outer(sigma_dot, sigma) + _outer(sigma, sigma_dot)
    )


def dcm(sigma: np.ndarray) -> np.ndarray:
    """Direction-cosine matrix ``C(sigma) = I + [8 S^2 - 4 (1 - q) S] / (1 + q)^2`` of the MRP of
    frame X relative to Y: it maps Y-components to X-components."""
    sigma = np.asarray(sigma, dtype=float)
    q = _dot(sigma, sigma)[..., None, None]
    S = skew(sigma)
    return np.eye(3) + (8.0 * S @ S - 4.0 * (1.0 - q) * S) / (1.0 + q) ** 2


def from_dcm(C: np.ndarray) -> np.ndarray:
    """MRP of a proper orthogonal matrix, the short rotation (``|sigma| <= 1``).

    Goes through the quaternion (Shepperd's method: the largest of the four squared
    components is taken as pivot, so no division by a small number).
    """
    C = np.asarray(C, dtype=float)
    tr = np.trace(C, axis1=-2, axis2=-1)
    # 4 q_i^2 for i = 0 (scalar), 1, 2, 3
    b2 = np.stack(
        [
            1.0 + tr,
            1.0 + 2.0 * C[..., 0, 0] - tr,
            1.0 + 2.0 * C[..., 1, 1] - tr,
            1.0 + 2.0 * C[..., 2, 2] - tr,
        ],
        axis=-1,
    )
    pivot = np.argmax(b2, axis=-1)
    d12 = C[..., 1, 2] - C[..., 2, 1]
    d20 = C[..., 2, 0] - C[..., 0, 2]
    d01 = C[..., 0, 1] - C[..., 1, 0]
    s01 = C[..., 0, 1] + C[..., 1, 0]
    s20 = C[..., 2, 0] + C[..., 0, 2]
    s12 = C[..., 1, 2] + C[..., 2, 1]
    bp = np.sqrt(np.take_along_axis(b2, pivot[..., None], axis=-1)[..., 0])
    cands = np.stack(
        [
            np.stack([bp, d12 / bp, d20 / bp, d01 / bp], axis=-1),
            np.stack([d12 / bp, bp, s01 / bp, s20 / bp], axis=-1),
            np.stack([d20 / bp, s01 / bp, bp, s12 / bp], axis=-1),
            np.stack([d01 / bp, s20 / bp, s12 / bp, bp], axis=-1),
        ],
        axis=-2,
    )
    # bp >= 1 (the largest of four numbers summing to 4), so the divisions above are safe
    quat = 0.5 * np.take_along_axis(cands, pivot[..., None, None], axis=-2)[..., 0, :]
    # short rotation: scalar part >= 0, so |sigma| <= 1
    quat = np.where(quat[..., :1] < 0.0, -quat, quat)
    return quat[..., 1:] / (1.0 + quat[..., :1])


def relative(sigma: np.ndarray, sigma_t: np.ndarray) -> np.ndarray:
    """MRP of B relative to R from ``sigma = sigma_{B/N}`` and ``sigma_t = sigma_{R/N}`` (eq 4):
    ``sigma_e = [(1 - |sigma_t|^2) sigma - (1 - |sigma|^2) sigma_t + 2 sigma x sigma_t]
    / [1 + |sigma_t|^2 |sigma|^2 + 2 sigma_t^T sigma]``."""
    sigma = np.asarray(sigma, dtype=float)
    sigma_t = np.asarray(sigma_t, dtype=float)
    qs = _dot(sigma, sigma)[..., None]
    qt = _dot(sigma_t, sigma_t)[..., None]
    num = (1.0 - qt) * sigma - (1.0 - qs) * sigma_t + 2.0 * np.cross(sigma, sigma_t)
    den = 1.0 + qt * qs + 2.0 * _dot(sigma_t, sigma)[..., None]
    return num / den


def shadow(sigma: np.ndarray) -> np.ndarray:
    """Switch to the shadow set ``-sigma / |sigma|^2`` where ``|sigma| > 1``; same attitude."""
    sigma = np.asarray(sigma, dtype=float)
    q = _dot(sigma, sigma)[..., None]
    return np.where(q > 1.0, -sigma / np.where(q > 1.0, q, 1.0), sigma)
