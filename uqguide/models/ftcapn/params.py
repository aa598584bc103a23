"""Parameters of the ``ftcapn`` model: the paper's nominal scenario (Wang & Song 2019, section
2.2, Tables 1-2) with choices where the paper gives none (docs/papers.md#ftcapn-beside-the-paper);
SI units."""

from __future__ import annotations

import math
from typing import Literal

from pydantic import Field, model_validator

from ..base import ModelParams
from ..dynamics.hill import MU_EARTH
from ..kernels import KernelParam, kernel_field

__all__ = ["FTCAPNParams"]


class FTCAPNParams(ModelParams):
    """FTCAPN parameters (SI units); defaults are the paper's nominal scenario (section 2.2)
    with choices for the settings the paper does not give (N, A_sat, delta)."""

    c: float = Field(0.1, ge=0.0, description="sliding-surface slope [1/s] (eq 4)")
    eps: float = Field(5.0, ge=0.0, description="constant reaching gain [m/s^2] (eq 6)")
    beta: float = Field(2.0, ge=0.0, description="power reaching gain (eq 6)")
    eta: float = Field(0.2, gt=0.0, lt=1.0, description="power reaching exponent (eq 6)")
    N: float = Field(3.0, ge=0.0, description="navigation constant (eq 3); spec choice")
    A_sat: float = Field(10.0, gt=0.0, description="LOS acceleration limit [m/s^2] (eq 13)")
    delta: float = Field(50.0, gt=0.0, description="boundary layer of sgn_d [m/s] (eq 14)")
    dt: float = Field(0.5, gt=0.0, description="control/integration step [s] (section 4.4)")
    r_stop: float = Field(50.0, gt=0.0, description="range at which midrange control stops [m]")
    t_max: float = Field(400.0, gt=0.0, description="a run not stopped by then fails [s]")
    t_final: float | None = Field(
        None, gt=0.0,
        description="end of the output time grid [s]; default: the nominal run's stop time "
                    "rounded up to the step")
    gravity: Literal["none", "hill"] = Field(
        "none", description="'none': straight-line relative motion (paper eqs 2-3); 'hill': "
                            "CW terms of the Table 1 circular orbit")
    semi_major_axis: float = Field(7043.14e3, gt=0.0, description="target orbit radius [m]")
    mu: float = Field(MU_EARTH, gt=0.0, description="gravitational parameter [m^3/s^2]")
    chaser_position: tuple[float, float, float] = Field(
        (4386.28, 308.60, 3204.43), description="chaser relative to target [m] (Table 2)")
    chaser_velocity: tuple[float, float, float] = Field(
        (-57.7, 2.1, -38.5), description="chaser relative to target [m/s] (Table 2)")
    control: bool = Field(True, description="False: free drift (for checks against closed forms)")
    los_settle_fraction: float = Field(
        0.05, gt=0.0, lt=1.0, description="threshold of t_los_settle, fraction of omega_s(0)")
    maneuver_frame: Literal["initial", "rotating"] = Field(
        "initial", description="target maneuver components along the nominal initial LOS "
                               "frame (fixed vector) or along each sample's current LOS frame "
                               "(rotating; frozen at the stop for the ZEM drift)")
    kernel: KernelParam = kernel_field()
    threads: int = Field(
        0, ge=0, description="threads of the numba kernel; 0: all cores (set 1 when batches "
                             "already run in parallel worker processes)")

    @model_validator(mode="after")
    def _times(self) -> FTCAPNParams:
        if self.t_max < self.dt:
            raise ValueError(f"t_max must be at least dt = {self.dt} s, got {self.t_max} s")
        if self.t_final is not None and self.t_final > self.t_max:
            raise ValueError(
                f"t_final must not exceed t_max = {self.t_max} s, got {self.t_final} s")
        if math.hypot(*self.chaser_position) <= 0.0:
            raise ValueError("chaser_position must be non-zero (the range would be zero)")
        return self
