"""Parameters of the ``ft_as`` model: the paper's section 5.1 scenario, SI units."""

from __future__ import annotations

from dataclasses import fields
from typing import Literal

import numpy as np
from pydantic import Field, PositiveFloat, model_validator

from ..base import ModelParams
from ..kernels import KernelParam, kernel_field
from ..time_grid import whole_steps
from . import scenario
from .runner import Timing
from .setup import Gains, Plant


class FTASParams(ModelParams):
    """Fixed parameters of the FT-AS model (defaults: the paper's nominal scenario).

    Where the paper leaves a choice (FT-AS-A by default, FT-AS-P off, switching term in input units,
    ``step = 0.01`` s over 3000 s): docs/papers.md#ft-as-conventions-variants-and-checks.
    ``output_interval`` sets only the recorded series (metrics are computed at every step), kept
    coarse so that Monte Carlo batches of thousands of runs fit in memory.
    """

    controller: Literal["ft_as", "case1", "case2"] = Field(
        default="ft_as", description="FT-AS (eq 29 + FT-DO + saturation), Case 1 or Case 2"
    )
    ft_as_observer_input: Literal["applied", "command"] = Field(
        default="applied", description="FT-AS: input the FT-DO sees (command = literal eq 20)"
    )
    psi2_bound: PositiveFloat | None = Field(
        default=None, description="FT-AS-P box |psi2_k| <= bound [m/s^2, 1/s^2]; None: off"
    )
    switch_units: Literal["input", "accel"] = Field(
        default="input", description="[A10] units of gamma sign(s): N/N m or e2-acceleration"
    )
    switch_boundary: float = Field(
        default=0.0, ge=0.0, description="tanh boundary layer of sign(s); 0: sign (paper)"
    )
    observer_norm: Literal["joint", "per_channel"] = Field(
        default="joint", description="[A12] FT-DO norm over R^6 or per 3-D channel"
    )
    omega_chi: PositiveFloat = Field(
        default=0.05, description="Case 2 compensator natural frequency [rad/s] ([A14])"
    )
    kernel: KernelParam = kernel_field("numba")
    threads: int = Field(
        default=0, ge=0, description="threads of the numba kernel (blocks of samples in "
        "parallel); 0: all cores (set 1 when batches already run in parallel worker processes)"
    )
    # --- integration (section 9)
    step: PositiveFloat = Field(default=0.01, description="RK4 / ZOH step [s]")
    duration: PositiveFloat = Field(default=3000.0, description="horizon [s]")
    output_interval: PositiveFloat = Field(default=10.0, description="series grid spacing [s]")
    final_window: PositiveFloat = Field(default=200.0, description="final-accuracy window [s]")
    late_time: float = Field(default=300.0, ge=0.0, description="start of late-peak window [s]")
    # --- plant (section 3.1) and scenario (section 2)
    mass: PositiveFloat = Field(default=600.0, description="nominal mass m0 [kg]")
    inertia: list[list[float]] = Field(
        default=scenario.J0_NOMINAL.tolist(), description="nominal inertia J0 [kg m^2] ([A3])"
    )
    force_limit: PositiveFloat = Field(default=2.0, description="per-axis force limit [N]")
    torque_limit: PositiveFloat = Field(default=1.0, description="per-axis torque limit [N m]")
    force_disturbance_amplitude: float = Field(default=1e-3, ge=0.0, description="A_f [N]")
    torque_disturbance_amplitude: float = Field(default=1e-5, ge=0.0, description="A_tau [N m]")
    reference_semi_major_axis: PositiveFloat = Field(default=7000.5e3, description="[m]")
    actual_semi_major_axis: PositiveFloat = Field(default=7000.0e3, description="[m]")
    inclination_deg: float = Field(default=28.5, description="both orbits [deg]")
    raan_deg: float = Field(default=100.0, description="both orbits [deg]")
    arg_perigee_deg: float = Field(default=0.0, description="both orbits [deg]")
    mean_anomaly_deg: float = Field(default=130.0, description="both orbits at t = 0 [deg]")
    # --- gains (section 5.1)
    nu1: PositiveFloat = 0.001
    eta1: PositiveFloat = 0.04
    nu2: PositiveFloat = 0.01
    eta2: PositiveFloat = 0.001
    m1_over_n1: PositiveFloat = 2.0
    p1_over_q1: float = Field(default=0.9, gt=0.5, lt=1.0, description="1 < q1/p1 < 2")
    m2_over_n2: PositiveFloat = 1.1
    p2_over_q2: PositiveFloat = 0.6
    epsilon: PositiveFloat = 0.01
    gamma: float = Field(default=0.05, ge=0.0)
    observer_p: float = Field(default=1.2, gt=1.0)
    lambda1: PositiveFloat = 0.5
    lambda2: PositiveFloat = 0.1
    lambda3: PositiveFloat = 0.1

    @model_validator(mode="after")
    def _consistent(self) -> FTASParams:
        J = np.asarray(self.inertia, dtype=float)
        if J.shape != (3, 3) or not np.allclose(J, J.T):
            raise ValueError("inertia must be a symmetric 3x3 matrix [kg m^2]")
        if np.any(np.linalg.eigvalsh(J) <= 0.0):
            raise ValueError("inertia must be positive definite")
        for name in ("duration", "output_interval"):
            whole_steps(getattr(self, name), self.step, name, "step", rtol=1e-6)
        if self.output_interval > self.duration or self.final_window > self.duration:
            raise ValueError("output_interval and final_window must not exceed duration")
        if self.m1_over_n1 - self.p1_over_q1 <= 1.0:
            raise ValueError("m1/n1 - p1/q1 must be greater than 1 (eq 26)")
        return self

    def gains(self) -> Gains:
        return Gains(
            nu1=self.nu1, eta1=self.eta1, nu2=self.nu2, eta2=self.eta2, m1n1=self.m1_over_n1,
            p1q1=self.p1_over_q1, m2n2=self.m2_over_n2, p2q2=self.p2_over_q2, eps=self.epsilon,
            gamma=self.gamma, obs_p=self.observer_p, lam1=self.lambda1, lam2=self.lambda2,
            lam3=self.lambda3, boundary=self.switch_boundary,
            obs_per_channel=self.observer_norm == "per_channel",
        )  # fmt: skip

    def orbit(self, a: float) -> scenario.CircularOrbit:
        return scenario.CircularOrbit(
            a, self.inclination_deg, self.raan_deg, self.arg_perigee_deg, self.mean_anomaly_deg
        )

    def plant(self) -> Plant:
        limits = np.array([self.force_limit] * 3 + [self.torque_limit] * 3)
        return Plant(
            self.mass, np.asarray(self.inertia, float), self.orbit(self.reference_semi_major_axis),
            limits,
        )  # fmt: skip

    def timing(self, **override: float) -> Timing:
        return Timing(**{f.name: getattr(self, f.name) for f in fields(Timing)} | override)
