"""GMM-FTC: safe proximity to a rotating, complex-shaped target (Chen et al. 2020, [C]).

The servicer approaches a spinning target in its body frame
(:mod:`..dynamics.rotating_body_frame`) under the fixed-time law (:mod:`.law`) whose potential
encodes the target's shape by a 12-component GMM (:mod:`.target`); defaults are the paper's
scenario. The inputs, outputs and choices, with the ambiguities they settle:
docs/papers.md#gmm-ftc-target-thruster-error-and-inputs.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping

import numpy as np

from ..base import InputInfo, Model, OutputInfo, StepCount
from ...core.types import ModelOutput
from ..dynamics.rotating_body_frame import RotatingBodyFrame
from ..dynamics.tschauner_hempel import ChiefOrbit
from ..gmm.potential import AttractRepulsePotential
from . import noise
from .loop import LoopRun, LoopSettings
from .law import FTCGains, GMMFTCLaw
from .params import GMMFTCParams
from .target import target_geometry, target_mixture

log = logging.getLogger(__name__)

XYZ = ("x", "y", "z")
PARTS = ("body", "panel+x", "panel-x", "antenna+y", "antenna-y")

INPUT_INFO: tuple[InputInfo, ...] = (
    InputInfo("dx0", "m", "error added to the initial body-frame position, x"),
    InputInfo("dy0", "m", "error added to the initial body-frame position, y"),
    InputInfo("dz0", "m", "error added to the initial body-frame position, z"),
    InputInfo("dvx0", "m/s", "error added to the initial body-frame velocity, x"),
    InputInfo("dvy0", "m/s", "error added to the initial body-frame velocity, y"),
    InputInfo("dvz0", "m/s", "error added to the initial body-frame velocity, z"),
    InputInfo("dw_x", "rad/s", "error added to the target spin rate (body x, relative to LVLH)"),
    InputInfo("dw_y", "rad/s", "error added to the target spin rate (body y)"),
    InputInfo("dw_z", "rad/s", "error added to the target spin rate (body z)"),
    InputInfo("thrust_scale", "-", "thruster output factor, all axes, held over the run", 1.0),
    InputInfo("thrust_scale_x", "-", "thruster output factor, body x axis", 1.0),
    InputInfo("thrust_scale_y", "-", "thruster output factor, body y axis", 1.0),
    InputInfo("thrust_scale_z", "-", "thruster output factor, body z axis", 1.0),
)

SERIES_INFO: tuple[OutputInfo, ...] = (
    OutputInfo("pos_error", "series", "m", "position error y1 = r - r_f, body frame (Fig 7)",
               XYZ, default=False),
    OutputInfo("pos_error_norm", "series", "m", "|r - r_f|"),
    OutputInfo("velocity", "series", "m/s", "velocity error y2 = r', body frame (Fig 8)", XYZ,
               default=False),
    OutputInfo("speed", "series", "m/s", "|r'|, body frame"),
    OutputInfo("u_body", "series", "m/s^2", "applied thrust acceleration, body frame (Fig 9)",
               XYZ, default=False),
    OutputInfo("u_norm", "series", "m/s^2", "|u| of the applied thrust"),
    OutputInfo("u_lvlh", "series", "m/s^2", "applied thrust in LVLH, C u (physical thrust)", XYZ,
               default=False),
    OutputInfo("u_eq32_lvlh", "series", "m/s^2",
               "eq (32) diagnostic C (u + 2 w x v + w x (w x r)) in LVLH (Fig 11)", XYZ,
               default=False),
    OutputInfo("r_lvlh", "series", "m", "position in LVLH (Fig 10)", XYZ, default=False),
    OutputInfo("v_lvlh", "series", "m/s", "velocity relative to LVLH, LVLH axes", XYZ,
               default=False),
    OutputInfo("range", "series", "m", "distance to the target's centre"),
    OutputInfo("los_rate", "series", "rad/s", "LOS rate |r_l x v_l| / |r_l|^2 in LVLH"),
    OutputInfo("s2_norm", "series", "m/s", "|s2|, the fixed-time sliding variable (eq 21)",
               default=False),
    OutputInfo("dv_cum", "series", "m/s", "accumulated delta-v", default=False),
)

SCALAR_INFO: tuple[OutputInfo, ...] = (
    OutputInfo("collided", "scalar", "-", "1 if the swept path hit any part (spec 4.2), else 0; "
               "its MC mean is the probability of collision"),
    OutputInfo("min_clearance", "scalar", "m", "minimum distance of the path to the target's "
               "zero-thickness skeleton"),
    OutputInfo("clearance_parts", "scalar", "m", "minimum clearance per part", PARTS,
               default=False),
    OutputInfo("t_converge", "scalar", "s", "time after which |r - r_f| < converge_tol for good "
               "(t_final if never: censored)"),
    OutputInfo("converged", "scalar", "-", "1 if |r - r_f| < converge_tol at the end",
               default=False),
    OutputInfo("t_settle", "scalar", "s", "time after which |r - r_f| < settle_tol for good "
               "(not censored by steady offsets of a few 1e-4 m)"),
    OutputInfo("t_converge_vel", "scalar", "s", "time after which |r'| < velocity_tol",
               default=False),
    OutputInfo("t_reach_s2", "scalar", "s", "time after which |s2| < 1e-6 m/s (compare the "
               "eq 36 bound)", default=False),
    OutputInfo("pos_error_final", "scalar", "m", "max |r - r_f| for t >= t_check"),
    OutputInfo("speed_final", "scalar", "m/s", "max |r'| for t >= t_check", default=False),
    OutputInfo("speed_max", "scalar", "m/s", "max |r'| over the run"),
    OutputInfo("speed_max_axes", "scalar", "m/s", "max |r'_i| per body axis", XYZ,
               default=False),
    OutputInfo("u_max", "scalar", "m/s^2", "max |u| over the run"),
    OutputInfo("u_max_converged", "scalar", "m/s^2", "max |u| after t_converge (NaN if never)",
               default=False),
    OutputInfo("u_final", "scalar", "m/s^2", "|u| at t_final (station keeping, -u_eq)",
               default=False),
    OutputInfo("delta_v", "scalar", "m/s", "delta-v, sum |u_k| dt of the applied thrust"),
    OutputInfo("range_min", "scalar", "m", "minimum distance to the target's centre",
               default=False),
    OutputInfo("los_rate_max", "scalar", "rad/s", "max LOS rate on the output grid",
               default=False),
)


def _compiled() -> Callable[..., LoopRun]:
    # imported on first use (compiles or loads the cache); tests/oracles substitutes NumPy here
    from .kernel_numba import run_closed_loop_numba

    return run_closed_loop_numba


class GMMFTC(Model):
    """GMM-FTC proximity to a spinning complex-shaped target ([C]), vectorised over samples."""

    name = "gmm_ftc"
    fidelity_params = ("dt",)
    summary = ("GMM-based fixed-time control approaching a tumbling complex-shaped target in "
               "its body frame (Chen et al. 2020)")
    Params = GMMFTCParams
    example_params = {"t_final": 20.0}
    params: GMMFTCParams

    def inputs(self) -> tuple[InputInfo, ...]:
        return INPUT_INFO

    def step_count(self) -> StepCount:
        p = self.params
        return StepCount(p.t_final / p.dt, p.t_final / p.record_dt + 1, "dt", "t_final / dt")

    def outputs(self) -> tuple[OutputInfo, ...]:
        return SERIES_INFO + SCALAR_INFO

    # ------------------------------------------------------------------ building blocks
    def orbit(self) -> ChiefOrbit:
        p = self.params
        return ChiefOrbit(p.semi_major_axis, p.eccentricity, p.f0, p.mu)

    def law(self) -> GMMFTCLaw:
        """GMM-FTC with the configured gains and target GMM."""
        p = self.params
        mixture = target_mixture(p.gmm).with_variance_floor(p.variance_floor)
        potential = AttractRepulsePotential(np.diag(p.P), np.diag(p.M),
                                            mixture.to_gauss_sum(p.norm))
        gains = FTCGains(np.asarray(p.alpha1), np.asarray(p.beta1), np.asarray(p.lambda1),
                         np.asarray(p.lambda2), p.zeta1, p.zeta2, np.asarray(p.k_s))
        return GMMFTCLaw(potential, np.asarray(p.r_f), gains)

    def settings(self, thrust_noise: float | None = None) -> LoopSettings:
        p = self.params
        return LoopSettings(
            dt=p.dt, n_sub=p.n_sub, t_final=p.t_final,
            record_every=round(p.record_dt / p.dt),
            thrust_noise=p.thrust_noise if thrust_noise is None else thrust_noise,
            converge_tol=p.converge_tol, settle_tol=p.settle_tol, velocity_tol=p.velocity_tol,
            t_check=p.t_check,
            u_max=np.inf if p.u_max is None else p.u_max,
        )

    def simulate(self, values: Mapping[str, np.ndarray], n: int,
                 settings: LoopSettings | None = None, noise_keys: np.ndarray | None = None
                 ) -> LoopRun:
        """Closed-loop runs for inputs ``values`` (each (n,)); see
        :func:`.kernel_numba.run_closed_loop_numba`.

        ``noise_keys`` (n,) overrides the keys derived from ``noise_seed`` and the inputs.
        """
        p = self.params
        col = {i.name: np.broadcast_to(np.asarray(values[i.name], dtype=float), (n,))
               for i in INPUT_INFO}
        x0 = np.empty((n, 6))
        x0[:, :3] = np.asarray(p.r0) + np.stack([col["dx0"], col["dy0"], col["dz0"]], axis=1)
        x0[:, 3:] = np.asarray(p.v0) + np.stack([col["dvx0"], col["dvy0"], col["dvz0"]], axis=1)
        dw = np.stack([col["dw_x"], col["dw_y"], col["dw_z"]], axis=1)
        w = np.asarray(p.spin_rate) + dw
        if np.all(w == w[0]):
            w = w[:1]  # common spin: plant matrices computed once for the batch
        orbit = self.orbit()
        printed = p.controller_model == "printed"
        plant = RotatingBodyFrame(orbit, w)
        ctl_w = np.asarray([p.spin_rate]) if p.controller_spin == "nominal" else w
        controller_plant = None
        if printed or p.controller_spin == "nominal":
            controller_plant = RotatingBodyFrame(orbit, ctl_w, printed=printed)
        scale = col["thrust_scale"][:, None] * np.stack(
            [col["thrust_scale_x"], col["thrust_scale_y"], col["thrust_scale_z"]], axis=1)
        st = self.settings() if settings is None else settings
        if noise_keys is None and st.thrust_noise > 0:
            noise_keys = noise.sample_keys(p.noise_seed, np.stack(list(col.values()), axis=1))
        geometry = target_geometry(p.panel_half_thickness, p.antenna_half_width,
                                   p.body_tolerance)
        return _compiled()(plant, controller_plant, self.law(), geometry, x0, st,
                           thrust_scale=scale, noise_keys=noise_keys)

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]
                  ) -> ModelOutput:
        run = self.simulate(values, n)
        return to_model_output(run, outputs)


def los_rate(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``|r x v| / |r|^2`` [rad/s] for ``r, v`` (..., 3) (0 where ``r = 0``)."""
    rr = np.sum(r * r, axis=-1)
    w = np.linalg.norm(np.cross(r, v), axis=-1)
    return np.divide(w, rr, out=np.zeros_like(w), where=rr > 0)


def to_model_output(run: LoopRun, outputs: frozenset[str]) -> ModelOutput:
    """The model contract's arrays from a :class:`LoopRun` (only the outputs asked for)."""
    sc = run.scalars
    series_src = {
        "pos_error": lambda: run.r - run.goal,
        "pos_error_norm": lambda: np.linalg.norm(run.r - run.goal, axis=2)[..., None],
        "velocity": lambda: run.v,
        "speed": lambda: np.linalg.norm(run.v, axis=2)[..., None],
        "u_body": lambda: run.u,
        "u_norm": lambda: np.linalg.norm(run.u, axis=2)[..., None],
        "u_lvlh": lambda: run.u_l,
        "u_eq32_lvlh": lambda: run.u_eq32_l,
        "r_lvlh": lambda: run.r_l,
        "v_lvlh": lambda: run.v_l,
        "range": lambda: np.linalg.norm(run.r, axis=2)[..., None],
        "los_rate": lambda: los_rate(run.r_l, run.v_l)[..., None],
        "s2_norm": lambda: run.s2[..., None],
        "dv_cum": lambda: run.dv_cum[..., None],
    }
    series = {k: np.ascontiguousarray(f(), dtype=float) for k, f in series_src.items()
              if k in outputs}
    scalars: dict[str, np.ndarray] = {}
    for info in SCALAR_INFO:
        if info.name in outputs:
            value = (los_rate(run.r_l, run.v_l).max(axis=1) if info.name == "los_rate_max"
                     else sc[info.name])
            scalars[info.name] = np.array(value if value.ndim == 2 else value[:, None],
                                          dtype=float)
    failed = run.failed.copy()
    reasons = np.where(failed, "non-finite state: the closed loop diverged", "").astype(object)
    # a loop that diverges without an inf in its state has failed too
    # (docs/simulators.md#gmm-ftc-a-run-that-diverges)
    overflow = ~failed & ~(np.isfinite(sc["delta_v"]) & np.isfinite(sc["speed_max"]))
    failed |= overflow
    reasons[overflow] = "the closed loop diverged (speed or delta-v overflowed; dt too coarse?)"
    for v in scalars.values():
        v[failed] = np.nan
    return ModelOutput(time=run.time, series=series, scalars=scalars, failed=failed,
                       reasons=reasons)
