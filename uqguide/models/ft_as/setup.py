"""The fixed quantities of one FT-AS run and the per-sample arrays of a batch.

:class:`Gains` holds the controller and observer gains of section 5.1 (the FT-DO and FT-NTSM
laws, eqs 18-30), :class:`Plant` the nominal plant and reference orbit, :class:`Batch` everything
that may differ between the samples of one integration: initial state, truth-model dispersions
and which controller each sample runs. The compiled kernel (``kernel_numba.py``) gets them
flattened by :func:`pack_constants`; its NumPy test oracle takes them as they are.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..dynamics import mrp
from . import scenario

# Controller codes of Batch.controller.
FT_AS, CASE1, CASE2 = 0, 1, 2
CONTROLLER_CODES = {"ft_as": FT_AS, "case1": CASE1, "case2": CASE2}

# Layout of the 36-element state of one sample (section 9).
R_E, V_E, SIGMA_E, OMEGA = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12)
PSI1, PSI2, CHI1, CHI2 = slice(12, 18), slice(18, 24), slice(24, 30), slice(30, 36)
N_STATE = 36


@dataclass(frozen=True)
class Gains:
    """Gains of the FT-NTSM law (eq 26-30) and the FT-DO (eq 18-23), section 5.1.

    No defaults here: the paper's values are stated once, as the defaults of
    :class:`~uqguide.models.ft_as.params.FTASParams`, and reach the integrators through
    ``FTASParams.gains()``. Ratios such as ``m1n1 = m1/n1`` are used as real exponents with
    explicit ``sig`` powers ([A18]). ``boundary`` > 0 replaces ``sign(s)`` by
    ``tanh(s / boundary)`` (not from the paper).
    """

    nu1: float
    eta1: float
    nu2: float
    eta2: float
    m1n1: float
    p1q1: float
    m2n2: float
    p2q2: float
    eps: float
    gamma: float
    obs_p: float
    lam1: float
    lam2: float
    lam3: float
    boundary: float
    obs_per_channel: bool

    @property
    def a(self) -> float:
        """``q1/p1``, exponent of the sliding variable, 1 < a < 2."""
        return 1.0 / self.p1q1

    @property
    def b(self) -> float:
        """``m1/n1 - p1/q1`` > 1."""
        return self.m1n1 - self.p1q1

    @property
    def c(self) -> float:
        """``p1/q1``."""
        return self.p1q1


@dataclass(frozen=True)
class Plant:
    """Nominal plant: mass ``m0`` [kg], inertia ``J0`` (3, 3) [kg m^2], the ``reference`` orbit
    whose RTN frame is the desired attitude (A1), per-axis input limits ``u_bar`` (6,)
    [N, N, N, N m, N m, N m]."""

    m0: float
    J0: np.ndarray
    reference: scenario.CircularOrbit
    limits: np.ndarray

    @property
    def J0_inv(self) -> np.ndarray:
        return np.linalg.inv(self.J0)

    @property
    def omega_t(self) -> np.ndarray:
        """Reference angular velocity in R, ``[0, 0, n_t]`` [rad/s] (constant)."""
        return np.array([0.0, 0.0, self.reference.mean_motion])


@dataclass(frozen=True)
class Batch:
    """Per-sample arrays of one integration, all of leading length ``n``.

    ``x0 (n, 36)``: initial state ``(r_e, v_e, sigma_e, omega, psi1, psi2, chi1, chi2)``;
    ``mass_offset`` [kg] added to the true mass; ``inertia_scale_error`` ``x`` in ``J = J0 (1 +
    x) + Delta J(t)``; ``force_amp`` ``A_f`` [N], ``torque_amp`` ``A_tau`` [N m]; ``controller``
    ``FT_AS``, ``CASE1`` or ``CASE2``; ``observer_on_applied`` (FT-AS only): the FT-DO sees
    ``sat(u_c)`` (FT-AS-A) instead of ``u_c``; ``psi2_bound`` the box ``|psi2_k| <= D`` after
    each step (FT-AS-P; ``inf``: none); ``omega_chi`` the Case 2 compensator's natural
    frequency [rad/s]; ``switch_input``: the switching term ``gamma sign(s)`` in input units
    (N, N m), else in e2-acceleration units (the literal eq 29).
    """

    x0: np.ndarray
    mass_offset: np.ndarray
    inertia_scale_error: np.ndarray
    force_amp: np.ndarray
    torque_amp: np.ndarray
    controller: np.ndarray
    observer_on_applied: np.ndarray
    psi2_bound: np.ndarray
    omega_chi: np.ndarray
    switch_input: np.ndarray

    @property
    def n(self) -> int:
        return int(self.x0.shape[0])


def initial_state(
    plant: Plant,
    r_e0: np.ndarray,
    v_e0: np.ndarray,
    sigma_e0: np.ndarray,
    omega_e0: np.ndarray,
) -> np.ndarray:
    """The 36-element initial state (n, 36) of each sample from its initial tracking errors
    (n, 3) [m, m/s, -, rad/s]: ``omega(0) = omega_e(0) + C(sigma_e(0)) omega_t``, the observer at
    ``(PSI1_0, PSI2_0)``, the compensator at rest."""
    n = r_e0.shape[0]
    x0 = np.zeros((n, N_STATE))
    x0[:, R_E], x0[:, V_E], x0[:, SIGMA_E] = r_e0, v_e0, sigma_e0
    x0[:, OMEGA] = omega_e0 + mrp.dcm(sigma_e0) @ plant.omega_t
    x0[:, PSI1], x0[:, PSI2] = scenario.PSI1_0, scenario.PSI2_0
    return x0


# Indices into the flat constants vector handed to the numba kernel.
(
    K_MU, K_M0, K_AT, K_NT, K_U0, K_NU1, K_ETA1, K_NU2, K_ETA2, K_A, K_B, K_C, K_R2, K_RHO2,
    K_EPS, K_GAMMA, K_BOUNDARY, K_OBS_P, K_LAM1, K_LAM2, K_LAM3, K_OBS_PER_CHANNEL, N_CONST,
) = range(23)  # fmt: skip


def pack_constants(plant: Plant, gains: Gains) -> np.ndarray:
    """Flatten the scalar constants for the numba kernel (indices ``K_*`` of this module)."""
    ref = plant.reference
    c = np.zeros(N_CONST)
    c[K_MU], c[K_M0], c[K_AT], c[K_NT] = ref.mu, plant.m0, ref.a, ref.mean_motion
    c[K_U0] = np.radians(ref.argp + ref.m0)
    c[K_NU1], c[K_ETA1], c[K_NU2], c[K_ETA2] = gains.nu1, gains.eta1, gains.nu2, gains.eta2
    c[K_A], c[K_B], c[K_C] = gains.a, gains.b, gains.c
    c[K_R2], c[K_RHO2], c[K_EPS], c[K_GAMMA] = gains.m2n2, gains.p2q2, gains.eps, gains.gamma
    c[K_BOUNDARY] = gains.boundary
    c[K_OBS_P], c[K_LAM1], c[K_LAM2], c[K_LAM3] = gains.obs_p, gains.lam1, gains.lam2, gains.lam3
    c[K_OBS_PER_CHANNEL] = float(gains.obs_per_channel)
    return c
