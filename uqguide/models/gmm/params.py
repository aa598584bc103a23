"""Parameters of the ``gmm_proximity`` model: the [W] scenario, the literal reading of the paper
by default (docs/papers.md#the-gmm-papers-ambiguities-as-settled); SI units."""

from __future__ import annotations

from typing import Literal

from pydantic import Field, model_validator

from ..base import ModelParams
from ..dynamics.tschauner_hempel import MU_EARTH
from ..kernels import KernelParam, kernel_field
from ..time_grid import recording_stride, whole_steps

__all__ = ["ControllerName", "GMMProximityParams", "Vec3"]

Vec3 = tuple[float, float, float]
ControllerName = Literal["gmm_ntsmc", "gmm_tsmc", "apf_tsmc"]


class GMMProximityParams(ModelParams):
    """The [W] scenario; SI units. Defaults are the literal reading of the paper."""

    controller: ControllerName = Field("gmm_ntsmc", description="control law ([W] 3, App. A2, A3)")
    gmm_source: Literal["published", "fitted"] = Field(
        "published",
        description="App. A4 parameters, or the k-means + EM fit shipped in uqguide/data")
    gmm_norm: Literal["2pi", "3d"] = Field("2pi", description="kernel normaliser (spec 5.1, A9)")
    gmm_sigma_floor: float = Field(
        0.0, ge=0.0, description="m; GMM covariance eigenvalues raised to this squared (spec 6.3, "
        "A31; 0 = as published, 0.3 in the spec's F configurations)")
    mu: float = Field(MU_EARTH, gt=0, description="m^3/s^2")
    a: float = Field(6778.1336e3, gt=0, description="chief semi-major axis, m")
    e: float = Field(0.01, ge=0, lt=1, description="chief eccentricity")
    f0: float = Field(0.0, description="chief true anomaly at t = 0, rad (A4)")
    printed_omega_dot: bool = Field(False, description="use the papers' printed dw/dt (A3)")
    r0: Vec3 = Field((1.0, -16.0, 0.0), description="initial position, m (Table 2, literal, A1)")
    v0: Vec3 = Field((0.0, 0.0, 0.0), description="initial velocity, m/s")
    r_f: Vec3 = Field((-5.0, -0.913043, -0.304348), description="goal, m ([W 20])")
    dt: float = Field(1.0, gt=0, description="control period, s ([W 21])")
    t_f: float = Field(800.0, gt=0, description="final time, s ([W 21])")
    n_sub: int = Field(10, ge=1, description="RK4 sub-steps per period (spec 8)")
    deputy_mass: float = Field(50.0, gt=0, description="kg (Table 1)")
    max_thrust: float = Field(30.0, gt=0, description="N (Table 1)")
    saturation: Literal["norm", "per_axis", "none"] = Field("norm", description="A13")
    P: Vec3 = Field((1.2e-2, 1.2e-2, 1.2e-2), description="attraction gain diag ([W 23])")
    M: Vec3 = Field((0.8, 0.6, 0.4), description="repulsion gain diag ([W 23])")
    k_s: Vec3 = Field((10.0, 6.0, 8.0), description="surface gain diag ([W 23])")
    lambda1: Vec3 = Field((1.5e-2, 1.5e-2, 1.5e-2), description="reaching gain diag ([W 23])")
    lambda2: Vec3 = Field((1e-2, 1e-2, 1e-2), description="reaching gain diag ([W 23])")
    alpha: float = Field(0.9999, gt=0, lt=1, description="reaching exponent ([W 23])")
    xi0: float = Field(0.01, gt=0, description="NTSMC ([W 23])")
    xi1: Vec3 = Field((1e-2, 1e-3, 1e-3), description="NTSMC diag ([W 23])")
    xi2: Vec3 = Field((1.0, 0.8, 0.8), description="NTSMC diag ([W 23])")
    tau: float = Field(1.5, gt=1, description="NTSMC ([W 23])")
    p: int = Field(5, ge=1, description="NTSMC odd exponent numerator ([W 23])")
    q: int = Field(7, ge=1, description="NTSMC odd exponent denominator ([W 23])")
    ntsmc_eps: float = Field(1e-6, ge=0, description="m/s, stall floor (A17; 0 = as published)")
    apf_psi: float = Field(0.1, gt=0, description="APF height ([W 23])")
    apf_n: Vec3 = Field((5.5e-4, 5.5e-4, 5.5e-4), description="APF shape diag, 1/m^2 ([W 23])")
    apf_sigma: float = Field(1.0, gt=0, description="APF width ([W 23])")
    apf_center: Vec3 = Field((0.0, 0.0, 0.0), description="APF obstacle centre, m (A12)")
    panel_half_thickness: float = Field(0.05, ge=0, description="m (spec 4.2)")
    antenna_half_width: float = Field(0.10, ge=0, description="m (spec 4.2)")
    body_tolerance: float = Field(0.01, ge=0, description="allowed body penetration, m (A8)")
    deputy_radius: float = Field(0.0, ge=0, description="m (a point in [W])")
    record_interval: float = Field(10.0, gt=0, description="s between recorded series points")
    reach_tolerance: float = Field(0.05, gt=0, description="m; goal reached (claim W10, A32)")
    kernel: KernelParam = kernel_field()
    threads: int = Field(
        0, ge=0, description="threads of the numba kernel; 0: all cores (set 1 when batches "
                             "already run in parallel worker processes)")

    @model_validator(mode="after")
    def _grid(self) -> GMMProximityParams:
        steps = whole_steps(self.t_f, self.dt, "t_f")
        recording_stride(self.record_interval, self.dt, steps, "record_interval", span_name="t_f")
        if self.p % 2 == 0 or self.q % 2 == 0 or self.p >= self.q:
            raise ValueError(f"p and q must be odd with p < q, got {self.p}, {self.q}")
        return self
