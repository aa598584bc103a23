"""Parameters of the ``gmm_ftc`` model: [C] Tables 3-5 and section 4.2 with the ambiguities
settled as docs/papers.md#the-gmm-papers-ambiguities-as-settled says; SI units."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from ..base import ModelParams
from ..kernels import KernelParam, kernel_field
from ..time_grid import recording_stride, whole_steps

__all__ = ["GMMFTCParams", "PosVec3", "Vec3"]

Vec3 = tuple[float, float, float]
Positive = Annotated[float, Field(gt=0.0)]
PosVec3 = tuple[Positive, Positive, Positive]


class GMMFTCParams(ModelParams):
    """GMM-FTC scenario (SI units); defaults are [C] Tables 3-5 and section 4.2 with the
    ambiguities settled (docs/papers.md#the-gmm-papers-ambiguities-as-settled)."""

    # target orbit, [C] Table 4 (i, RAAN, argument of perigee do not enter the TH model)
    semi_major_axis: float = Field(6878.14e3, gt=0.0, description="target orbit [m]")
    eccentricity: float = Field(0.01, ge=0.0, lt=1.0, description="target orbit")
    f0: float = Field(0.0, description="initial true anomaly [rad]")
    mu: float = Field(3.986e14, gt=0.0, description="[m^3/s^2] ([C] 2.3, printed unit typo)")
    # target spin and servicer, [C] Table 5
    spin_rate: Vec3 = Field((0.0, 0.0, 0.05), description="target rate relative to LVLH, "
                            "body components [rad/s] (constant)")
    r0: Vec3 = Field((12.0, 3.0, 1.0), description="initial body-frame position [m] (A11)")
    v0: Vec3 = Field((0.0, 0.0, 0.0), description="initial body-frame velocity [m/s] "
                     "(co-rotating start, A35)")
    r_f: Vec3 = Field((2.0, 1.0, 0.0), description="goal, body frame [m] (at rest)")
    # GMM-FTC gains, [C] Table 3 (diagonal matrices as 3-vectors)
    alpha1: PosVec3 = Field((0.3, 0.3, 0.3), description="s1 linear gain, diagonal [1/s]")
    beta1: PosVec3 = Field((0.01, 0.01, 0.01), description="s1 cubic gain, diagonal "
                           "[1/(m^2 s)]")
    zeta1: float = Field(0.6, gt=0.0, lt=1.0, description="reaching-law exponent < 1")
    zeta2: float = Field(1.5, gt=1.0, description="reaching-law exponent > 1")
    lambda1: PosVec3 = Field((0.05, 0.05, 0.05), description="gain of sig^zeta1(s2), diagonal")
    lambda2: PosVec3 = Field((0.01, 0.01, 0.01), description="gain of sig^zeta2(s2), diagonal")
    k_s: PosVec3 = Field((3e-4, 1e-4, 1e-4), description="weight of the potential gradient in "
                         "s1, diagonal")
    M: PosVec3 = Field((0.6, 0.6, 0.4), description="repulsion gain, diagonal")
    P: PosVec3 = Field((0.8, 0.8, 0.8), description="attraction gain, diagonal")
    # target shape
    gmm: Literal["published", "fitted"] = Field(
        "published", description="'published': [C] Table 2; 'fitted': the shipped EM fit")
    norm: Literal["3d", "2pi"] = Field("3d", description="GMM kernel normaliser (A9)")
    variance_floor: float = Field(0.0, ge=0.0, description="optional GMM variance floor [m^2] "
                                  "(A31 deviation; 0 = as published)")
    panel_half_thickness: float = Field(0.02, ge=0.0, description="[m] (spec 4.2)")
    antenna_half_width: float = Field(0.05, ge=0.0, description="[m] (spec 4.2)")
    body_tolerance: float = Field(0.01, ge=0.0, description="allowed body penetration [m]")
    # simulation, [C] 4.2
    dt: float = Field(0.1, gt=0.0, description="control period = RK4 step [s]")
    n_sub: int = Field(1, ge=1, description="RK4 sub-steps per control period")
    t_final: float = Field(300.0, gt=0.0, description="duration [s] (A26)")
    record_dt: float = Field(1.0, gt=0.0, description="output grid step [s] (metrics use "
                             "every control step)")
    thrust_noise: float = Field(0.05, ge=0.0, lt=1.0, description="half-width of the per-axis, "
                                "per-period thrust factor 1 + U(-w, w) (A25)")
    noise_seed: int = Field(0, ge=0, lt=2**63, description="key of the thrust-noise streams")
    u_max: float | None = Field(None, gt=0.0, description="thrust limit [m/s^2] (None: none, "
                                "as in [C])")
    controller_spin: Literal["true", "nominal"] = Field(
        "true", description="spin rate in the controller's model: the actual one or spin_rate")
    controller_model: Literal["corrected", "printed"] = Field(
        "corrected", description="body-frame model the controller cancels (A20)")
    kernel: KernelParam = kernel_field()
    # claim thresholds, [C] 4.2
    converge_tol: float = Field(1e-4, gt=0.0, description="position convergence [m]")
    settle_tol: float = Field(1e-2, gt=0.0, description="coarse position settling [m] "
                              "(t_settle; a docking-readiness threshold, our choice)")
    velocity_tol: float = Field(1e-4, gt=0.0, description="velocity convergence [m/s]")
    t_check: float = Field(150.0, ge=0.0, description="converged window starts [s]")

    @model_validator(mode="after")
    def _grid(self) -> GMMFTCParams:
        n_steps = whole_steps(self.t_final, self.dt, "t_final")
        recording_stride(self.record_dt, self.dt, n_steps, "record_dt")
        return self
