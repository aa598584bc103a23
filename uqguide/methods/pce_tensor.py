"""Full-tensor PCE (Wang & Song 2019, section 4.2): ``m^d`` runs on the tensor grid of ``m``
nodes per input, coefficients by pseudo-spectral projection. The paper's "TPCE level 2" is
``m = 2``. Rules, degrees and run counts: ``docs/methods.md#full-tensor-and-smolyak-as-configured``.

Example config entry::

    - {name: pce_tensor, label: tpce2, m: 2}
"""

from __future__ import annotations

from typing import Any, Literal

from pydantic import Field

from ..errors import ConfigError
from ..pce.germ import Germ
from ..pce.quadrature import RULE_FAMILIES, Grid, tensor_grid
from ..core.inputs import InputSpace
from .base import RunPlan
from .pce_quadrature import MAX_NODES, QuadraturePCE, QuadratureSettings


class TensorPCESettings(QuadratureSettings):
    """Settings of ``pce_tensor``."""

    m: int = Field(default=2, ge=1, le=64,
                   description="nodes per input (the paper's level): m^d runs, basis degree "
                               "m - 1 per input")
    rule: Literal["auto", "gauss", "clenshaw_curtis"] = Field(
        default="auto", description="one-dimensional rule: auto and gauss take each input's "
                                    "Gauss rule, clenshaw_curtis (uniform inputs only) about "
                                    "half the basis degree")


class TensorPCE(QuadraturePCE):
    """Full-tensor pseudo-spectral PCE."""

    name = "pce_tensor"
    own_design = "its quadrature needs its own tensor grid of Gauss nodes"
    example_settings = {"m": 3, "surrogate_draws": 20_000}
    summary = "full-tensor PCE: m^d quadrature runs, pseudo-spectral projection (paper 4.2)"
    Settings = TensorPCESettings
    settings: TensorPCESettings

    def plan(self, space: InputSpace) -> RunPlan:
        """``m^d`` runs and terms; ConfigError (field ``m``) above ``MAX_NODES``, and above
        ``MAX_INPUTS`` inputs."""
        self.refuse_many_inputs(space.dim)
        n = self.settings.m ** space.dim
        if n > MAX_NODES:
            raise ConfigError(
                f"m: {self.label} with m = {self.settings.m} on {space.dim} inputs is {n:.3g} "
                f"runs; allowed at most {MAX_NODES} (lower m, or use pce_smolyak or "
                f"pce_adaptive)", field="m")
        return RunPlan(runs=n + self.n_validation(), terms=n)

    def _rule(self) -> str:
        return "gauss" if self.settings.rule == "auto" else self.settings.rule

    def _grid(self, germ: Germ) -> Grid:
        rule = self._rule()
        for j, fam in enumerate(germ.families):
            if fam not in RULE_FAMILIES[rule]:
                raise ConfigError(
                    f"methods.rule: the '{rule}' rule of {self.label} does not fit input "
                    f"'{germ.space.names[j]}' ({germ.space.marginals[j].dist}); use 'auto'",
                    field="methods.rule")
        return tensor_grid(germ, self.settings.m, [rule] * germ.dim)

    def _grid_diagnostics(self, grid: Grid) -> dict[str, Any]:
        return {"rule": self._rule(), "m": self.settings.m}
