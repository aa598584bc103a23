"""FTCAPN: finite-time-convergence augmented proportional navigation (Wang & Song 2019).

Closed-loop midrange rendezvous along the line of sight ``r = r_target - r_chaser``, run in the
compiled kernel (:func:`_compiled`); ``zem`` and ``zem_eq15`` are derived from the stop state
(:meth:`FTCAPN.derived_outputs`). Frames, equations and every choice the paper leaves open (the
maneuver's two readings are ``maneuver_frame``): docs/papers.md#ftcapn-frames-and-choices and
docs/papers.md#ftcapn-beside-the-paper.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Mapping

import numpy as np

from ..base import InputInfo, Model, OutputInfo, StepCount
from ...core.types import DerivedOutput, ModelOutput
from ..dynamics.hill import mean_motion
from ..kernels import numba_threads
from .params import FTCAPNParams
from . import layout as L
from .drift import miss_hill, miss_parabola

log = logging.getLogger(__name__)

SCALAR_INFO: tuple[OutputInfo, ...] = (
    OutputInfo("t_stop", "scalar", "s", "time at which the range reaches r_stop (in-step root)"),
    OutputInfo("Rdot_stop", "scalar", "m/s", "range rate at stop"),
    OutputInfo("speed_stop", "scalar", "m/s", "relative speed |v| at stop"),
    OutputInfo("omega_s_stop", "scalar", "rad/s", "LOS rate at stop", default=False),
    OutputInfo("dv_total", "scalar", "m/s", "total delta-v: integral of |a_c| dt up to the stop"),
    OutputInfo("zem_eq15", "scalar", "m", "zero-effort miss by eq (15): omega_s R^2 / |Rdot|"),
    OutputInfo("zem", "scalar", "m",
               "true closest approach of the uncontrolled drift after the stop (target "
               "maneuver and, with gravity: hill, CW terms included)"),
    OutputInfo("t_zem", "scalar", "s", "time of the closest approach after the stop",
               default=False),
    OutputInfo("t_surface", "scalar", "s",
               "first time |s| <= delta (sliding boundary layer reached; compare eq 12)",
               default=False),
    OutputInfo("t_los_settle", "scalar", "s",
               "time after which omega_s stays below los_settle_fraction * omega_s(0)",
               default=False),
    OutputInfo("ac_max", "scalar", "m/s^2", "largest commanded acceleration |a_c|",
               default=False),
    OutputInfo("r_at_stop", "scalar", "m", "line of sight r at stop", ("x", "y", "z"),
               default=False),
    OutputInfo("v_at_stop", "scalar", "m/s", "its rate v at stop", ("x", "y", "z"),
               default=False),
)

SERIES_INFO: tuple[OutputInfo, ...] = (
    OutputInfo("omega_s", "series", "rad/s", "LOS rate |r x v| / R^2 (eq 1)"),
    OutputInfo("w", "series", "rad/s", "LOS rate vector r x v / R^2", ("x", "y", "z"),
               default=False),
    OutputInfo("R", "series", "m", "range |r|"),
    OutputInfo("Rdot", "series", "m/s", "range rate r.v / R", default=False),
    OutputInfo("s", "series", "m/s", "sliding variable c R_m + Rdot (eq 4, measured range)",
               default=False),
    OutputInfo("a_c", "series", "m/s^2", "commanded acceleration (held over the step)",
               ("x", "y", "z"), default=False),
    OutputInfo("a_c_los", "series", "m/s^2", "commanded acceleration in the LOS frame",
               ("r", "theta", "w"), default=False),
    OutputInfo("dv", "series", "m/s", "accumulated delta-v, integral of |a_c| dt",
               default=False),
    OutputInfo("r", "series", "m", "line of sight r = target - chaser", ("x", "y", "z"),
               default=False),
    OutputInfo("v", "series", "m/s", "line-of-sight rate v = dr/dt", ("x", "y", "z"),
               default=False),
    OutputInfo("speed", "series", "m/s", "relative speed |v|", default=False),
)

INPUT_INFO: tuple[InputInfo, ...] = (
    InputInfo("dx", "m", "initial position error added to r0 (x, Table-2/LVLH axes)"),
    InputInfo("dy", "m", "initial position error added to r0 (y)"),
    InputInfo("dz", "m", "initial position error added to r0 (z)"),
    InputInfo("dvx", "m/s", "initial velocity error added to v0 (x)"),
    InputInfo("dvy", "m/s", "initial velocity error added to v0 (y)"),
    InputInfo("dvz", "m/s", "initial velocity error added to v0 (z)"),
    InputInfo("b_w", "rad/s", "LOS-rate measurement bias, added to omega_s"),
    InputInfo("b_R", "m", "range measurement bias, added to R"),
    InputInfo("at_theta", "m/s^2", "target acceleration along e_theta of the LOS frame "
              "(nominal initial or rotating: maneuver_frame)"),
    InputInfo("at_r", "m/s^2", "target acceleration along e_r of the LOS frame (maneuver_frame)"),
    InputInfo("at_w", "m/s^2", "target acceleration along e_w of the LOS frame (maneuver_frame)"),
)

def _compiled() -> Callable[..., None]:
    # imported on first use (compiles or loads the cache); tests/oracles substitutes NumPy here
    from .kernel_numba import simulate_numba

    return simulate_numba


def los_frames(r: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows ``e_theta, e_r, e_w`` ``(n, 3, 3)`` of the true LOS frames of states ``r, v (n, 3)``
    (``e_theta, e_w`` zero where there is no transverse velocity, as in the kernels)."""
    R = np.linalg.norm(r, axis=1, keepdims=True)
    er = r / R
    vp = v - np.einsum("ij,ij->i", v, er)[:, None] * er
    Vt = np.linalg.norm(vp, axis=1, keepdims=True)
    with np.errstate(divide="ignore", invalid="ignore"):
        et = np.where(Vt > 0.0, vp / Vt, 0.0)
    return np.stack([et, er, np.cross(er, et)], axis=1)


class FTCAPN(Model):
    """FTCAPN closed-loop rendezvous simulator, vectorised over samples."""

    name = "ftcapn"
    fidelity_params = ("dt",)
    summary = ("finite-time-convergence augmented proportional navigation, midrange "
               "rendezvous from 5.4 km to 50 m (Wang & Song 2019)")
    Params = FTCAPNParams
    params: FTCAPNParams

    def __init__(self, params=None) -> None:
        super().__init__(params)
        self._t_final: float | None = None

    # ------------------------------------------------------------------ contract
    def inputs(self) -> tuple[InputInfo, ...]:
        return INPUT_INFO

    def outputs(self) -> tuple[OutputInfo, ...]:
        return SERIES_INFO + SCALAR_INFO

    @property
    def mean_motion(self) -> float:
        """Mean motion [rad/s] of the target orbit, 0 with ``gravity: none``."""
        p = self.params
        return 0.0 if p.gravity == "none" else mean_motion(p.semi_major_axis, p.mu)

    def initial_state(self) -> tuple[np.ndarray, np.ndarray]:
        """Nominal ``r0, v0`` (shape (3,)) of the line of sight ``target - chaser``."""
        return -np.asarray(self.params.chaser_position), -np.asarray(self.params.chaser_velocity)

    def initial_los_frame(self) -> np.ndarray:
        """Rows ``e_theta, e_r, e_w`` (3, 3) of the nominal initial LOS frame (eq 1)."""
        r, v = self.initial_state()
        er = r / np.linalg.norm(r)
        w = np.cross(r, v)
        if np.linalg.norm(w) == 0.0:
            raise ValueError("the nominal initial LOS rate is zero: e_theta, e_w undefined")
        ew = w / np.linalg.norm(w)
        return np.stack([np.cross(ew, er), er, ew])

    def drift_maneuver(self, comps: np.ndarray, r: np.ndarray, v: np.ndarray) -> np.ndarray:
        """The target's acceleration ``(n, 3)`` during the drift after the stop from its
        components ``(n, 3)`` (theta, r, w) and the stop state ``r, v (n, 3)``."""
        if not np.any(comps):
            return np.zeros_like(comps, dtype=float)
        F = self.initial_los_frame()[None] if self.params.maneuver_frame == "initial" \
            else los_frames(r, v)
        # written out (not a matrix product): a row's bits must not depend on the batch it is
        # in, so a replayed sample reproduces its stored scalars exactly
        return (comps[:, 0, None] * F[:, 0] + comps[:, 1, None] * F[:, 1]) \
            + comps[:, 2, None] * F[:, 2]

    def _miss(self, r: np.ndarray, v: np.ndarray, at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Closest approach [m] and its time [s] of the drift after the stop from ``r, v`` with
        the target acceleration ``at`` (each (n, 3)), with the CW terms under ``gravity: hill``."""
        if self.params.gravity == "hill":
            return miss_hill(r, v, at, self.mean_motion)
        return miss_parabola(r, v, at)

    def derived_outputs(self) -> dict[str, DerivedOutput]:
        """``zem`` and ``zem_eq15`` from the stop state ``r_at_stop, v_at_stop`` (and the target
        maneuver inputs): both are non-smooth functions (a norm, an absolute value) of a smooth
        state, so a surrogate method fits the state and applies these maps to its draws."""
        def zem(carriers: Mapping[str, np.ndarray], inputs: Mapping[str, np.ndarray]):
            r, v = carriers["r_at_stop"], carriers["v_at_stop"]
            comps = np.stack([np.broadcast_to(inputs.get(k, 0.0), (r.shape[0],))
                              for k in ("at_theta", "at_r", "at_w")], axis=1)
            return self._miss(r, v, self.drift_maneuver(comps, r, v))[0][:, None]

        def zem_eq15(carriers: Mapping[str, np.ndarray], inputs: Mapping[str, np.ndarray]):
            r, v = carriers["r_at_stop"], carriers["v_at_stop"]
            R = np.linalg.norm(r, axis=1)
            with np.errstate(invalid="ignore", divide="ignore"):
                rdot = np.einsum("ij,ij->i", r, v) / R
                return (np.linalg.norm(np.cross(r, v), axis=1) / np.abs(rdot))[:, None]

        carriers = ("r_at_stop", "v_at_stop")
        return {"zem": DerivedOutput(carriers, zem), "zem_eq15": DerivedOutput(carriers, zem_eq15)}

    @property
    def t_final(self) -> float:
        """End of the output grid [s]: the parameter, or the nominal stop time rounded up."""
        p = self.params
        if p.t_final is not None:
            return p.t_final
        if self._t_final is None:
            # the same run in every process, so that all share one grid
            out = self._run(np.zeros((1, len(INPUT_INFO))), frozenset(["t_stop"]), grid_end=0.0)
            t_stop = out.scalars["t_stop"][0, 0]
            if out.failed[0] or not np.isfinite(t_stop):
                log.warning("FTCAPN nominal run did not stop (%s): output grid runs to t_max",
                            out.reasons[0])
                self._t_final = p.t_max
            else:
                self._t_final = min(p.t_max, math.ceil(t_stop / p.dt - 1e-9) * p.dt)
        return self._t_final

    def step_count(self) -> StepCount:
        p = self.params
        end = p.t_final if p.t_final is not None else p.t_max
        return StepCount(p.t_max / p.dt, end / p.dt + 1, "dt", "t_max / dt")

    def time_grid(self) -> np.ndarray:
        """Output time grid ``(T,)`` [s]: ``k dt`` for ``k = 0 .. ceil(t_final / dt)``."""
        K = math.ceil(self.t_final / self.params.dt - 1e-9)
        return np.arange(K + 1) * self.params.dt

    def _evaluate(
        self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]
    ) -> ModelOutput:
        x = np.stack([np.asarray(values[i.name], dtype=float) for i in INPUT_INFO], axis=1)
        return self._run(x, outputs)

    # ------------------------------------------------------------------ simulation
    def _run(self, x: np.ndarray, outputs: frozenset[str], grid_end: float | None = None
             ) -> ModelOutput:
        """Simulate ``x (n, 11)`` (columns in :data:`INPUT_INFO` order)."""
        p = self.params
        n = x.shape[0]
        r0n, v0n = self.initial_state()
        r0 = r0n + x[:, 0:3]
        v0 = v0n + x[:, 3:6]
        rotating = p.maneuver_frame == "rotating"
        # the kernel's at: a fixed vector, or the components along the current LOS frame
        at = np.ascontiguousarray(x[:, 8:11]) if rotating else \
            self.drift_maneuver(x[:, 8:11], r0, v0)
        time = self.time_grid() if grid_end is None else np.array([0.0])
        K = time.shape[0] - 1
        max_steps = math.ceil(p.t_max / p.dt - 1e-9)
        col, C = L.series_columns(outputs)
        buf = np.empty((C, n, K + 1))
        sc = np.empty((n, L.N_KSCALARS))
        status = np.empty(n, dtype=np.int8)
        prm = np.zeros(L.N_PARAMS)
        prm[[L.P_C, L.P_EPS, L.P_BETA, L.P_ETA, L.P_N, L.P_ASAT, L.P_DELTA, L.P_DT, L.P_RSTOP,
             L.P_NMEAN, L.P_SETTLE, L.P_CONTROL, L.P_ROTATING]] = [
            p.c, p.eps, p.beta, p.eta, p.N, p.A_sat, p.delta, p.dt, p.r_stop, self.mean_motion,
            p.los_settle_fraction, float(p.control), float(rotating)]
        args = (np.ascontiguousarray(r0), np.ascontiguousarray(v0), np.ascontiguousarray(at),
                np.ascontiguousarray(x[:, 7]), np.ascontiguousarray(x[:, 6]), prm, K, max_steps,
                col, buf, sc, status)
        with numba_threads(p.threads):
            _compiled()(*args)
        series = {}
        for i, (name, k) in enumerate(L.SERIES_LAYOUT):
            if col[i] >= 0:
                # one component: a contiguous (n, T, 1) view (a transposed view would carry the
                # (n*T*8)-byte stride of buf on its unit axis, which slows NumPy reductions 3x)
                series[name] = (buf[col[i]].reshape(n, K + 1, 1) if k == 1
                                else buf[col[i]:col[i] + k].transpose(1, 2, 0))
        failed = status != L.ST_OK
        reasons = np.full(n, "", dtype=object)
        reasons[status == L.ST_TMAX] = (
            f"range did not reach r_stop = {p.r_stop:g} m within t_max = {p.t_max:g} s")
        reasons[status == L.ST_NONFINITE] = "non-finite state: the integration diverged"
        scalars = self._scalars(sc, x[:, 8:11], outputs)
        for v in scalars.values():
            v[failed] = np.nan
        return ModelOutput(time=time, series=series, scalars=scalars, failed=failed,
                           reasons=reasons)

    def _scalars(self, sc: np.ndarray, comps: np.ndarray, outputs: frozenset[str]
                 ) -> dict[str, np.ndarray]:
        """Scalar outputs ``(n, k)`` from the kernel's per-sample results ``sc`` and the
        maneuver components ``comps (n, 3)``."""
        r = sc[:, L.K_RS:L.K_RS + 3]
        v = sc[:, L.K_VS:L.K_VS + 3]
        with np.errstate(invalid="ignore", divide="ignore"):
            R = np.linalg.norm(r, axis=1)
            Rdot = np.einsum("ij,ij->i", r, v) / R
            omega = np.linalg.norm(np.cross(r, v), axis=1) / (R * R)
            direct = {
                "t_stop": sc[:, L.K_TSTOP], "Rdot_stop": Rdot,
                "speed_stop": np.linalg.norm(v, axis=1), "omega_s_stop": omega,
                "dv_total": sc[:, L.K_DV], "zem_eq15": omega * R * R / np.abs(Rdot),
                "t_surface": sc[:, L.K_TSURF], "t_los_settle": sc[:, L.K_TSETTLE],
                "ac_max": sc[:, L.K_ACMAX], "r_at_stop": r, "v_at_stop": v,
            }
        out = {k: (v_ if v_.ndim == 2 else v_[:, None]).copy() for k, v_ in direct.items()
               if k in outputs}
        if {"zem", "t_zem"} & outputs:
            ok = np.isfinite(r).all(axis=1) & np.isfinite(v).all(axis=1)
            miss = np.full(r.shape[0], np.nan)
            t_miss = np.full(r.shape[0], np.nan)
            if ok.any():
                at = self.drift_maneuver(comps[ok], r[ok], v[ok])
                miss[ok], t_miss[ok] = self._miss(r[ok], v[ok], at)
            if "zem" in outputs:
                out["zem"] = miss[:, None]
            if "t_zem" in outputs:
                out["t_zem"] = t_miss[:, None]
        return out

    # ------------------------------------------------------------------ nominal scenario
    def nominal(self, outputs: frozenset[str] | None = None) -> ModelOutput:
        """The nominal run (every input at its nominal value) with the given outputs (all)."""
        wanted = frozenset(o.name for o in self.outputs()) if outputs is None else outputs
        return self.evaluate(np.zeros((1, 0)), [], wanted)
