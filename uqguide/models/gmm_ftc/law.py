"""GMM-based fixed-time control, GMM-FTC ([C] eqs 20-31): :class:`GMMFTCLaw`, its gains
:class:`FTCGains` and the [C 36] bound :func:`fixed_time_bound`.

The law in full and the corrections (A21-A23, the singular-Jacobian guard A28):
docs/papers.md#gmm-potentials-and-controllers; the labels:
docs/papers.md#the-gmm-papers-ambiguities-as-settled.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics.rotating_body_frame import Stage
from ..gmm.controllers import positive_diagonal, sig
from ..gmm.potential import AttractRepulsePotential


@dataclass(frozen=True)
class FTCGains:
    """Gains of GMM-FTC, diagonals as 3-vectors ([C] Table 3 defaults are set by the model's
    parameters): the linear ``alpha1`` [1/s] and cubic ``beta1`` [1/(m^2 s)] gains of the
    ``s1`` dynamics, the reaching-law gains ``lambda1``, ``lambda2`` of ``sig^zeta1``,
    ``sig^zeta2`` (``0 < zeta1 < 1 < zeta2``), and the weight ``k_s`` [-] of the potential's
    gradient in ``s1`` (``g`` is a length for dimensionless ``P``, ``M``)."""

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
    """Bound [s] on the time for ``s2`` to reach 0: [C 36] as printed, or with ``tight`` the
    valid, tighter bound (docs/simulators.md#gmm-ftc-the-fixed-time-bound)."""
    l1, l2 = float(np.min(lambda1)), float(np.min(lambda2))
    if not tight:
        return 2.0 / (l1 * (1 - zeta1)) + 2.0 / (l2 * (zeta2 - 1))
    p, q = (1 + zeta1) / 2, (1 + zeta2) / 2
    a = l1 * 2.0**p
    b = l2 * 3.0 ** ((1 - zeta2) / 2) * 2.0**q
    return 1.0 / (a * (1 - p)) + 1.0 / (b * (q - 1))


@dataclass(frozen=True)
class FTCCommand:
    """One evaluation of GMM-FTC on a batch: the commanded acceleration ``u`` (n, 3), body
    components [m/s^2], ``s1`` [m] and ``s2`` [m/s] (n, 3), and ``guarded`` (n,): where
    ``I + k_s H`` was (near-)singular and replaced by ``I``."""

    u: np.ndarray
    s1: np.ndarray
    s2: np.ndarray
    guarded: np.ndarray


@dataclass(frozen=True)
class GMMFTCLaw:
    """GMM-FTC ([C 31]) for a goal ``r_f`` (3,) [m] at rest in the body frame; ``potential`` is
    ``phi`` of [C 17-19] with the target's GMM kernels; below ``det_guard`` of ``|det(I + k_s H)|``
    the identity replaces it (A28)."""

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
        sample time (A34): a :class:`~uqguide.models.dynamics.rotating_body_frame.
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

