"""Adaptive sparse PCE (Blatman & Sudret 2011; Wang & Song 2019, section 4.4).

Every output column fitted by LARS with corrected leave-one-out selection
(:mod:`uqguide.pce.sparse_regression`; a series through principal components,
:mod:`uqguide.pce.series_fit`), the design enriched while the LOO error is above ``target_loo``
and ``max_runs`` allows; without ``n_samples`` and ``max_runs`` :mod:`uqguide.pce.default_plan`
sizes design and validation. Steps and reasons:
``docs/methods.md#the-adaptive-pce-step-by-step``. Example config entry (paper Table 5)::

    - {name: pce_adaptive, label: apce, n_samples: 150, max_runs: 300}
"""

from __future__ import annotations

import hashlib
import logging
import math
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field, model_validator

from ..errors import MethodError
from ..core.inputs import InputSpace
from ..core.types import Estimate, ModelOutput
from ..pce import basis
from ..pce.basis import hyperbolic_indices
from ..core.events import EventEstimate
from ..pce.tails import control_variate_events, surrogate_values
from ..pce.default_plan import (STALL_FITS, default_budget, default_validation, mean_and_std,
                                settled, stalled)
from ..pce.design import SURROGATE_STREAM, stream, unit_design
from ..pce.expansion import Expansion
from ..pce.germ import Germ
from ..pce.index_check import ValidationRuns, cross_term_band
from ..pce.loo import loo_values
from ..pce.outputs import OutputColumns, assemble, failure_summary, output_columns
from ..pce.series_fit import fit_series
from ..pce.sobol_indices import (
    BOOTSTRAP_STREAM, regression_intervals, truncation_error_intervals,
)
from ..pce.sparse_regression import Q_GRID, ColumnsFit, fit_columns
from ..pce.surrogate import Surrogate
from ..pce.validation_design import ValidationDesign
from .base import Design, Method, MethodSettings, RunPlan
from .monte_carlo import U_EPS
from .pce_validated import (
    SURROGATE_DRAWS_FIELD, SURROGATE_SAMPLING_FIELD, USABLE_FIELD, VALIDATION_FIELD,
    ValidationSettings, finish, output_values, split_validation, surrogate_of, with_validation,
)

log = logging.getLogger(__name__)

_MIN_RUNS = 3  # a leave-one-out error needs at least three runs


class AdaptivePCESettings(MethodSettings):
    """Settings of ``pce_adaptive`` (the defaults' rules: :attr:`AdaptivePCE.default_rules`)."""

    n_samples: int | None = Field(default=None, ge=_MIN_RUNS, le=10_000_000,
                                  description="initial design size; default n0 = max(10 d, "
                                              "2 P_min), capped by max_runs")
    sampling: Literal["sobol", "lhs"] = Field(
        default="sobol", description="design on the unit cube: scrambled Sobol' or Latin "
                                     "hypercube")
    degree_min: int = Field(default=1, ge=1, le=30,
                            description="lowest truncation degree tried")
    degree_max: int | None = Field(default=None, ge=1, le=30,
                                   description="highest truncation degree tried; default the "
                                               "largest whose candidate set has at most five "
                                               "terms per run and 3000 in all, up to 40")
    q_norm: float | None = Field(default=None, gt=0.0, le=1.0,
                                 description="hyperbolic truncation ||alpha||_q <= p; default: "
                                             "chosen per output among 0.5, 0.75 and 1")
    target_loo: float = Field(default=1e-5, gt=0.0, lt=1.0,
                              description="corrected LOO error (relative to the variance) at "
                                          "which enrichment stops (paper 4.4)")
    max_runs: int | None = Field(default=None, ge=_MIN_RUNS, le=10_000_000,
                                 description="budget of fit runs, enrichment included; default "
                                             "min(max(10 n0, 100), 1000) when n_samples is not "
                                             "given either, else n_samples (no enrichment)")
    enrich: bool = Field(default=True, description="whether to add runs while the LOO error "
                                                   "is above target and the budget allows")
    variance_fraction: float | None = Field(
        default=None, gt=0.0, le=1.0,
        description="keep the principal components of a time series that hold this fraction of "
                    "its variance; default: docs/methods.md#time-series-in-the-adaptive-pce")
    n_components: int | None = Field(default=None, ge=1, le=10_000,
                                     description="keep this many principal components of a "
                                                 "time series (instead of either rule)")
    surrogate_draws: int = SURROGATE_DRAWS_FIELD
    surrogate_sampling: Literal["random", "sobol"] = SURROGATE_SAMPLING_FIELD
    validation_runs: int = Field(default=0, ge=0, le=10_000_000,
                                 description="model runs at independent random inputs after "
                                             "the fit (0: none); the older form of validation")
    validation: ValidationSettings | None = VALIDATION_FIELD
    usable_error: float = USABLE_FIELD

    @model_validator(mode="after")
    def _consistent(self) -> AdaptivePCESettings:
        if self.degree_max is not None and self.degree_min > self.degree_max:
            raise ValueError(f"The 'degree_min' parameter of pce_adaptive must be <= degree_max "
                             f"({self.degree_max}). Got {self.degree_min} instead.")
        if self.variance_fraction is not None and self.n_components is not None:
            raise ValueError(f"The 'n_components' parameter of pce_adaptive must be unset when "
                             f"variance_fraction ({self.variance_fraction}) is given. Got "
                             f"{self.n_components} instead.")
        if self.n_samples is not None and self.max_runs is not None \
                and self.n_samples > self.max_runs:
            raise ValueError(f"The 'n_samples' parameter of pce_adaptive must be <= max_runs "
                             f"({self.max_runs}). Got {self.n_samples} instead.")
        return self


def _runs_digest(space: InputSpace, design: Design, outputs: ModelOutput) -> bytes:
    """A digest of the fit's inputs (design points, outputs, failures)."""
    h = hashlib.blake2b(digest_size=20)
    h.update(repr(space.names).encode())
    for a in ([np.asarray(design.data.get("u", design.x)), outputs.failed]
              + [outputs.scalars[k] for k in sorted(outputs.scalars)]
              + [outputs.series[k] for k in sorted(outputs.series)]):
        arr = np.ascontiguousarray(a)
        h.update(repr((arr.dtype.str, arr.shape)).encode())
        h.update(arr.tobytes())
    return h.digest()


@dataclass
class _OutputFit:
    """An output's expansion and its fit diagnostics."""

    columns: OutputColumns
    expansion: Expansion
    loo: float
    degree: int
    q: float
    n_terms: int
    n_components: int | None
    #: The columns the core was fitted to (a scalar's components, a series' scores).
    targets: np.ndarray | None = None


class AdaptivePCE(Method):
    """Degree-adaptive sparse PCE by least-angle regression, with sequential design."""

    name = "pce_adaptive"
    summary = ("adaptive sparse PCE: LARS + corrected LOO over a (q-norm, degree) grid, "
               "sequential design")
    Settings = AdaptivePCESettings
    fits_surrogate = True
    settings: AdaptivePCESettings
    uses_derivations = True
    example_settings = {"n_samples": 40, "max_runs": 60, "degree_max": 3,
                        "surrogate_draws": 20_000}
    own_design = ""
    default_rules = (
        ("n_samples", "n0 = max(10 d, 2 P_min), P_min the basis at degree_min and q-norm 0.5: "
                      "ten runs per input see every main effect, twice the smallest basis "
                      "lets its least-squares refit be scored"),
        ("max_runs", "with neither n_samples nor max_runs: min(max(10 n0, 100), 1000) fit runs; "
                     "ten times n0 allows six refits of +50% for the degree to rise, and past "
                     "1000 runs a Monte Carlo gives every moment with an interval. With "
                     "n_samples alone: n_samples (no enrichment)"),
        ("stopping", "the design grows (by half) until the worst corrected LOO error is <= "
                     "target_loo (1e-5) and every output's mean and std moved by <= 2 sqrt(LOO) "
                     "std since the previous fit (the most two fits of that error can differ); "
                     "with max_runs given: the LOO target alone"),
        ("validation", "with neither n_samples nor max_runs: max(20, ceil(n_fit / 4)) runs "
                       "stratified by the surrogate (the 80/20 split of the runs made, at least "
                       "two per stratum) from a pool leaning to the faces of the inputs the "
                       "surrogate is curved in, where a polynomial swings (the arcsine "
                       "density, importance-weighted, when at most 2 are; uniform otherwise); "
                       "otherwise none. validation: {n_samples: 0} opts out"),
        ("statistics", "a skewness or kurtosis is printed only where the validation runs' "
                       "corrected (+cv) estimate and the runs' Monte Carlo estimate support "
                       "it; elsewhere withheld, with the runs' estimate (+mc) beside it"),
    )

    @classmethod
    def default_sizes(cls, d: int) -> dict[str, int]:
        """The numbers of :attr:`default_rules` for ``d`` inputs."""
        m = cls()
        budget = m.budget(d)
        return {"n_samples": m.initial_size(d), "max_runs": budget,
                "validation": m.n_validation(budget), "most runs": m.plan_runs(d)}

    def plan_runs(self, d: int) -> int:
        """Most model runs, fit and validation, for ``d`` inputs."""
        budget = self.budget(d)
        return budget + self.n_validation(budget)

    @property
    def default_plan(self) -> bool:
        """Whether the method sizes its own design (:mod:`uqguide.pce.default_plan`): neither
        ``n_samples`` nor ``max_runs`` given, and no data file's rows."""
        s = self.settings
        return s.n_samples is None and s.max_runs is None and self.context.rows is None

    def _n0(self, d: int) -> int:
        """``max(10 d, 2 P_min)``, ``P_min`` the basis at ``degree_min`` and the least q."""
        s = self.settings
        q = s.q_norm if s.q_norm is not None else min(Q_GRID)
        p_min = hyperbolic_indices(d, s.degree_min, q).shape[0]
        return max(10 * d, 2 * p_min)

    def initial_size(self, d: int) -> int:
        s = self.settings
        if s.n_samples is not None:
            return s.n_samples
        n = self._n0(d)
        return min(n, s.max_runs) if s.max_runs is not None else n

    def min_rows(self, d: int) -> int:
        """The fewest successful rows of a data file: :meth:`_n0` plus the held-out rows."""
        return max(self._n0(d), _MIN_RUNS) + self._asked_validation()

    def n_validation(self, n_fit: int = 0) -> int:
        """Validation runs after a fit of ``n_fit`` runs."""
        s = self.settings
        v = s.validation
        if v is None and s.validation_runs == 0 and self.default_plan:
            return default_validation(n_fit)
        return self._asked_validation()

    def _asked_validation(self) -> int:
        """The validation runs the config asks for (a data file's rows get no default set:
        holding rows out would change the fit asked of them)."""
        v = self.settings.validation
        return max(v.n_samples if v is not None else 0, self.settings.validation_runs)

    def budget(self, d: int) -> int:
        """Most fit runs the method makes for ``d`` inputs (validation runs not included)."""
        s = self.settings
        if s.max_runs is not None:
            return s.max_runs
        if s.n_samples is not None or not self.default_plan:
            return self.initial_size(d)
        return default_budget(self._n0(d))

    def plan(self, space: InputSpace) -> RunPlan:
        from math import comb

        from ..pce.sparse_regression import MAX_CANDIDATES, candidate_cap

        s = self.settings
        runs = self.budget(space.dim)
        if s.degree_max is None:  # the union of the q-norms' data-driven candidate sets
            terms = len(Q_GRID) * candidate_cap(runs)
        else:  # at most the total-degree basis (a q-norm below 1 prunes it), capped
            terms = min(comb(space.dim + s.degree_max, space.dim), MAX_CANDIDATES)
        return RunPlan(runs=self.plan_runs(space.dim), terms=terms)

    def design(self, space: InputSpace, seed: int) -> Design:
        if self.context.rows is not None:
            return self._rows_design(space, seed)
        n = self.initial_size(space.dim)
        u = unit_design(space.dim, 0, n, self.settings.sampling, seed, self.label, batch=0)
        log.info("%s: initial design of %d runs (budget %d)", self.label, n,
                 self.budget(space.dim))
        return Design(x=space.from_unit(u), data={"u": u, **self._first_data(seed)})

    def _first_data(self, seed: int) -> dict[str, Any]:
        """The design data before any fit: the seeds and an empty history."""
        draw_seed = int(stream(seed, self.label, SURROGATE_STREAM).generate_state(1)[0])
        return {"seed": int(seed), "batches": 1, "draw_seed": draw_seed, "fit_seconds": 0.0,
                "loo_history": np.zeros(0)}

    def _rows_design(self, space: InputSpace, seed: int) -> Design:
        """The data file's rows as the design (config ``data:``): no enrichment; the validation
        set, when asked for, drawn from the rows that did not fail (the validation stream)
        and placed last. The germ values come from :meth:`Germ.from_physical`, not the unit
        cube, whose CDFs would round away normal tails."""
        from ..pce.design import VALIDATION_STREAM
        from ..pce.validation_design import random_design_of

        assert self.context.rows is not None
        x, failed = self.context.rows.x, self.context.rows.failed
        n, nv = x.shape[0], self._asked_validation()
        data = self._first_data(seed)
        n_fit = n
        if nv:
            rng = np.random.default_rng(stream(seed, self.label, VALIDATION_STREAM))
            held = np.sort(rng.choice(np.flatnonzero(~failed), nv, replace=False))
            order = np.concatenate([np.setdiff1d(np.arange(n), held), held])
            x, n_fit = x[order], n - nv
            u_held = np.clip(space.to_unit(x[n_fit:]), U_EPS, 1 - U_EPS)
            data.update(n_fit=n_fit, **random_design_of(u_held).to_data())
            log.info("%s: %d of the %d rows held out for validation", self.label, nv, n)
        data["u"] = space.to_unit(x[:n_fit])
        data["xi"] = Germ.of(space).from_physical(x[:n_fit])
        return Design(x=x, data=data)

    def refine(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Design | None:
        """Enrich while the LOO error is above target and the budget allows; then, once, add
        the validation runs (when asked for), placed by the final fit's surrogate."""
        if "n_fit" in design.data or self.context.rows is not None:
            return None
        bigger = self._enrich(space, design, outputs)
        nv = self.n_validation(design.n_runs)
        if bigger is not None or not nv:
            return bigger
        surrogate = self._surrogate(space, self._fit(space, design, outputs))
        asked = self.settings.validation
        if asked is None and self.settings.validation_runs == 0:  # the default set: stratified
            asked = ValidationSettings(n_samples=nv)
        return with_validation(design, asked, nv, surrogate, self.context.outputs, space,
                               self.label)

    def _surrogate(self, space: InputSpace, fits: list[_OutputFit]) -> Surrogate:
        return surrogate_of(Germ.of(space), [(f.columns, f.expansion) for f in fits],
                            self.derived_outputs)

    def _enrich(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Design | None:
        s, d, n = self.settings, space.dim, design.n_runs
        budget = self.budget(d)
        if not s.enrich or n >= budget:
            return None
        t0 = time.perf_counter()
        fits = self._fit(space, design, outputs)
        worst = max((f.loo for f in fits), default=0.0)
        history = np.append(design.data.get("loo_history", np.zeros(0)), worst)
        fit_seconds = design.data.get("fit_seconds", 0.0) + time.perf_counter() - t0
        moments = {f.columns.name: mean_and_std(f.expansion.coef) for f in fits}
        if self.default_plan:  # LOO below target and the moments settled
            done = settled(design.data.get("moments", {}), moments,
                           {f.columns.name: f.loo for f in fits}, s.target_loo)
        else:
            done = worst <= s.target_loo
        if done:
            design.data.update(fit_seconds=fit_seconds, loo_history=history)
            return None
        add = min(budget - n, max(d + 1, math.ceil(n / 2)))
        if self.default_plan and stalled(history, s.usable_error):
            # a design that will not settle ends at its budget anyway: its runs are added at
            # once (with Sobol' points the very ones the steps would add), without the refits
            add = budget - n
            log.info("%s: LOO error %.2e with %d runs, above usable_error %g at the last %d "
                     "fits and not halved over them: adding the rest of the budget (%d) at "
                     "once", self.label, worst, n, s.usable_error, STALL_FITS, add)
        elif worst > s.target_loo:
            log.info("%s: LOO error %.2e above target %.0e with %d runs: adding %d (budget %d)",
                     self.label, worst, s.target_loo, n, add, budget)
        else:
            log.info("%s: LOO error %.2e below target, but the mean or std moved by more than "
                     "2 sqrt(LOO) std since the last fit, with %d runs: adding %d (budget %d)",
                     self.label, worst, n, add, budget)
        batch = int(design.data.get("batches", 1))
        u_new = unit_design(d, n, n + add, s.sampling, design.data["seed"], self.label,
                            batch=batch)
        data = dict(design.data, u=np.vstack([design.data["u"], u_new]), batches=batch + 1,
                    fit_seconds=fit_seconds, loo_history=history, moments=moments)
        return Design(x=np.vstack([design.x, space.from_unit(u_new)]), data=data)

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        t0 = time.perf_counter()
        s = self.settings
        outputs, validation = split_validation(design.data, outputs)
        if validation is not None:
            design = Design(x=design.x[:outputs.n], data=design.data)
        fits = self._fit(space, design, outputs)
        n_ok = int((~outputs.failed).sum())
        stats, names, s_mean, s_cov, extra, events = assemble(
            [(f.columns, f.expansion) for f in fits], self.derived_outputs, outputs,
            n_runs=n_ok, n_draws=s.surrogate_draws, seed=design.data.get("draw_seed", 0),
            label=self.label, sampling=s.surrogate_sampling,
            levels=self.context.quantile_levels, events=self.context.events,
            components=self.context.components,
            note=self.note)
        val_design = ValidationDesign.from_data(design.data)
        self._indices(space, design, outputs, fits, stats, validation, val_design)
        if validation is not None and val_design is not None:
            events = self._validate(space, fits, val_design, validation, events)
        worst = max((f.loo for f in fits), default=0.0)
        diagnostics: dict[str, Any] = {
            "n_runs": outputs.n,
            "n_failed": int(outputs.failed.sum()),
            "failure_reasons": failure_summary(outputs),
            "sampling": "data" if self.context.rows is not None else s.sampling,
            "n_initial": self.initial_size(space.dim),
            "max_runs": self.budget(space.dim),
            "n_enrichments": int(design.data.get("batches", 1)) - 1,
            "target_loo": s.target_loo,
            "loo_error": worst,
            "degree": max((f.degree for f in fits), default=0),
            "q_norm": max((f.q for f in fits), default=0.0),
            "n_terms": max((f.n_terms for f in fits), default=0),
            "n_components": max((f.n_components or 0 for f in fits), default=0),
            "moments_method": ", ".join(sorted({st.moments_method for st in stats.values()})),
            **extra,
        }
        for f in fits:
            diagnostics[f"loo_error.{f.columns.name}"] = f.loo
            diagnostics[f"degree.{f.columns.name}"] = f.degree
            diagnostics[f"q_norm.{f.columns.name}"] = f.q
            diagnostics[f"n_terms.{f.columns.name}"] = f.n_terms
            if f.n_components is not None:
                diagnostics[f"n_components.{f.columns.name}"] = f.n_components
        diagnostics["fit_seconds"] = (design.data.get("fit_seconds", 0.0)
                                      + time.perf_counter() - t0)
        est = Estimate(method=self.name, label=self.label, stats=stats, diagnostics=diagnostics,
                       scalar_index=names, scalar_mean=s_mean, scalar_cov=s_cov, events=events)
        finish(est, self._surrogate(space, fits), space=space, validation=validation,
               design=val_design,
               loo={f.columns.name: f.loo for f in fits}, threshold=s.usable_error,
               seed=int(design.data.get("seed", 0)), n_draws=s.surrogate_draws,
               fit=outputs, fit_u=_fit_u(design, outputs.n),
               fit_loo_values=self._fit_loo(space, design, outputs, fits)
               if val_design is not None and val_design.sorter is not None else None)
        truncation_error_intervals(est.stats, {f.columns.name: f.loo for f in fits})
        return est

    def _fit_loo(self, space: InputSpace, design: Design, outputs: ModelOutput,
                 fits: list[_OutputFit]) -> dict[str, np.ndarray]:
        """Each fitted output's leave-one-out values ``(n_ok, *shape)`` at the successful fit
        runs (:mod:`uqguide.pce.loo`), and each derived output's, from its carriers'."""
        germ = Germ.of(space)
        ok = np.flatnonzero(~outputs.failed)
        xi = self._fit_points(germ, design, ok)
        loo = {f.columns.name: loo_values(f.expansion, xi, f.targets).reshape(
                   (ok.size,) + tuple(f.expansion.shape))
               for f in fits if f.targets is not None}
        x = germ.to_physical(xi)
        inputs = {nm: x[:, j] for j, nm in enumerate(space.names)}
        for name, dv in self.derived_outputs.items():
            if name not in loo and all(c in loo for c in dv.carriers):
                y = np.asarray(dv.function({c: loo[c] for c in dv.carriers}, inputs), float)
                loo[name] = y if y.ndim > 1 else y[:, None]
        return loo

    def _indices(self, space: InputSpace, design: Design, outputs: ModelOutput,
                 fits: list[_OutputFit], stats: dict[str, Any],
                 validation: ModelOutput | None, val_design: ValidationDesign | None) -> None:
        """Sobol' indices of every fitted output with bootstrap intervals, joined with the
        cross term the successful validation runs measure (if any)."""
        germ = Germ.of(space)
        xi = self._fit_points(germ, design, np.flatnonzero(~outputs.failed))
        fitted = {f.columns.name: (f.expansion, basis.evaluate(germ, f.expansion.alpha, xi),
                                   f.targets) for f in fits if f.targets is not None}
        groups = [c for _, c in self.context.groups]
        cross: dict[str, np.ndarray] = {}
        ok = None if validation is None else ~validation.failed
        if validation is not None and val_design is not None and ok is not None \
                and int(ok.sum()) >= 2:
            used = val_design.successful(ok)
            xi_val = germ.from_unit(used.u)
            for name, (exp, _, _) in fitted.items():
                y = output_values(validation, name)
                if y is not None:
                    runs = ValidationRuns(xi_val, y[ok].reshape(int(ok.sum()), -1), used)
                    cross[name] = cross_term_band(exp, runs, groups)
        seed = stream(int(design.data.get("seed", 0)), self.label, BOOTSTRAP_STREAM)
        regression_intervals(stats, fitted, self.context.groups, seed, joined=cross)

    def _validate(self, space: InputSpace, fits: list[_OutputFit], vd: ValidationDesign,
                  validation: ModelOutput, events: dict[str, EventEstimate]
                  ) -> dict[str, EventEstimate]:
        """The events corrected by the validation runs (the surrogate as control variate)."""
        expansions = {f.columns.name: f.expansion for f in fits}
        germ = Germ.of(space)
        names = [n for n in validation.scalars if n in expansions or n in self.derived_outputs]
        sur = {n: surrogate_values(germ, expansions, self.derived_outputs, n, vd.u)
               for n in names}
        cv = control_variate_events(events, self.context.events, self.context.components,
                                    validation.scalars, sur, ~validation.failed, vd)
        return {**events, **cv}

    def _fit(self, space: InputSpace, design: Design, outputs: ModelOutput) -> list[_OutputFit]:
        """The fit of every output, cached for the same runs: ``refine`` places the validation
        runs by the final fit, which ``estimate`` reuses."""
        key = _runs_digest(space, design, outputs)
        cached = getattr(self, "_last_fit", None)
        if cached is not None and cached[0] == key:
            fits: list[_OutputFit] = cached[1]
            return fits
        fits = self._fit_now(space, design, outputs)
        self._last_fit = (key, fits)
        return fits

    def _fit_now(self, space: InputSpace, design: Design, outputs: ModelOutput
                 ) -> list[_OutputFit]:
        if outputs.n != design.n_runs or "u" not in design.data:
            raise MethodError(f"{self.label}: the outputs ({outputs.n} runs) do not belong to "
                              f"this method's design ({design.n_runs} runs)")
        ok = np.flatnonzero(~outputs.failed)
        if ok.size < _MIN_RUNS:
            raise MethodError(
                f"{self.label}: only {ok.size} of {outputs.n} runs succeeded "
                f"({failure_summary(outputs)}); a regression PCE needs at least {_MIN_RUNS}")
        germ = Germ.of(space)
        xi = self._fit_points(germ, design, ok)
        cols = [c for c in output_columns(outputs, ok) if c.name not in self.derived_outputs]
        fits = []
        for i, col in enumerate(cols):
            self.note(f"fitting {col.name} ({i + 1}/{len(cols)}, {ok.size} runs)")
            fits.append(self._fit_output(germ, xi, col))
        return fits

    @staticmethod
    def _fit_points(germ: Germ, design: Design, ok: np.ndarray) -> np.ndarray:
        """Germ coordinates ``(n_ok, d)`` of the design's successful runs."""
        return design.data["xi"][ok] if "xi" in design.data else \
            germ.from_unit(design.data["u"][ok])

    def _fit_output(self, germ: Germ, xi: np.ndarray, col: OutputColumns) -> _OutputFit:
        s = self.settings

        def fit_of(y: np.ndarray) -> ColumnsFit:
            return fit_columns(germ, xi, y, degree_min=s.degree_min, degree_max=s.degree_max,
                               q=s.q_norm)

        if col.kind == "scalar":
            fit = fit_of(col.y)
            exp = Expansion(germ, fit.alpha, fit.core, col.shape)
            return _OutputFit(col, exp, float(fit.loo.max()), int(fit.degree.max()),
                              float(fit.q.max()), int(fit.alpha.shape[0]), None, col.y)
        series = fit_series(germ, xi, col.y, degree_min=s.degree_min, degree_max=s.degree_max,
                            q=s.q_norm, variance_fraction=s.variance_fraction,
                            n_components=s.n_components)
        comps, fit = series.components, series.fit
        r = comps.n_components
        core = np.zeros((fit.alpha.shape[0], r + 1))
        core[:, :r] = fit.core
        core[0, r] = 1.0  # the sample mean, mix's last row
        exp = Expansion(germ, fit.alpha, core, col.shape, mix=comps.mix)
        lam = comps.scores.var(axis=0)
        total = lam.sum() / max(comps.explained, 1e-300)
        loo = float((lam @ fit.loo + (total - lam.sum())) / total) if r else 0.0
        return _OutputFit(col, exp, loo, int(fit.degree.max(initial=0)),
                          float(fit.q.max(initial=0.0)), int(fit.alpha.shape[0]), r,
                          comps.scores)


def _fit_u(design: Design, n_fit: int) -> np.ndarray | None:
    """The fit's runs on the unit cube (None where the design keeps none: given germ points)."""
    u = design.data.get("u")
    if u is None or np.shape(u)[0] < n_fit:
        return None
    return np.asarray(u)[:n_fit]
