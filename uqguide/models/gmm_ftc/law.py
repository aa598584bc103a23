"""GMM-based fixed-time control, GMM-FTC ([C] eqs 20-31, spec section 7.4).

Body-frame error coordinates (constant goal, ``r_f' = r_f'' = 0`` as in [C] Table 5):
``y1 = r - r_f``, ``y2 = r'``. With the attract/repulse potential ``phi`` of [C 17-19]
(gradient ``g``, Hessian ``H``, third-derivative contraction ``Gamma(y) = D3 phi[y, y]``):

.. math::
    s_1 = y_1 + k_s g, \\qquad
    s_2 = y_2 + \\alpha_1 s_1 + \\beta_1 s_1^{\\circ 3} + k_s H y_2          \\;([C\\,21]),

    \\Lambda = (\\alpha_1 + 3 \\beta_1 \\mathrm{diag}(s_1 \\circ s_1)) (I + k_s H)  \\;([C\\,23]),

    u = (I + k_s H)^{-1} [ -\\lambda_1 \\mathrm{sig}^{\\zeta_1}(s_2)
        - \\lambda_2 \\mathrm{sig}^{\\zeta_2}(s_2) - \\Lambda y_2 - k_s \\Gamma(y_2) ]
        - A_{21} r - A_{22} r'                                        \\;([C\\,31]).

Then ``s1' = -alpha1 s1 - beta1 s1^3 + s2`` and ``s2' = -lambda1 sig^z1(s2) - lambda2
sig^z2(s2)`` ([C 22, 30]) hold exactly for the continuous law. Corrections to the printed text
(spec A21-A23): "phi1 y1 y2" in [C 21] is ``(d phi1 / d y1) y2 = k_s H y2``; the cube is
element-wise; ``Gamma`` is the derived ``D3 phi[y2, y2]`` (the printed [C 24] misplaces a factor
2 and a sign); ``-A21 y1 - A22 y2 - u_eq`` of [C 31] equals ``-A21 r - A22 r'`` for a goal at
rest (the printed "u = u_eq" of [C 9] lost its sign).

``I + k_s H`` is singular somewhere inside every thin GMM sheet: where ``|det| < det_guard`` the
identity is used instead and the event is counted (never triggered in the [C] scenario).

Gains are diagonal and stored as 3-vectors (row scaling: ``k_s H`` is ``diag(k_s) H``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.rotating_body_frame import Stage
from ..gmm.controllers import positive_diagonal, sig
from ..gmm.potential import AttractRepulsePotential


@dataclass(frozen=True)
class FTCGains:
    """Gains of GMM-FTC ([C] Table 3 defaults are set by the model's parameters).

    Attributes
    ----------
    alpha1, beta1 : ndarray, shape (3,)
        ``s1`` dynamics: linear [1/s] and cubic [1/(m^2 s)] gains.
    lambda1, lambda2 : ndarray, shape (3,)
        Reaching-law gains of ``sig^zeta1`` and ``sig^zeta2``.
    zeta1, zeta2 : float
        Exponents, ``0 < zeta1 < 1 < zeta2``.
    k_s : ndarray, shape (3,)
        Weight of the potential gradient in ``s1`` [-] (``g`` is a length for dimensionless
        ``P``, ``M``).
    """

    alpha1: np.ndarray
    beta1: np.ndarray
    lambda1: np.ndarray
    lambda2: np.ndarray
    zeta1: float
    zeta2: float
    k_s: np.ndarray

    def __post_init__(self) -> None:
        for name in ("alpha1", "beta1", "lambda1", "lambda2", "k_s"):
            object.__setattr__(self, name, positive_diagonal(name, getattr(self, name)))
        if not 0 < self.zeta1 < 1:
            raise ValueError(f"zeta1 must be in (0, 1), got {self.zeta1}")
        if not self.zeta2 > 1:
            raise ValueError(f"zeta2 must be greater than 1, got {self.zeta2}")


def fixed_time_bound(lambda1: np.ndarray, lambda2: np.ndarray, zeta1: float, zeta2: float,
                     tight: bool = False) -> float:
    """Bound on the time for ``s2`` to reach 0 ([C 36], spec 7.4) [s].

    With ``V = 1/2 |s2|^2`` the paper's Lemma 2 gives
    ``V' <= -sum lambda_i,min (2V)^((1+zeta_i)/2)``
    and Corollary 1 ``T_max = 2 / (lambda1,min (1 - zeta1)) + 2 / (lambda2,min (zeta2 - 1))``
    (500 s for Table 3). Lemma 2 is invalid for ``zeta > 1`` in 3-D: by the power-mean
    inequality ``sum |s_i|^(1+zeta2) >= 3^((1-zeta2)/2) |s|^(1+zeta2)``; keeping that factor and the
    ``2^((1+zeta)/2)`` of ``(2V)^...`` in Corollary 1 gives the valid, tighter bound
    (``tight=True``; about 279 s for Table 3).

    Parameters
    ----------
    lambda1, lambda2 : ndarray, shape (3,)
    zeta1, zeta2 : float
    tight : bool
    """
    l1, l2 = float(np.min(lambda1)), float(np.min(lambda2))
    if not tight:
        return 2.0 / (l1 * (1 - zeta1)) + 2.0 / (l2 * (zeta2 - 1))
    p, q = (1 + zeta1) / 2, (1 + zeta2) / 2
    a = l1 * 2.0**p
    b = l2 * 3.0 ** ((1 - zeta2) / 2) * 2.0**q
    return 1.0 / (a * (1 - p)) + 1.0 / (b * (q - 1))


@dataclass(frozen=True)
class FTCCommand:
    """One evaluation of GMM-FTC on a batch.

    Attributes
    ----------
    u : ndarray, shape (n, 3)
        Commanded acceleration, body components [m/s^2].
    s1 : ndarray, shape (n, 3)  [m]
    s2 : ndarray, shape (n, 3)  [m/s]
    guarded : ndarray of bool, shape (n,)
        ``I + k_s H`` was (near-)singular and replaced by ``I``.
    """

    u: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    guarded: np.ndarray


@dataclass(frozen=True)
class GMMFTCLaw:
    """GMM-FTC ([C 31]) for a goal at rest in the body frame.

    Attributes
    ----------
    potential : AttractRepulsePotential
        ``phi`` of [C 17-19] with the target's GMM kernels.
    r_f : ndarray, shape (3,)
        Goal, body frame [m].
    gains : FTCGains
    det_guard : float
        ``|det(I + k_s H)|`` below which the identity replaces it (spec 7.4, A28).
    """

    potential: AttractRepulsePotential
    r_f: np.ndarray
    gains: FTCGains
    det_guard: float = 1e-9

    def __post_init__(self) -> None:
        object.__setattr__(self, "r_f", np.asarray(self.r_f, dtype=float))

    def surfaces(self, r: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``s1`` [m] and ``s2`` [m/s] of [C 21], each (n, 3)."""
        gn = self.gains
        d = self.potential.derivatives(r, self.r_f)
        s1 = (r - self.r_f) + gn.k_s * d.g
        Hv = np.einsum("nij,nj->ni", d.H, v)
        return s1, v + gn.alpha1 * s1 + gn.beta1 * s1**3 + gn.k_s * Hv

    def command(self, r: np.ndarray, v: np.ndarray, plant: Stage) -> FTCCommand:
        """GMM-FTC command for states ``r, v`` (n, 3).

        ``plant.apply(r, v)`` is the ``A21 r + A22 v`` the controller believes, evaluated at the
        sample time (spec A34): a :class:`~uqguide.models.dynamics.rotating_body_frame.
        BodyFrameStage`, or a ``LinearStage`` of given matrices.
        """
        gn = self.gains
        d = self.potential.derivatives(r, self.r_f, v)
        y1 = r - self.r_f
        s1 = y1 + gn.k_s * d.g
        Hv = np.einsum("nij,nj->ni", d.H, v)
        s2 = v + gn.alpha1 * s1 + gn.beta1 * s1**3 + gn.k_s * Hv
        J = np.eye(3) + gn.k_s[:, None] * d.H  # I + k_s H, (n, 3, 3)
        guarded = ~(np.abs(np.linalg.det(J)) >= self.det_guard)
        if guarded.any():
            J[guarded] = np.eye(3)
        Jv = v + gn.k_s * Hv
        lam_y2 = (gn.alpha1 + 3.0 * gn.beta1 * s1 * s1) * Jv  # Lambda y2
        rhs = (-gn.lambda1 * sig(s2, gn.zeta1) - gn.lambda2 * sig(s2, gn.zeta2)
               - lam_y2 - gn.k_s * d.gamma)
        acc = np.linalg.solve(J, rhs[..., None])[..., 0]
        return FTCCommand(u=acc - plant.apply(r, v), s1=s1, s2=s2, guarded=guarded)

