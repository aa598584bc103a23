"""Smolyak sparse PCE (Wang & Song 2019, section 4.3): the Smolyak combination of
one-dimensional Gauss (or nested) rules, coefficients by Smolyak pseudo-spectral projection
(:mod:`uqguide.pce.projection`). ``level`` is the paper's, chaospy's order + 1. The level table
and what nesting buys: ``docs/methods.md#full-tensor-and-smolyak-as-configured``.

Example config entry::

    - {name: pce_smolyak, label: spce2, level: 2}
"""

from __future__ import annotations

from typing import Any

from pydantic import Field

from ..errors import ConfigError
from ..pce.germ import NORMAL, UNIFORM, Germ
from ..core.inputs import InputSpace
from ..pce.quadrature import Grid, smolyak_grid
from .base import RunPlan
from .pce_quadrature import MAX_NODES, QuadraturePCE, QuadratureSettings

_NESTED = {NORMAL: "genz_keister", UNIFORM: "patterson"}


class SmolyakPCESettings(QuadratureSettings):
    """Settings of ``pce_smolyak``."""

    level: int = Field(default=2, ge=1, le=12,
                       description="the paper's sparse-grid level, chaospy order + 1 (level 2: "
                                   "15 runs for 7 inputs)")
    nested: bool = Field(default=False, description="nested rules (Genz-Keister / "
                                                    "Gauss-Patterson) instead of Gauss rules")


class SmolyakPCE(QuadraturePCE):
    """Smolyak sparse-grid pseudo-spectral PCE."""

    name = "pce_smolyak"
    own_design = "its quadrature needs the nodes of its own sparse grid"
    example_settings = {"level": 2, "surrogate_draws": 20_000}
    summary = "Smolyak sparse PCE: sparse-grid runs, Smolyak pseudo-spectral projection (paper 4.3)"
    Settings = SmolyakPCESettings
    settings: SmolyakPCESettings

    @property
    def order(self) -> int:
        """chaospy's order of the grid (the paper's level minus one)."""
        return self.settings.level - 1

    def _rules(self, germ: Germ) -> list[str]:
        if not self.settings.nested:
            return ["gauss"] * germ.dim
        return [_NESTED.get(f, "gauss") for f in germ.families]

    def plan(self, space: InputSpace) -> RunPlan:
        """An upper bound of the runs from the 1-D rule sizes alone (the points of every tensor
        grid Smolyak combines); ConfigError (field ``level``) above ``MAX_NODES``, and above
        ``MAX_INPUTS`` inputs."""
        from ..pce.quadrature import rule_1d

        germ = Germ.of(space)
        rules = self._rules(germ)
        q, d = self.order, germ.dim
        self.refuse_many_inputs(d)
        try:
            sizes = [[rule_1d(germ, j, rules[j], lv).nodes.size for lv in range(q + 1)]
                     for j in range(d)]
        except ValueError as exc:
            raise ConfigError(f"level: {self.label}: {exc}; use a lower level or nested: "
                              f"false", field="level") from None
        # poly[t]: the points of all tensor grids whose levels sum to t (exact integers).
        poly = [1] + [0] * q
        for s in sizes:
            poly = [sum(poly[a] * s[t - a] for a in range(t + 1)) for t in range(q + 1)]
        bound = sum(poly[max(0, q - d + 1):])
        if bound > MAX_NODES:
            raise ConfigError(
                f"level: {self.label} with level {self.settings.level} on {d} inputs combines "
                f"{bound:.3g} grid points; allowed at most {MAX_NODES} (lower the level)",
                field="level")
        return RunPlan(runs=bound + self.n_validation(), terms=bound, exact=False)

    def _grid(self, germ: Germ) -> Grid:
        # (plan, run first, refused a rule that has no such level)
        return smolyak_grid(germ, self.order, self._rules(germ))

    def _grid_diagnostics(self, grid: Grid) -> dict[str, Any]:
        return {"level": self.settings.level, "chaospy_order": self.order,
                "nested": self.settings.nested}
