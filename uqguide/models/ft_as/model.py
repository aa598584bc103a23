"""The ``ft_as`` model: 6-DOF orbit + attitude (MRP) tracking under FT-AS, Case 1 or Case 2.

Wei et al. (2024), The Aeronautical Journal, doi 10.1017/aer.2024.2. Uncertain inputs are the
initial tracking errors (offsets and a common scale of Table 1), the truth model's mass and
inertia errors and the disturbance amplitudes; outputs are tracking-error histories, inputs,
observer errors and the paper's metrics. Its reconstruction:
docs/papers.md#ft-as-conventions-variants-and-checks.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ..base import InputInfo, Model, OutputInfo, StepCount, failure_reasons
from ...core.types import ModelOutput
from . import scenario
from .params import FTASParams
from .runner import SETTLE_TOLERANCES, RunResult, run_batch
from .setup import CONTROLLER_CODES, FT_AS, Batch, initial_state

XYZ = ("x", "y", "z")
MRP3 = ("1", "2", "3")
SIX = ("x", "y", "z", "sigma1", "sigma2", "sigma3")


@dataclass(frozen=True)
class Variant:
    """One controller configuration of a batch
    (docs/papers.md#ft-as-conventions-variants-and-checks)."""

    label: str
    controller: str
    observer_on_applied: bool = True
    psi2_bound: float = np.inf


def _settle_components(q: str) -> tuple[str, ...]:
    return tuple(f"{tol:g}" for tol in SETTLE_TOLERANCES[q])


_SERIES = {
    # name: (record group, unit, components, description, default)
    "r_e": ("r_e", "m", XYZ, "position tracking error r - r_t, ECI", False),
    "v_e": ("v_e", "m/s", XYZ, "velocity tracking error, ECI", False),
    "sigma_e": ("sigma_e", "1", MRP3, "MRP attitude error sigma_{B/R}", False),
    "omega_e": ("omega_e", "rad/s", XYZ, "angular velocity error omega - C omega_t, body", False),
    "s": ("s", "mixed", SIX, "sliding variable s = e1 + sig^a(kappa e2) (eq 26-27)", False),
    "force_command": ("u_command", "N", XYZ, "commanded force u_c at the grid time", False),
    "torque_command": ("u_command", "N m", XYZ, "commanded torque u_c at the grid time", False),
    "observer_error": ("eps1", "mixed", SIX, "FT-DO error eps1 = psi1 - e2 (eq 21)", False),
    "disturbance_error": ("eps2", "mixed", SIX, "FT-DO error eps2 = psi2 - d_obs (eq 22)", False),
    "disturbance_estimate": ("d_hat", "mixed", SIX, "FT-DO estimate psi2", False),
}
_NORMS = {
    "r_e_norm": ("r_e", "m", "|r_e|", True),
    "v_e_norm": ("v_e", "m/s", "|v_e|", True),
    "sigma_e_norm": ("sigma_e", "1", "|sigma_e|", True),
    "omega_e_norm": ("omega_e", "rad/s", "|omega_e|", True),
}
_PEAKS = {
    "force_peak": (slice(0, 3), "N", "max |f_k| of the applied force over the output interval"),
    "torque_peak": (slice(3, 6), "N m", "max |tau_k| of the applied torque over the interval"),
}


class FTAS(Model):
    """FT-AS 6-DOF tracking (FT-DO + FT-NTSM + smooth saturation) and Cases 1-2.

    The controller is chosen by ``Params.controller``; the paper scenario
    (:mod:`uqguide.papers.ft_as`) runs all of them side by side, as the paper's comparison does.
    """

    name = "ft_as"
    fidelity_params = ("step",)
    summary = (
        "6-DOF orbit+attitude tracking: fixed-time observer, FT-NTSM, 2 N / 1 N m saturation "
        "(Wei et al. 2024)"
    )
    Params = FTASParams
    # 250 steps of 0.02 s: the tests' NumPy oracle takes seconds, not hours
    example_params = {"step": 0.02, "duration": 5.0, "output_interval": 1.0,
                      "final_window": 2.0, "late_time": 2.0}
    params: FTASParams

    # ------------------------------------------------------------------ contract
    def inputs(self) -> tuple[InputInfo, ...]:
        p = self.params
        ins = [
            InputInfo(
                "initial_error_scale", "1",
                "common factor on all Table 1 initial errors (r_e, v_e, sigma_e, omega_e)", 1.0,
            ),
        ]  # fmt: skip
        for prefix, unit, of, axes in (("dr0", "m", "r_e(0), ECI", XYZ),
                                       ("dv0", "m/s", "v_e(0), ECI", XYZ),
                                       ("dsigma0", "1", "sigma_e(0),", MRP3),
                                       ("domega0", "rad/s", "omega_e(0), body", XYZ)):
            ins += [InputInfo(f"{prefix}_{a}", unit, f"offset of {of} {a}", 0.0) for a in axes]
        ins += [
            InputInfo("mass_offset", "kg", "constant true-mass error beyond Delta m(t)", 0.0),
            InputInfo(
                "inertia_scale_error", "1", "true J = J0 (1 + x) + Delta J(t)", 0.0
            ),
            InputInfo(
                "force_disturbance_amplitude", "N", "A_f of d_f(t) ([A2])",
                p.force_disturbance_amplitude,
            ),
            InputInfo(
                "torque_disturbance_amplitude", "N m", "A_tau of d_tau(t) ([A2])",
                p.torque_disturbance_amplitude,
            ),
        ]  # fmt: skip
        return tuple(ins)

    def step_count(self) -> StepCount:
        p = self.params
        return StepCount(p.duration / p.step, p.duration / p.output_interval + 1, "step",
                         "duration / step")

    def outputs(self) -> tuple[OutputInfo, ...]:
        outs = [
            OutputInfo(k, "series", unit, desc, comps if k not in ("force_command",
                       "torque_command") else XYZ, default)
            for k, (_, unit, comps, desc, default) in _SERIES.items()
        ]  # fmt: skip
        outs += [OutputInfo(k, "series", u, d, ("",), df) for k, (_, u, d, df) in _NORMS.items()]
        outs += [OutputInfo(k, "series", u, d, XYZ, False) for k, (_, u, d) in _PEAKS.items()]
        outs += [
            OutputInfo("delta_v", "scalar", "m/s", "integral sum_k |f_k| dt / m0", ("",), True),
            OutputInfo(
                "angular_impulse", "scalar", "N m s", "integral sum_k |tau_k| dt", ("",), True
            ),
        ]
        # the tracking errors: their settling times and their largest values at the end
        errors = (("r_e", "m", XYZ, True), ("v_e", "m/s", XYZ, False),
                  ("sigma_e", "1", MRP3, True), ("omega_e", "rad/s", XYZ, False))
        for q, unit, _, default in errors + (("eps1", "mixed", SIX, True),):
            outs.append(OutputInfo(
                f"settle_{q}", "scalar", "s",
                f"last time |{q}| > tol (components: tol in {unit}); = duration if not settled",
                _settle_components(q), default))
        outs.append(OutputInfo("settle_s", "scalar", "s",
                               "last time |s_1..3|, |s_4..6| > 1e-3 (claim C6)",
                               ("translation", "rotation"), False))
        outs += [OutputInfo(f"final_{q}", "scalar", unit, f"max |{q},k| over the final window",
                            comps, default) for q, unit, comps, default in errors]
        for kind, unit, sl in (("force", "N", "applied"), ("torque", "N m", "applied")):
            outs += [
                OutputInfo(f"peak_{kind}", "scalar", unit, f"max |{kind}_k| {sl}", XYZ, True),
                OutputInfo(f"peak_{kind}_command", "scalar", unit, f"max |{kind}_k| commanded",
                           XYZ, False),
                OutputInfo(f"peak_{kind}_late", "scalar", unit,
                           f"max |{kind}_k| applied after late_time", XYZ, False),
            ]  # fmt: skip
        return tuple(outs)

    # ------------------------------------------------------------------ evaluation
    def _variant(self) -> Variant:
        p = self.params
        return Variant(
            label=p.controller,
            controller=p.controller,
            observer_on_applied=p.ft_as_observer_input == "applied",
            psi2_bound=np.inf if p.psi2_bound is None else p.psi2_bound,
        )

    def make_batch(self, values: Mapping[str, np.ndarray], variants: list[Variant]) -> Batch:
        """The batch of ``len(variants)`` runs, one per variant, from every input of :meth:`inputs`
        (``values`` arrays of that length)."""
        p = self.params
        plant = p.plant()
        n = len(variants)
        r_t1, v_t1 = scenario.initial_orbit_errors(
            p.orbit(p.actual_semi_major_axis), p.orbit(p.reference_semi_major_axis)
        )
        k = np.asarray(values["initial_error_scale"], float)[:, None]

        def offsets(prefix: str, names: tuple[str, ...]) -> np.ndarray:
            return np.column_stack([values[f"{prefix}_{a}"] for a in names])

        x0 = initial_state(
            plant,
            k * r_t1 + offsets("dr0", XYZ),
            k * v_t1 + offsets("dv0", XYZ),
            k * scenario.SIGMA_E0 + offsets("dsigma0", MRP3),
            k * scenario.OMEGA_E0 + offsets("domega0", XYZ),
        )
        return Batch(
            x0=x0,
            mass_offset=np.asarray(values["mass_offset"], float),
            inertia_scale_error=np.asarray(values["inertia_scale_error"], float),
            force_amp=np.asarray(values["force_disturbance_amplitude"], float),
            torque_amp=np.asarray(values["torque_disturbance_amplitude"], float),
            controller=np.array([CONTROLLER_CODES[v.controller] for v in variants]),
            observer_on_applied=np.array([v.observer_on_applied for v in variants]),
            psi2_bound=np.array([v.psi2_bound for v in variants], float),
            omega_chi=np.full(n, p.omega_chi),
            switch_input=np.full(n, p.switch_units == "input"),
        )

    def run(
        self,
        values: Mapping[str, np.ndarray],
        variants: list[Variant],
        record: tuple[str, ...] = (),
        **timing: float,
    ) -> RunResult:
        """Integrate one run per variant with the given input values (timing overrides allowed)."""
        p = self.params
        batch = self.make_batch(values, variants)
        return run_batch(batch, p.plant(), p.gains(), p.timing(**timing), record, p.threads)

    def _evaluate(
        self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]
    ) -> ModelOutput:
        record: list[str] = []
        for name in outputs:
            if name in _SERIES:
                record.append(_SERIES[name][0])
            elif name in _NORMS:
                record.append(_NORMS[name][0])
            elif name in _PEAKS:
                record += ["u_applied_min", "u_applied_max"]
        res = self.run(values, [self._variant()] * n, tuple(record))
        return self._to_output(res, outputs)

    def _to_output(self, res: RunResult, outputs: frozenset[str]) -> ModelOutput:
        series: dict[str, np.ndarray] = {}
        m0 = self.params.mass
        for name in outputs:
            if name in _SERIES:
                arr = res.records[_SERIES[name][0]]
                if name == "force_command":
                    arr = arr[..., :3]
                elif name == "torque_command":
                    arr = arr[..., 3:]
                series[name] = arr
            elif name in _NORMS:
                series[name] = np.linalg.norm(res.records[_NORMS[name][0]], axis=-1, keepdims=True)
            elif name in _PEAKS:
                sl = _PEAKS[name][0]
                lo = res.records["u_applied_min"][..., sl]
                hi = res.records["u_applied_max"][..., sl]
                series[name] = np.maximum(np.abs(lo), np.abs(hi))
        scalar_values = {
            "delta_v": res.impulse[:, :3].sum(axis=1, keepdims=True) / m0,
            "angular_impulse": res.impulse[:, 3:].sum(axis=1, keepdims=True),
            "settle_s": np.column_stack([res.settle["s_trans"], res.settle["s_rot"]]),
        }
        for kind, sl in (("force", slice(0, 3)), ("torque", slice(3, 6))):
            scalar_values[f"peak_{kind}"] = res.peak_applied[:, sl]
            scalar_values[f"peak_{kind}_command"] = res.peak_command[:, sl]
            scalar_values[f"peak_{kind}_late"] = res.peak_late[:, sl]
        scalar_values |= {f"settle_{q}": v for q, v in res.settle.items()}
        scalar_values |= {f"final_{q}": v for q, v in res.final_max.items()}
        scalars = {name: scalar_values[name] for name in outputs if name in scalar_values}
        return ModelOutput(
            time=res.time,
            series=series,
            scalars=scalars,
            failed=res.failed.copy(),
            reasons=failure_reasons(res.failed, "state became non-finite (closed loop diverged)"),
        )


__all__ = ["FTAS", "Variant", "FT_AS"]
