"""What the quadrature PCE methods share (full tensor and Smolyak).

Both run the model once at each node of a quadrature grid on the germ, project every output
column on the orthonormal basis and take the statistics from the coefficients. A projection
needs every node: with ``pce_failure_policy: regression`` the coefficients of the terms the
surviving nodes determine (:func:`identifiable_terms`) are fitted by least squares instead
(``docs/scale.md#failures``).
"""

from __future__ import annotations

import logging
import time
from abc import abstractmethod
from collections.abc import Callable
from typing import Any, Literal

import numpy as np

from ..errors import ConfigError, MethodError
from ..core.inputs import InputSpace
from ..core.types import Estimate, ModelOutput
from ..pce import basis
from ..pce.design import SURROGATE_STREAM, stream
from ..pce.expansion import Expansion
from ..pce.germ import Germ
from ..pce.outputs import assemble, failure_summary, output_columns
from ..pce.pca import constant_columns
from ..pce.projection import project
from ..pce.sobol_indices import set_indices, truncation_error_intervals
from ..pce.quadrature import Grid, union_basis
from ..pce.validation_design import ValidationDesign
from .base import Design, Method, MethodSettings
from .pce_validated import (
    SURROGATE_DRAWS_FIELD, SURROGATE_SAMPLING_FIELD, USABLE_FIELD, VALIDATION_FIELD,
    ValidationSettings, finish, split_validation, surrogate_of, with_validation,
)

log = logging.getLogger(__name__)

#: Largest grid a quadrature method builds (runs); beyond it the settings are surely a mistake.
MAX_NODES = 2_000_000
#: Most inputs of a quadrature PCE: its projection holds a tensor rule's values in an array of
#: one axis per input and one for the outputs, and NumPy allows 64 axes.
MAX_INPUTS = 63


def identifiable_terms(psi: np.ndarray, tol: float = 1e-8) -> np.ndarray:
    """Columns of ``psi (n, P)`` kept in order while their part orthogonal to the kept ones
    has a norm above ``tol`` times their own (at most ``n``): lost nodes can make terms
    indistinguishable (``x1`` left at two values: ``x1^2`` is a combination of ``1`` and ``x1``).
    """
    n = psi.shape[0]
    q = np.zeros((n, 0))
    keep: list[int] = []
    for j in range(psi.shape[1]):
        if len(keep) == n:
            break
        a = psi[:, j]
        v = a - q @ (q.T @ a)
        v -= q @ (q.T @ v)
        rho = np.linalg.norm(v)
        if rho > tol * max(float(np.linalg.norm(a)), 1e-300):
            q = np.column_stack([q, v / rho])
            keep.append(j)
    return np.asarray(keep, dtype=int)


class QuadratureSettings(MethodSettings):
    """Settings shared by the quadrature PCE methods."""

    surrogate_draws: int = SURROGATE_DRAWS_FIELD
    surrogate_sampling: Literal["random", "sobol"] = SURROGATE_SAMPLING_FIELD
    validation: ValidationSettings | None = VALIDATION_FIELD
    usable_error: float = USABLE_FIELD


class QuadraturePCE(Method):
    """Pseudo-spectral PCE on a quadrature grid; subclasses choose the grid."""

    Settings = QuadratureSettings
    settings: QuadratureSettings
    uses_derivations = True
    random_design = False
    fits_surrogate = True

    @abstractmethod
    def _grid(self, germ: Germ) -> Grid:
        """The quadrature grid for these settings (raises ConfigError on impossible ones);
        :meth:`_checked_grid` calls it."""

    @abstractmethod
    def _grid_diagnostics(self, grid: Grid) -> dict[str, Any]:
        """What the grid is (rule, level, ...), for the diagnostics."""

    def refuse_many_inputs(self, d: int) -> None:
        """ConfigError for more than ``MAX_INPUTS`` inputs."""
        if d > MAX_INPUTS:
            raise ConfigError(f"name: {self.label} on {d} inputs: a quadrature PCE takes at "
                              f"most {MAX_INPUTS} (one array axis per input); use pce_adaptive",
                              field="name")

    def _checked_grid(self, germ: Germ) -> Grid:
        """The grid, once :meth:`plan` has refused a size above ``MAX_NODES`` (before it is
        built: it would not fit)."""
        self.plan(germ.space)
        return self._grid(germ)

    def design(self, space: InputSpace, seed: int) -> Design:
        germ = Germ.of(space)
        grid = self._checked_grid(germ)
        draw_seed = int(stream(seed, self.label, SURROGATE_STREAM).generate_state(1)[0])
        log.info("%s: %d model runs (%s)", self.label, grid.n_nodes,
                 ", ".join(f"{k}={v}" for k, v in self._grid_diagnostics(grid).items()))
        design = Design(x=germ.to_physical(grid.xi),
                        data={"xi": grid.xi, "draw_seed": draw_seed, "seed": int(seed)})
        v = self.settings.validation
        if v is not None and v.n_samples and v.design == "random":  # (no fit needed)
            return with_validation(design, v, v.n_samples, None, self.context.outputs, space,
                                   self.label)
        return design

    def refine(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Design | None:
        """Stratified validation runs, placed by the projection of the grid's runs (once)."""
        v = self.settings.validation
        if v is None or not v.n_samples or "n_fit" in design.data:
            return None
        germ = Germ.of(space)
        grid = self._checked_grid(germ)
        _, fitted = self._project(germ, grid, design, outputs)
        return with_validation(design, v, v.n_samples,
                               surrogate_of(germ, fitted, self.derived_outputs),
                               self.context.outputs, space, self.label)

    def _project(self, germ: Germ, grid: Grid, design: Design, outputs: ModelOutput
                 ) -> tuple[np.ndarray, list[tuple[Any, Expansion]]]:
        """Rows used and every fitted output's expansion (not the derived ones)."""
        if outputs.n != grid.n_nodes or not np.allclose(
                design.data.get("xi", grid.xi), grid.xi, rtol=0, atol=1e-12):
            raise MethodError(
                f"{self.label}: the design ({design.n_runs} runs, {outputs.n} outputs) is not "
                f"this method's {grid.n_nodes}-node grid")
        rows, alpha, fit = self._fitter(germ, grid, outputs)
        fitted = []
        for col in output_columns(outputs, rows):
            if col.name in self.derived_outputs:
                continue  # computed from its carriers' surrogates below
            self.note(f"projecting {col.name}")
            coef = fit(col.y)
            coef[1:, constant_columns(col.y)] = 0.0  # runs that all agree: exactly constant
            fitted.append((col, Expansion(germ, alpha, coef, col.shape)))
        return rows, fitted

    def n_validation(self) -> int:
        """Validation runs the method adds after the grid."""
        v = self.settings.validation
        return v.n_samples if v is not None else 0

    def _fitter(self, germ: Germ, grid: Grid, outputs: ModelOutput
                ) -> tuple[np.ndarray, np.ndarray, Callable[[np.ndarray], np.ndarray]]:
        """Rows used, basis ``alpha (P, d)`` and ``f(y (n_rows, m)) -> coef (P, m)`` under the
        failure policy."""
        n_failed = int(outputs.failed.sum())
        alpha = union_basis(grid)
        if not n_failed:
            return np.arange(outputs.n), alpha, lambda y: project(germ, grid, y)[1]
        what = (f"{self.label}: {n_failed} of {outputs.n} quadrature runs failed "
                f"({failure_summary(outputs)})")
        if self.context.failure_policy != "regression":
            raise MethodError(f"{what}; a quadrature PCE needs every node (set "
                              f"pce_failure_policy: regression to fit on the others)")
        rows = np.flatnonzero(~outputs.failed)
        if rows.size == 0:
            raise MethodError(f"{what}; no run is left to fit on")
        keep = identifiable_terms(basis.evaluate(germ, alpha, grid.xi[rows]))
        alpha = alpha[keep]
        log.warning("%s; fitting %d of the grid's terms by least squares on the %d others",
                    what, alpha.shape[0], rows.size)
        psi = basis.evaluate(germ, alpha, grid.xi[rows])
        return rows, alpha, lambda y: np.linalg.lstsq(psi, y, rcond=None)[0]

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        t0 = time.perf_counter()
        germ = Germ.of(space)
        grid = self._checked_grid(germ)
        n_total = outputs.n
        outputs, validation = split_validation(design.data, outputs)
        rows, fitted = self._project(germ, grid, design, outputs)
        alpha = fitted[0][1].alpha if fitted else union_basis(grid)
        seed = design.data.get("draw_seed", 0)
        stats, names, s_mean, s_cov, extra, events = assemble(
            fitted, self.derived_outputs, outputs, n_runs=rows.size,
            n_draws=self.settings.surrogate_draws, seed=seed, label=self.label,
            sampling=self.settings.surrogate_sampling,
            levels=self.context.quantile_levels, events=self.context.events,
            components=self.context.components,
            note=self.note)
        for col, exp in fitted:
            set_indices(stats[col.name], exp, self.context.groups)
        diagnostics: dict[str, Any] = {
            "n_runs": n_total,
            "n_fit_runs": outputs.n,
            "n_failed": int(outputs.failed.sum()),
            "failure_reasons": failure_summary(outputs),
            "coefficients": "projection" if rows.size == outputs.n else "regression",
            **self._grid_diagnostics(grid),
            "degree": int(alpha.sum(axis=1).max()),
            "n_terms": int(alpha.shape[0]),
            "moments_method": ", ".join(sorted({s.moments_method for s in stats.values()})),
            **extra,
        }
        est = Estimate(method=self.name, label=self.label, stats=stats, diagnostics=diagnostics,
                       scalar_index=names, scalar_mean=s_mean, scalar_cov=s_cov, events=events)
        finish(est, surrogate_of(germ, fitted, self.derived_outputs), space=space,
               validation=validation, design=ValidationDesign.from_data(design.data), loo={},
               threshold=self.settings.usable_error, seed=int(design.data.get("seed", 0)),
               n_draws=self.settings.surrogate_draws, failed_fit=outputs.failed)
        # no regression to resample: the (aliased) truncation bound of the validation error
        truncation_error_intervals(est.stats, orthogonal=False)
        diagnostics["fit_seconds"] = time.perf_counter() - t0
        return est
