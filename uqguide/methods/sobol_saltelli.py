"""``sobol_saltelli``: first-order and total Sobol' indices from a pick-freeze design, with the
plain Monte Carlo statistics of its ``A`` and ``B`` rows.

``N (m + 2)`` runs (Saltelli et al. 2010; :mod:`uqguide.stats.sobol_pick_freeze`): ``A``, ``B``
and ``A_B^u`` for each of ``m`` frozen sets (the inputs, and each group frozen whole), in chunks
of ``chunk_size`` base rows with all their runs, reduced where they ran
(:class:`SaltelliReducer`) and merged in chunk order; the ``A`` and ``B`` rows by Monte Carlo's
own code. The estimators and their accuracy:
``docs/error-budget.md#totals-a-pick-freeze-design``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np
from pydantic import Field

from ..core.inputs import InputSpace, split_groups
from ..core.types import Estimate, GeneratedRows, ModelOutput, OutputStats
from ..errors import ConfigError, MethodError
from ..stats.sobol_pick_freeze import PickFreezeSums, pick_freeze_indices
from .base import Design, MethodSettings, RunPlan, StreamingMethod
from .monte_carlo import (
    MonteCarlo, MonteCarloReducer, MonteCarloSettings, at_steps, ci_index, method_seed,
    poisson1, stream_seed, unit_chunk,
)

log = logging.getLogger(__name__)

_SUMS = "pick-freeze"


class SaltelliSettings(MethodSettings):
    """Settings of ``sobol_saltelli``."""

    n_base: int = Field(ge=2, le=10_000_000,
                        description="N, base rows: the design makes N (m + 2) runs, m the "
                                    "frozen sets (inputs and groups)")
    sampling: Literal["sobol", "random", "lhs"] = Field(
        default="sobol", description="points of A and B within each chunk (default scrambled "
                                     "Sobol', as SALib's)")
    chunk_size: int = Field(default=1024, ge=1, le=1_000_000,
                            description="base rows per chunk (each with its m + 2 runs); a "
                                        "power of two keeps Sobol' points balanced")
    bootstrap: int = Field(default=200, ge=0, le=10_000,
                           description="Poisson-bootstrap resamples of the indices' 95% "
                                       "intervals, and of the moments' with intervals: "
                                       "bootstrap or studentized (0: none)")
    intervals: Literal["tail", "delta", "bootstrap", "studentized"] = Field(
        default="tail", description="the intervals of the A and B rows' moments, as "
                                    "monte_carlo's")


class SobolSaltelli(StreamingMethod):
    """Pick-freeze (Saltelli / Jansen) Sobol' indices with bootstrap intervals."""

    name = "sobol_saltelli"
    summary = ("Saltelli pick-freeze design: first-order and total Sobol' indices with "
               "intervals; Monte Carlo moments of its A and B rows")
    Settings = SaltelliSettings
    settings: SaltelliSettings
    example_settings = {"n_base": 256, "chunk_size": 64, "bootstrap": 50}

    def frozen_sets(self, space: InputSpace) -> list[tuple[str, int, tuple[int, ...]]]:
        """The frozen sets ``(kind, position, input columns)``: ``("input", j, (j,))`` for
        each input outside a correlated group, ``("group", g, cols)`` for each group."""
        correlated = [set(g.index) for g in space.groups]
        inside = set().union(*correlated) if correlated else set()
        sets: list[tuple[str, int, tuple[int, ...]]] = [
            ("input", j, (j,)) for j in range(space.dim) if j not in inside]
        for g, (name, cols) in enumerate(self.context.groups):
            split = split_groups([c.index for c in space.groups], cols)
            if split:
                # a config error, found when the budget plans the runs (exit 2, nothing run)
                whole = ", ".join(space.names[i] for i in sorted(split[0]))
                raise ConfigError(
                    f"groups.{name}: holds part of the correlated group ({whole}); "
                    f"{self.name} (method '{self.label}') can freeze a correlated group only "
                    f"whole: add its other inputs to the group, or leave them all out",
                    field=f"groups.{name}")
            sets.append(("group", g, tuple(cols)))
        return sets

    def plan(self, space: InputSpace) -> RunPlan:
        s = self.settings
        m2 = len(self.frozen_sets(space)) + 2
        return RunPlan(runs=s.n_base * m2, chunk=min(s.chunk_size, s.n_base) * m2)

    def design(self, space: InputSpace, seed: int) -> Design:
        s = self.settings
        if space.dim == 0:
            raise MethodError(f"{self.label}: no uncertain input, no index to estimate")
        sets = self.frozen_sets(space)
        m2 = len(sets) + 2
        rows = PickFreezeChunks(space, s.n_base, s.sampling, s.chunk_size,
                                method_seed(seed, self.label), [c for _, _, c in sets])
        x = GeneratedRows(s.n_base * m2, space.dim, min(s.chunk_size, s.n_base) * m2, rows,
                          portable=True)
        return Design(x=x, data={"boot_seed": stream_seed(seed, self.label, 1),
                                 "sobol_boot_seed": stream_seed(seed, self.label, 2),
                                 "n_sets": len(sets)})

    def chunk_bounds(self, n_runs: int) -> list[tuple[int, int]]:
        """Blocks of ``chunk_size`` base rows with all their runs (the last may be shorter)."""
        s = self.settings
        m2 = n_runs // s.n_base if s.n_base else 1
        c = min(s.chunk_size, s.n_base) * m2
        return [(a, min(n_runs, a + c)) for a in range(0, max(n_runs, 1), c)]

    def _moments(self) -> MonteCarlo:
        """Monte Carlo over the ``A`` and ``B`` rows, which reduces and estimates them."""
        s = self.settings
        mc = MonteCarloSettings(n_samples=2 * s.n_base, chunk_size=2 * min(s.chunk_size,
                                                                            s.n_base),
                                intervals=s.intervals,
                                # (0 would switch the closed-form intervals off too)
                                bootstrap=s.bootstrap or int(s.intervals in ("tail", "delta")),
                                sensitivity="off", label=self.label)
        return MonteCarlo(mc, self.context)

    def reducer(self, space: InputSpace, design: Design) -> SaltelliReducer:
        mc = self._moments()
        inner = mc.reducer(space, Design(x=np.empty((2 * self.settings.n_base, 0)),
                                         data={"boot_seed": design.data["boot_seed"]}))
        assert isinstance(inner, MonteCarloReducer)
        return SaltelliReducer(int(design.data["n_sets"]), self.settings.bootstrap,
                               int(design.data["sobol_boot_seed"]),
                               self.context.report_times, inner)

    def fold(self, acc: dict | None, summary: dict[str, np.ndarray]) -> dict:
        """Pick-freeze sums merged per output; the ``A`` and ``B`` rows' by Monte Carlo."""
        sums, rest = split(summary)
        acc = {_SUMS: {}, "mc": None} if acc is None else acc
        for name, s in sums.items():
            acc[_SUMS][name] = acc[_SUMS][name].merge(s) if name in acc[_SUMS] else s
        acc["mc"] = self._moments().fold(acc["mc"], rest)
        return acc

    def estimate_reduced(self, space: InputSpace, design: Design, runs: ModelOutput,
                         acc: dict[str, Any] | None) -> Estimate:
        t0 = time.perf_counter()
        n_sets = int(design.data["n_sets"])
        ab = np.concatenate([np.arange(a, a + 2 * ((b - a) // (n_sets + 2)))
                             for a, b in self.chunk_bounds(runs.n)]) \
            if runs.n else np.arange(0)
        sample = ModelOutput(time=runs.time, scalars={k: v[ab] for k, v in runs.scalars.items()},
                             failed=runs.failed[ab], reasons=runs.reasons[ab])
        mc = self._moments()
        if acc is None or acc["mc"] is None:
            acc = {_SUMS: {}, "mc": None}
        est = mc.estimate_reduced(space, Design(x=np.empty((ab.size, 0))), sample, acc["mc"])
        sets = self.frozen_sets(space)
        used = 0
        for name, sums in acc[_SUMS].items():
            if name in est.stats:
                used = int(sums.w[0])
                _put_indices(est.stats[name], sums, sets, space.dim, len(self.context.groups),
                             runs.time, self.context.report_times)
                est.stats[name].sobol_groups = tuple(g for g, _ in self.context.groups)
        n_failed = int(runs.failed.sum())
        if used < 2:
            raise MethodError(f"{self.label}: {used} of {self.settings.n_base} base rows have "
                              f"all their runs (a base row with a failed run is left out); no "
                              f"indices")
        est.method, est.label = self.name, self.label
        est.diagnostics.update({
            "n_runs": runs.n, "n_failed": n_failed,
            "sample_runs": int(ab.size), "sample_failed": int(sample.failed.sum()),
            "n_base": self.settings.n_base, "n_base_used": used, "frozen_sets": len(sets),
            "sampling": self.settings.sampling, "sobol_bootstrap": self.settings.bootstrap,
            "fit_seconds": est.diagnostics.get("fit_seconds", 0.0) + time.perf_counter() - t0,
        })
        if used < self.settings.n_base:
            log.warning("%s: %d of %d base rows left out of the indices (a run of theirs "
                        "failed)", self.label, self.settings.n_base - used, self.settings.n_base)
        return est


def _put_indices(st: OutputStats, sums: PickFreezeSums,
                 sets: list[tuple[str, int, tuple[int, ...]]], d: int, n_groups: int,
                 time_grid: np.ndarray, report_times: tuple[float, ...] | None) -> None:
    """Set the indices of one output from its merged sums (lanes: every component of a scalar;
    the report steps' components of a series, NaN at the other steps)."""
    first, total, first_ci, total_ci = pick_freeze_indices(sums)          # (L, m), (2, L, m)
    k = st.mean.shape[-1]
    steps = ci_index(time_grid, report_times, "report") if st.mean.ndim == 2 else None
    rows = () if steps is None else (steps.size,)

    def place(values: np.ndarray, idx: list[int], pos: list[int], width: int) -> np.ndarray:
        """``values (..., L, m)``'s sets ``idx`` at positions ``pos`` of ``(..., [T,] k,
        width)``."""
        pre = values.shape[:-2]
        out = np.full(pre + rows + (k, width), np.nan)
        out[..., pos] = values[..., idx].reshape(pre + rows + (k, len(idx)))
        return at_steps(out, steps, time_grid.size, len(pre))

    inputs = [i for i, (kind, _, _) in enumerate(sets) if kind == "input"]
    groups = [i for i, (kind, _, _) in enumerate(sets) if kind == "group"]
    at_in, at_g = [sets[i][1] for i in inputs], [sets[i][1] for i in groups]
    st.sobol_first = place(first, inputs, at_in, d)
    st.sobol_total = place(total, inputs, at_in, d)
    st.sobol_first_ci = place(first_ci, inputs, at_in, d)
    st.sobol_total_ci = place(total_ci, inputs, at_in, d)
    if n_groups:
        st.sobol_group_first = place(first, groups, at_g, n_groups)
        st.sobol_group_total = place(total, groups, at_g, n_groups)
        st.sobol_group_first_ci = place(first_ci, groups, at_g, n_groups)
        st.sobol_group_total_ci = place(total_ci, groups, at_g, n_groups)
    st.sobol_estimator = "saltelli"


class PickFreezeChunks:
    """``make(i)``: chunk ``i`` of the design in SI units, ``A``, ``B`` and every ``A_B^u``
    of its base rows; picklable."""

    def __init__(self, space: InputSpace, n_base: int, sampling: str, chunk_size: int,
                 seed: np.random.SeedSequence, sets: list[tuple[int, ...]]) -> None:
        self.space, self.n_base, self.sampling = space, n_base, sampling
        self.chunk_size, self.seed, self.sets = min(chunk_size, n_base), seed, sets

    def __call__(self, i: int) -> np.ndarray:
        d = self.space.dim
        u = unit_chunk(2 * d, self.n_base, self.sampling, self.chunk_size, self.seed, i)
        a, b = u[:, :d], u[:, d:]
        blocks = [a, b]
        for cols in self.sets:
            ab = a.copy()
            ab[:, list(cols)] = b[:, list(cols)]
            blocks.append(ab)
        return self.space.from_unit(np.concatenate(blocks))


# -------------------- the chunk reduction, run where the chunk ran (in pool workers)
# A chunk of ``b`` base rows is laid out block by block: ``A``, ``B``, then ``A_B^u`` for each
# frozen set, all ``b`` rows: it holds everything its base rows' estimates need.

#: Summary keys of the pick-freeze sums: ``"p:<field>:<output>"`` (the others are Monte
#: Carlo's, of the ``A`` and ``B`` rows).
PICK_FREEZE = "p:"


def lanes(y: np.ndarray, steps: np.ndarray | None) -> np.ndarray:
    """An output's values ``(n, L)`` at the lanes that get indices: every component of a
    scalar, every component at ``steps`` of a series."""
    if y.ndim == 3:
        y = y[:, steps] if steps is not None else y
    return y.reshape(y.shape[0], -1)


@dataclass(frozen=True)
class SaltelliReducer:
    """Reduces one chunk of a pick-freeze design to Monte Carlo's sums of its ``A`` and ``B``
    rows and, per output, ``"p:<field>:<output>"`` (:class:`PickFreezeSums`) of the base rows
    none of whose ``m + 2`` runs failed or is non-finite (the estimators rest on the pairing).
    """

    n_sets: int
    bootstrap: int
    boot_seed: int
    report_times: tuple[float, ...] | None
    mc: MonteCarloReducer

    def __call__(self, out: ModelOutput, index: int) -> dict[str, np.ndarray]:
        m2 = self.n_sets + 2
        b = out.n // m2
        summary = self.mc(out.subset(np.arange(2 * b)), index)
        good = ~np.asarray(out.failed, dtype=bool).reshape(m2, b).any(axis=0)
        if not good.any():
            return summary
        steps = ci_index(out.time, self.report_times, "report") if out.series else None
        values = {name: lanes(y, steps).reshape(m2, b, -1)
                  for name, y in [*out.series.items(), *out.scalars.items()]}
        for v in values.values():
            good &= np.isfinite(v).all(axis=(0, 2))
        # drawn for every base row, bad ones then dropped (as Monte Carlo's, its own stream)
        rng = np.random.default_rng([self.boot_seed, index])
        w = np.concatenate([np.ones((1, b)), poisson1(rng, (self.bootstrap, b))])[:, good]
        for name, v in values.items():
            v = v[:, good]
            s = PickFreezeSums.of(v[0], v[1], v[2:], w)
            for f, arr in s.arrays().items():
                summary[f"{PICK_FREEZE}{f}:{name}"] = arr
        return summary


def split(summary: dict[str, np.ndarray]) -> tuple[dict[str, PickFreezeSums],
                                                   dict[str, np.ndarray]]:
    """A chunk's summary as its pick-freeze sums by output and the rest (Monte Carlo's)."""
    mine: dict[str, dict[str, np.ndarray]] = {}
    rest = {}
    for key, v in summary.items():
        if key.startswith(PICK_FREEZE):
            _, f, name = key.split(":", 2)
            mine.setdefault(name, {})[f] = v
        else:
            rest[key] = v
    return {k: PickFreezeSums.from_arrays(a) for k, a in mine.items()}, rest
