"""GMM-based close-range proximity to a complex-shaped chief (Wang et al. 2022, [W]).

:class:`GMMProximity` builds the scenario's pieces (geometry, mixture, controller) from its
parameters and runs the compiled closed loop (:mod:`.kernel_numba`). The scenario, the uncertain
inputs and where the paper is silent: docs/papers.md#gmm-proximity-scenario-inputs-and-outputs;
the laws and potentials: docs/papers.md#gmm-potentials-and-controllers. The paper's report and
figures are in :mod:`uqguide.papers.gmm_proximity`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from functools import lru_cache

import numpy as np

from ..base import InputInfo, Model, OutputInfo, StepCount, failure_reasons
from ...core.types import ModelOutput
from ..dynamics.tschauner_hempel import ChiefOrbit, LVLHPlant
from ..kernels import numba_threads
from .controllers import NTSMC, TSMC, ReachingLaw
from .gauss_sum import GaussSum
from .geometry import ChiefGeometry, wang2022_chief
from .mixture import WANG2022_PUBLISHED, Mixture
from .params import GMMProximityParams
from .potential import AttractRepulsePotential
from .loop import SampledRun, StepSchedule, build_schedule

log = logging.getLogger(__name__)

FITTED_FILE = "gmm_wang2022_fitted.npz"


def _gmm_shift(values: Mapping[str, np.ndarray]) -> np.ndarray:
    """The per-sample translation of the repulsive kernels, shape (n, 3) [m]."""
    return np.stack([values["gmm_shift_x"], values["gmm_shift_y"], values["gmm_shift_z"]], 1)


@lru_cache(maxsize=8)
def _schedule(a: float, e: float, f0: float, mu: float, printed: bool, t_f: float, dt: float,
              n_sub: int) -> StepSchedule:
    # The chief orbit is shared by every sample and every call: one RK4 map set per scenario.
    return build_schedule(LVLHPlant(ChiefOrbit(a, e, f0, mu), printed), t_f, dt, n_sub)


@lru_cache(maxsize=1)
def fitted_mixture() -> Mixture:
    """The k-means + EM fit of the [W] chief shipped as package data
    (scripts/fit_gmm_wang2022.py)."""
    return Mixture.packaged(FITTED_FILE)


def _compiled() -> Callable[..., SampledRun]:
    # imported on first use (compiles or loads the cache); tests/oracles substitutes NumPy here
    from .kernel_numba import simulate_compiled

    return simulate_compiled


_PERTURBATION = ("gmm_shift_x", "gmm_shift_y", "gmm_shift_z", "gmm_mean_scale", "gmm_cov_scale")
_NOMINAL = (0.0, 0.0, 0.0, 1.0, 1.0)


class GMMProximity(Model):
    """APF-TSMC / GMM-TSMC / GMM-NTSMC proximity manoeuvre near the [W] chief (module docstring)."""

    name = "gmm_proximity"
    summary = ("GMM-potential sliding-mode proximity to a box/panel/antenna chief "
               "(Wang et al. 2022): clearance, collision, delta-v, final error")
    Params = GMMProximityParams
    params: GMMProximityParams

    _INPUTS = (
        InputInfo("dx0", "m", "error added to the initial radial position", 0.0),
        InputInfo("dy0", "m", "error added to the initial along-track position", 0.0),
        InputInfo("dz0", "m", "error added to the initial cross-track position", 0.0),
        InputInfo("dvx0", "m/s", "error added to the initial radial velocity", 0.0),
        InputInfo("dvy0", "m/s", "error added to the initial along-track velocity", 0.0),
        InputInfo("dvz0", "m/s", "error added to the initial cross-track velocity", 0.0),
        InputInfo("thrust_scale", "1", "applied / commanded thrust (magnitude error), > 0", 1.0),
        InputInfo("gmm_shift_x", "m",
                  "controller's chief-position error along x (GMM and APF)", 0.0),
        InputInfo("gmm_shift_y", "m",
                  "controller's chief-position error along y (GMM and APF)", 0.0),
        InputInfo("gmm_shift_z", "m",
                  "controller's chief-position error along z (GMM and APF)", 0.0),
        InputInfo("gmm_mean_scale", "1", "scale of the GMM component means about the centre", 1.0),
        InputInfo("gmm_cov_scale", "1", "scale of every GMM covariance", 1.0),
    )

    def inputs(self) -> tuple[InputInfo, ...]:
        return self._INPUTS

    def step_count(self) -> StepCount:
        p = self.params
        return StepCount(p.t_f / p.dt * p.n_sub, p.t_f / p.record_interval + 1, "dt",
                         "t_f / dt x n_sub")

    def outputs(self) -> tuple[OutputInfo, ...]:
        parts = self.geometry().names
        xyz = ("x", "y", "z")
        return (
            OutputInfo("range", "series", "m", "distance to the chief's centre |r|"),
            OutputInfo("position", "series", "m", "relative position in LVLH", xyz, default=False),
            OutputInfo("velocity", "series", "m/s", "relative velocity in LVLH", xyz,
                       default=False),
            OutputInfo("los_rate", "series", "rad/s", "LOS rate |r x v| / |r|^2 (LVLH)",
                       default=False),
            OutputInfo("position_error", "series", "m", "|r - r_f|", default=False),
            OutputInfo("zem", "series", "m", "zero-effort miss to the goal at t_f", default=False),
            OutputInfo("delta_v_history", "series", "m/s", "accumulated delta-v ([W 24])",
                       default=False),
            OutputInfo("min_clearance", "scalar", "m",
                       "minimum distance of the path to the panels and antennas (zero "
                       "thickness; the body is left out: the goal lies on its face)"),
            OutputInfo("collided", "scalar", "1",
                       "1 if the path crossed any part (swept test, spec 4.2): its mean is the "
                       "probability of collision"),
            OutputInfo("delta_v", "scalar", "m/s", "total delta-v sum |u_k| dt ([W 24])"),
            OutputInfo("final_error", "scalar", "m", "|r(t_f) - r_f|"),
            OutputInfo("final_speed", "scalar", "m/s", "|v(t_f)|", default=False),
            OutputInfo("clearance_parts", "scalar", "m", "minimum clearance to each part", parts,
                       default=False),
            OutputInfo("collided_parts", "scalar", "1", "1 if the path crossed the part", parts,
                       default=False),
            OutputInfo("body_penetration", "scalar", "m", "deepest point inside the body",
                       default=False),
            OutputInfo("min_range", "scalar", "m", "closest approach to the chief's centre",
                       default=False),
            OutputInfo("n_saturated", "scalar", "1", "control periods with saturated thrust",
                       default=False),
        )

    # ------------------------------------------------------------------ scenario pieces
    def geometry(self) -> ChiefGeometry:
        """The [W] chief with this configuration's thicknesses (A7)."""
        p = self.params
        return wang2022_chief(p.panel_half_thickness, p.antenna_half_width, p.body_tolerance,
                              p.deputy_radius)

    def _appendages(self) -> np.ndarray:
        """Indices of the thin parts (panels, antennas)."""
        return np.array([i for i, p in enumerate(self.geometry().parts) if p.kind != "solid"])

    def schedule(self) -> StepSchedule:
        p = self.params
        return _schedule(p.a, p.e, p.f0, p.mu, p.printed_omega_dot, p.t_f, p.dt, p.n_sub)

    def mixture(self) -> Mixture:
        """The GMM the controller uses (published or fitted, with the optional variance floor)."""
        p = self.params
        mix = WANG2022_PUBLISHED if p.gmm_source == "published" else fitted_mixture()
        return mix.with_variance_floor(p.gmm_sigma_floor**2)

    def repulsion(self, controller: str, values: Mapping[str, np.ndarray] | None = None,
                  n: int = 1) -> GaussSum:
        """The repulsive kernels of ``controller``, per sample when the GMM is perturbed."""
        p = self.params
        apf = controller == "apf_tsmc"
        if apf:  # only the shift applies to the APF obstacle
            gs = GaussSum.from_apf([p.apf_psi], [p.apf_center], [np.diag(p.apf_n)], [p.apf_sigma])
        else:
            gs = self.mixture().to_gauss_sum(p.gmm_norm)
        if values is None or all(np.all(values[k] == n_) for k, n_ in
                                 zip(_PERTURBATION, (0.0, 0.0, 0.0) if apf else _NOMINAL)):
            return gs
        shift = _gmm_shift(values)
        if apf:
            return GaussSum(gs.c, gs.mu[None] + shift[:, None, :], gs.L)
        s_mu = values["gmm_mean_scale"][:, None, None]
        s_cov = values["gmm_cov_scale"]
        return GaussSum(
            gs.c[None] * s_cov[:, None] ** -1.5,
            s_mu * gs.mu[None] + shift[:, None, :],
            gs.L[None] / s_cov[:, None, None, None],
        )

    def controller(self, controller: str, repulsion: GaussSum) -> TSMC | NTSMC:
        p = self.params
        pot = AttractRepulsePotential(np.diag(p.P), np.diag(p.M), repulsion)
        reach = ReachingLaw(np.asarray(p.lambda1), np.asarray(p.lambda2), p.alpha)
        if controller == "gmm_ntsmc":
            return NTSMC(pot, np.asarray(p.r_f), np.asarray(p.k_s), reach, p.xi0, np.asarray(p.xi1),
                         np.asarray(p.xi2), p.tau, p.p, p.q, p.ntsmc_eps)
        return TSMC(pot, np.asarray(p.r_f), np.asarray(p.k_s), reach)

    def run(self, values: Mapping[str, np.ndarray], n: int, controller: str | None = None,
            record_every: int | None = None, zem: bool = False) -> SampledRun:
        """Simulate ``n`` samples (inputs by name, as :meth:`_evaluate` receives them)."""
        p = self.params
        name = controller or p.controller
        x0 = np.empty((n, 6))
        x0[:, :3] = np.asarray(p.r0) + np.stack([values["dx0"], values["dy0"], values["dz0"]], 1)
        x0[:, 3:] = np.asarray(p.v0) + np.stack([values["dvx0"], values["dvy0"], values["dvz0"]], 1)
        scale = values["thrust_scale"]
        a_max = np.inf if p.saturation == "none" else p.max_thrust / p.deputy_mass
        if record_every is None:
            record_every = int(round(p.record_interval / p.dt))
        args = (self.schedule(), self.controller(name, self.repulsion(name, values, n)), x0,
                self.geometry())
        options = dict(a_max=a_max, per_axis_saturation=p.saturation == "per_axis",
                       thrust_scale=None if np.all(scale == 1.0) else scale,
                       record_every=record_every, goal=np.asarray(p.r_f) if zem else None)
        with numba_threads(p.threads):
            return _compiled()(*args, **options)

    # ------------------------------------------------------------------ contract
    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        values = {k: np.asarray(v, dtype=float) for k, v in values.items()}
        invalid = np.zeros(n, dtype=bool)
        for key in ("thrust_scale", "gmm_mean_scale", "gmm_cov_scale"):
            bad = ~(values[key] > 0)
            if bad.any():
                invalid |= bad
                values[key] = np.where(bad, 1.0, values[key])  # run a placeholder, flag it
        run = self.run(values, n, zem="zem" in outputs)
        r, v = run.r, run.v
        r_f = np.asarray(self.params.r_f)
        rng = np.linalg.norm(r, axis=2)
        series_src = {
            "range": lambda: rng[..., None],
            "position": lambda: r,
            "velocity": lambda: v,
            "los_rate": lambda: (np.linalg.norm(np.cross(r, v), axis=2) / rng**2)[..., None],
            "position_error": lambda: np.linalg.norm(r - r_f, axis=2)[..., None],
            "zem": lambda: np.asarray(run.zem)[..., None],  # run(zem=True) computed it
            "delta_v_history": lambda: run.delta_v_history[..., None],
        }
        series = {k: f() for k, f in series_src.items() if k in outputs}
        scalars = {
            "min_clearance": run.clearance[:, self._appendages()].min(axis=1)[:, None],
            "collided": run.collided.astype(float)[:, None],
            "delta_v": run.delta_v[:, None],
            "final_error": np.linalg.norm(r[:, -1] - r_f, axis=1)[:, None],
            "final_speed": np.linalg.norm(v[:, -1], axis=1)[:, None],
            "clearance_parts": run.clearance,
            "collided_parts": run.hits.astype(float),
            "body_penetration": run.penetration[:, None],
            "min_range": run.min_range[:, None],
            "n_saturated": run.n_saturated.astype(float)[:, None],
        }
        failed = run.failed | invalid
        reasons = failure_reasons(run.failed, "non-finite state")
        reasons[invalid] = "thrust_scale, gmm_mean_scale and gmm_cov_scale must be positive"
        return ModelOutput(time=run.time, series=series,
                           scalars={k: v for k, v in scalars.items() if k in outputs},
                           failed=failed, reasons=reasons)
