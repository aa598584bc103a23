"""Multi-fidelity Monte Carlo (``mfmc``): the highest level's statistics, with cheaper levels of
the same model (or a PCE method's surrogate) as control variates (Peherstorfer, Willcox &
Gunzburger 2016).

A level is the model with one ``fidelities`` entry's parameters changed, or ``{surrogate:
LABEL}``. A **pilot** at every level measures costs and correlations,
:meth:`MultiFidelityMC.allocate` chooses the levels and their runs, the **main** runs extend
each kept level on the same input stream (with a budget at measured costs in rounds, each
priced at what the one before paid: :meth:`MultiFidelityMC.top_up`) and
:meth:`MultiFidelityMC.estimate_levels` combines them. The config, the phases, the
intervals and measured gains: ``docs/multifidelity.md``.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field, model_validator

from ..core.inputs import InputSpace
from ..core.types import Estimate, GeneratedRows, ModelOutput, OutputStats
from ..errors import ConfigError, MethodError
from ..stats.mfmc_allocation import (
    Allocation, sample_sizes, select_allocation, variance_factor,
)
from ..stats.mfmc_estimator import mfmc_statistics
from ..stats.moments import quiet_overflow
from .base import (
    METHOD_FAILURES, Design, MethodSettings, Method, Propagated, Runner, RunPlan,
)
from .monte_carlo import CHUNK_ROWS, DesignChunks, ci_index, method_seed, stream_seed

log = logging.getLogger(__name__)

#: Share of ``budget_cpu_s`` the first round of main runs is planned for, at the pilot's
#: prices: a vectorised model's pilot (one small call) overprices its runs, and the estimate's
#: CPU is not known yet; the later rounds spend the rest at the prices the one before paid.
FIRST_ROUND = 0.5
#: Rounds of main runs with a budget at measured costs: the first at the pilot's prices, each
#: later one at those the round before paid.
ROUNDS = 3
#: Checkpoint stage of level ``i``'s round ``r >= 1``: ``TOP_UP_STAGE + 8 (r - 1) + i`` (the
#: pilots and the first round take stages 1 to 16).
TOP_UP_STAGE = 17
#: Resamples of the bootstrap that prices the estimate's CPU before the second round.
PROBE_RESAMPLES = 25


def _one_blas_thread() -> Any:
    """One BLAS thread for the estimate: its products are matrix-vector ones that threads do
    not speed up, and on a loaded machine threads spinning for work made its CPU 4 times
    larger (``docs/multifidelity.md``, as ``docs/pce.md#one-blas-thread``)."""
    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=1, user_api="blas")


#: A positive finite number (a standard error, seconds per run).
_Positive = Annotated[float, Field(gt=0.0, allow_inf_nan=False)]


def _one_level() -> list[dict[str, float | int | str]]:
    return [{}]


class MfmcSettings(MethodSettings):
    """Settings of ``mfmc`` (``docs/multifidelity.md``)."""

    fidelities: list[dict[str, float | int | str]] = Field(
        default_factory=_one_level, min_length=1, max_length=8,
        description="the levels, highest fidelity first: each the model parameters it changes, "
                    "or {surrogate: LABEL}, the PCE that the method LABEL, listed before this "
                    "one, fitted")
    n_pilot: int = Field(default=200, ge=10, le=1_000_000,
                         description="runs of every level in the pilot (and the least any used "
                                     "level gets)")
    budget_cpu_s: float | None = Field(default=None, gt=0.0, allow_inf_nan=False,
                                       description="CPU seconds for the whole method: the "
                                                   "model's runs, pilot included, and (costs "
                                                   "measured) the method's own, its estimate's "
                                                   "included")
    target_se: dict[str, _Positive] | None = Field(
        default=None, description="standard error of the mean wanted per output (its unit); "
                                  "exactly one of budget_cpu_s and target_se")
    optimise_for: list[str] = Field(default_factory=list,
                                    description="outputs the allocation is optimised for "
                                                "(default: every output of the run)")
    costs: list[_Positive] | None = Field(default=None, description="seconds per run of each "
                                                               "level, instead of the pilot's")
    min_gain: float = Field(default=1.1, ge=1.0, le=1e6,
                            description="estimated variance reduction below which plain MC "
                                        "of the highest level is run")
    chunk_size: int = Field(default=256, ge=1, le=1_000_000,
                            description="rows per random stream (changes the numbers); the "
                                        "model is called on blocks of whole streams, at least "
                                        "monte_carlo's chunk_size rows")
    bootstrap: int = Field(default=200, ge=0, le=100_000,
                           description="group-bootstrap resamples for the intervals of std, "
                                       "skewness, kurtosis (0: none)")
    max_runs: int = Field(default=10_000_000, ge=10, le=100_000_000,
                          description="largest number of runs of any one level")
    surrogate_ratio: float = Field(default=100.0, ge=1.0, le=1e5, allow_inf_nan=False,
                                   description="a surrogate level runs at most this many times "
                                               "the rows of the level before it")
    surrogate_values: float = Field(default=2e7, ge=1e3, le=1e10, allow_inf_nan=False,
                                    description="most values a surrogate level keeps in memory "
                                                "(rows times every output's columns)")
    estimator: Literal["mfmc", "blue"] = Field(
        default="blue", description="how the runs are combined: the best linear unbiased "
                                    "estimator (MLBLUE), or PWG16's MFMC estimator")

    @model_validator(mode="after")
    def _one_goal(self) -> MfmcSettings:
        if (self.budget_cpu_s is None) == (self.target_se is None):
            raise ValueError("give exactly one of budget_cpu_s (model CPU seconds) and "
                             "target_se (standard error of the mean per output)")
        if self.costs is not None and len(self.costs) != len(self.fidelities):
            raise ValueError(f"costs has {len(self.costs)} values for "
                             f"{len(self.fidelities)} fidelities; give one per level")
        for j, level in enumerate(self.fidelities):
            if "surrogate" not in level:
                continue
            if j == 0:
                raise ValueError("fidelities[0] is the highest fidelity, whose statistics are "
                                 "estimated: it must be the model, not {surrogate: ...}")
            if len(level) != 1 or not isinstance(level["surrogate"], str):
                raise ValueError(f"fidelities[{j}]: a surrogate level is {{surrogate: LABEL}} "
                                 f"alone, LABEL a PCE method's label; got {dict(level)}")
        if self.max_runs < self.n_pilot:
            raise ValueError(f"max_runs ({self.max_runs}) must be at least n_pilot "
                             f"({self.n_pilot})")
        return self


@dataclass
class LevelPlan:
    """What the pilot decided: the config ``levels`` used, in estimator order (0 first), the
    runs ``sizes`` of each (rows ``[0, m_i)``), the seconds per run ``costs (K,)`` of every config
    level (``measured`` or given) and a ``note``: why plain MC, or what limited the sizes."""

    levels: tuple[int, ...]
    sizes: np.ndarray
    allocation: Allocation
    costs: np.ndarray
    measured: bool
    note: str = ""
    #: the estimate's CPU seconds per run of a used level beyond its pilot (0: not priced)
    estimate_per_run: float = 0.0
    #: rounds of main runs planned so far (later ones at the prices the one before paid)
    rounds: int = 1


class MultiFidelityMC(Method):
    """Multi-fidelity Monte Carlo over fidelity levels of the run's model."""

    name = "mfmc"
    summary = "multi-fidelity Monte Carlo: cheaper fidelity levels as control variates"
    #: It prices each level by the CPU of its calls, which smaller calls would raise (its
    #: chunks are :attr:`block_rows`, whole calls, for that).
    runs_in_pieces = False
    Settings = MfmcSettings
    settings: MfmcSettings
    example_settings = {"fidelities": [{}], "n_pilot": 40, "costs": [1e-3],
                        "budget_cpu_s": 0.3, "chunk_size": 64, "bootstrap": 50,
                        "max_runs": 1000}

    def check(self, index: int) -> None:
        """ConfigError for outputs the run does not report, and for quantiles and events."""
        where = f"methods[{index}]"
        known = list(self.context.outputs)
        for key, names in (("optimise_for", self.settings.optimise_for),
                           ("target_se", list(self.settings.target_se or {}))):
            for name in names:
                if known and name not in known:
                    raise ConfigError(f"{where}.{key}: {name!r} is not an output of the run; "
                                      f"allowed: {', '.join(known)}", field=f"{where}.{key}")
        if self.context.quantile_levels is not None or self.context.events:
            raise ConfigError(f"{where}: mfmc estimates moments only; remove quantiles, "
                              f"events and requirements from the config or run them with "
                              f"monte_carlo", field=where)

    @property
    def surrogate_levels(self) -> dict[int, str]:
        """The levels that are a PCE method's surrogate: level index to that method's label."""
        return {j: str(f["surrogate"]) for j, f in enumerate(self.settings.fidelities)
                if "surrogate" in f}

    def check_order(self, methods: Sequence[Method], index: int) -> None:
        """ConfigError naming ``methods[i].fidelities[j]`` when a surrogate level names no PCE
        method listed before this one (the surrogate must be fitted before the pilot)."""
        before = {m.label: m for m in methods[:index]}
        fitting = [lab for lab, m in before.items() if m.fits_surrogate]
        for j, label in self.surrogate_levels.items():
            where = f"methods[{index}].fidelities[{j}]"
            m = before.get(label)
            if m is None or not m.fits_surrogate:
                what = ("is not a PCE method" if m is not None else
                        "is not the label of a method listed before this one")
                raise ConfigError(f"{where}: surrogate {label!r} {what}; allowed: "
                                  f"{', '.join(fitting) or 'none (list a PCE method first)'}",
                                  field=where)

    def check_model(self, model: Any, index: int) -> None:
        """ConfigError naming ``methods[i].fidelities[j]`` when a level changes a parameter
        that does not set the model's fidelity, or sets a value the model refuses."""
        for j, changes in enumerate(self.settings.fidelities):
            if "surrogate" in changes:
                continue
            try:
                model.at_fidelity(changes)
            except ValueError as exc:
                why = str(exc).splitlines()[0]
                if hasattr(exc, "errors"):  # pydantic: the field's own message
                    e = exc.errors()[0]
                    why = f"{'.'.join(map(str, e['loc']))}: {e['msg']}"
                raise ConfigError(f"methods[{index}].fidelities[{j}]: {dict(changes)}: {why}",
                                  field=f"methods[{index}].fidelities[{j}]") from None

    def plan(self, space: InputSpace) -> RunPlan:
        return RunPlan(runs=None, chunk=self.block_rows, exact=False)

    def design(self, space: InputSpace, seed: int) -> Design:
        """One stream of input rows shared by every level (rows made per chunk on demand)."""
        s = self.settings
        boot_seed = stream_seed(seed, self.label, 1)
        chunks = DesignChunks(space, s.max_runs, "random", s.chunk_size,
                              method_seed(seed, self.label))
        x = GeneratedRows(s.max_runs, space.dim, s.chunk_size, chunks, portable=True)
        return Design(x=x, data={"boot_seed": boot_seed})

    def planned_chunks(self, design: Design, batch_size: int) -> None:
        """None: the levels' runs are planned phase by phase, once the pilot has run."""
        return None

    def propagate(self, space: InputSpace, design: Design, runner: Runner) -> Propagated:
        """Pilot, allocation, main runs and estimate over the levels.

        Level ``i``'s pilot is checkpoint stage ``1 + 2 i`` (rows ``[0, n_pilot)``), its main
        runs stage ``2 + 2 i``: a resumed run restores the pilot chunks with their measured
        seconds, so it makes the same allocation. A failure is recorded without runs (they stay
        in the checkpoint).
        """
        try:
            return self._propagate(design, runner)
        except METHOD_FAILURES as exc:
            return Propagated.failed(self, exc, np.zeros((0, space.dim)), None)

    def _level(self, runner: Runner, j: int, changes: dict[str, Any]) -> Runner:
        """The runner of level ``j``: the model at a fidelity, or a surrogate."""
        if "surrogate" not in changes:
            return runner.at_fidelity(changes)
        try:
            return runner.surrogate_of(str(changes["surrogate"]))
        except MethodError as exc:
            raise MethodError(f"{self.label}: fidelities[{j}]: {exc}") from None

    def _propagate(self, design: Design, runner: Runner) -> Propagated:
        s = self.settings
        levels = [self._level(runner, j, f) for j, f in enumerate(s.fidelities)]

        def run_rows(i: int, stage: int, start: int, stop: int,
                     after: ModelOutput | None = None) -> ModelOutput | None:
            chunks = self.row_chunks(start, stop)
            if not chunks:
                return after
            levels[i].plan(chunks)
            out, _ = levels[i].run(design.x, stage, chunks, after=after)
            return out

        pilot = []
        for i in range(len(levels)):
            runner.phase(f"pilot of level {i} ({s.n_pilot} runs)")
            out = run_rows(i, 1 + 2 * i, 0, s.n_pilot)
            assert out is not None  # (n_pilot >= 10)
            pilot.append(out)
        # CPU, not wall seconds: the wall clock counts the neighbours' load
        pilot_cost = [lv.cpu_seconds / max(lv.n_runs, 1) for lv in levels]
        own = time.process_time()  # the method's own CPU here, the allocation and probes
        with quiet_overflow(), _one_blas_thread():  # (as the fits of Method.propagate)
            plan = self.allocate(pilot, pilot_cost,
                                 share=FIRST_ROUND if self._tops_up else 1.0)
        own = time.process_time() - own
        log.info("%s: levels %s, runs %s (estimated variance reduction %.3g)", self.label,
                 plan.levels, list(plan.sizes), 1.0 / plan.allocation.variance_ratio)
        have = dict(enumerate(pilot))
        prices = np.asarray(pilot_cost, dtype=float)
        earlier = np.full(len(levels), np.nan)  # the prices of the round before (not yet)
        fixed = per_row = moved = 0.0
        last = ROUNDS - 1 if self._tops_up else 0
        for r in range(last + 1):
            if r:
                t_own = time.process_time()
                with quiet_overflow(), _one_blas_thread():
                    if r == 1 or r == last:
                        # priced again before the last round on the rows run so far, near
                        # the final count: its CPU per row grows with the groups' size
                        fixed, per_row = self._estimate_price(
                            pilot, [have[i] for i in plan.levels], plan, design,
                            fixed=fixed if r > 1 else None)
                    spent = sum(lv.cpu_seconds for lv in levels) + own + moved + \
                        time.process_time() - t_own
                    # the last round is planned at prices raised by as much as a used
                    # level's price moved between the two rounds before (the machine's
                    # load and caches move it): a reserve for a move as large again
                    drift = _price_drift(prices, earlier, plan.levels) if r == last else 0.0
                    plan = self.top_up(pilot, plan, prices * (1.0 + drift),
                                       (fixed, per_row * (1.0 + drift)), spent,
                                       {i: out.n for i, out in have.items()},
                                       reselect=r == 1)
                own += time.process_time() - t_own
            before = [(lv.cpu_seconds, have[i].n) for i, lv in enumerate(levels)]
            moving = np.zeros(len(levels))
            for j, i in enumerate(plan.levels):
                runner.phase("")
                c_model, c_here = levels[i].cpu_seconds, time.process_time()
                out = run_rows(i, 2 + 2 * i if r == 0 else TOP_UP_STAGE + 8 * (r - 1) + i,
                               have[i].n, int(plan.sizes[j]), after=have[i])
                assert out is not None  # (the pilot's rows at least)
                moving[i] = _moving_cpu(time.process_time() - c_here,
                                        levels[i].cpu_seconds - c_model)
                have[i] = out
            moved += float(moving.sum())
            # each level's price: CPU per run of its latest round (a larger call is cheaper
            # per run for a vectorised model, so a later round is priced better), the rows'
            # moving between the processes included
            earlier = prices if r else earlier
            prices = np.array([(lv.cpu_seconds - c + moving[i]) / (have[i].n - n)
                               if have[i].n > n else prices[i] for i, (lv, (c, n)) in
                               enumerate(zip(levels, before))])
        runs = [have[i] for i in plan.levels]
        t_fit = time.perf_counter()
        runner.phase("estimating")
        with quiet_overflow(), _one_blas_thread():
            estimate = self.estimate_levels(
                runs, plan, design, [lv.cpu_seconds for lv in levels], pilot_cost,
                surrogate_cpu_s=sum(lv.fixed_cpu_s for lv, f in zip(levels, s.fidelities)
                                    if "surrogate" in f), overhead_cpu_s=own + moved)
        runner.phase("")
        top = runs[0]
        x = np.asarray(design.x.rows(0, top.n)) if isinstance(design.x, GeneratedRows) \
            else np.asarray(design.x)[:top.n]
        return Propagated(estimate, x, top, time.perf_counter() - t_fit)

    @property
    def _tops_up(self) -> bool:
        """Whether the main runs come in two rounds: a budget at measured costs."""
        return self.settings.budget_cpu_s is not None and self.settings.costs is None

    def _estimate_price(self, pilot: list[ModelOutput], runs: list[ModelOutput],
                        plan: LevelPlan, design: Design, fixed: float | None = None
                        ) -> tuple[float, float]:
        """The CPU seconds :meth:`estimate_levels` will take, as a fixed part and a part per
        run of a used level beyond its pilot (its work grows with each level's rows): its cost
        on the pilots (unless ``fixed`` is known) and on the runs so far, each without
        resamples and with a few, extrapolated to ``bootstrap`` resamples."""
        b = self.settings.bootstrap
        k = len(self.settings.fidelities)
        probe = min(PROBE_RESAMPLES, b)

        def cost(outs: list[ModelOutput], sized: LevelPlan) -> float:
            t0 = time.process_time()
            self.estimate_levels(outs, sized, design, [0.0] * k, [0.0] * k, n_resamples=0)
            t1 = time.process_time()
            if probe:
                self.estimate_levels(outs, sized, design, [0.0] * k, [0.0] * k,
                                     n_resamples=probe)
            t2 = time.process_time()
            return (t1 - t0) + b * max(t2 - t1 - (t1 - t0), 0.0) / max(probe, 1)

        n_p = self.settings.n_pilot
        if fixed is None:
            fixed = cost([pilot[i] for i in plan.levels],
                         replace(plan, sizes=np.full(len(plan.levels), n_p)))
        grown = float(np.sum(plan.sizes)) - n_p * len(plan.levels)
        if grown <= 0:
            return fixed, 0.0
        return fixed, max(cost(runs, plan) - fixed, 0.0) / grown

    @property
    def block_rows(self) -> int:
        """Rows per checkpointed chunk (a block of model calls): whole random streams, at least
        ``monte_carlo``'s chunk, so that a vectorised model costs per run what it costs there
        (in calls of 256 rows a pendulum cost 2.8 times as much per run)."""
        c = self.settings.chunk_size
        return c * -(-CHUNK_ROWS // c)

    def row_chunks(self, start: int, stop: int) -> list[tuple[int, int]]:
        """Rows ``[start, stop)`` split at the multiples of :attr:`block_rows`."""
        c = self.block_rows
        cuts = [start, *range((start // c + 1) * c, stop, c), stop]
        return [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]

    def _targets(self) -> list[str]:
        return list(self.settings.optimise_for) or list(self.context.outputs)

    def _report_columns(self, out: ModelOutput, name: str) -> np.ndarray:
        """Columns of :func:`values` at the report times and the last step."""
        if name in out.scalars:
            return np.arange(out.scalars[name].shape[1])
        k = out.series[name].shape[2]
        idx = ci_index(out.time, self.context.report_times, "report")
        steps = np.arange(out.time.size) if idx is None else idx
        return (steps[:, None] * k + np.arange(k)[None, :]).ravel()

    def allocate(self, pilot: list[ModelOutput], seconds_per_run: list[float],
                 share: float = 1.0) -> LevelPlan:
        """The levels and runs per level from the pilot's outputs and CPU seconds per run at
        every config level (``docs/multifidelity.md#what-it-does``, step 2), for ``share``
        of ``budget_cpu_s``."""
        s = self.settings
        measured = s.costs is None
        raw = np.asarray(seconds_per_run if measured else s.costs, dtype=float)
        costs = raw.copy()
        if measured:
            if not np.all(np.isfinite(raw) & (raw > 0)):
                raise MethodError(f"{self.label}: the pilot measured no model time at some "
                                  f"level ({list(raw)} CPU-s per run); give costs")
            rel = raw / raw[0]
            rounded = np.array([float(f"{r:.2g}") for r in rel])
            costs = rounded * float(f"{raw[0]:.2g}")
        rows, var0, owner = self._pilot_quantities(pilot)
        rho = _correlations(rows)
        step = np.array([s.surrogate_ratio if i in self.surrogate_levels else np.inf
                         for i in range(len(costs))])
        allocation = select_allocation(rho, costs, s.min_gain, max_step=step)
        notes = [f"surrogate rows capped at surrogate_ratio = {s.surrogate_ratio:g} times the "
                 f"level before"] if _at_cap(allocation, step) else []
        if allocation.is_plain_mc and len(costs) > 1:
            notes = [f"the pilot found no gain above min_gain = {s.min_gain:g} from the cheaper "
                     f"levels (correlations too low for their cost): plain Monte Carlo of the "
                     f"highest level"]
            log.warning("%s: %s", self.label, notes[0])
        levels = allocation.levels
        unused = [i for i in range(len(costs)) if i not in levels]
        if s.budget_cpu_s is not None:
            spent_unused = float(sum(costs[i] for i in unused)) * s.n_pilot
            sizes = sample_sizes(allocation, costs, budget=max(
                share * s.budget_cpu_s - spent_unused, 0.0), at_least=s.n_pilot)
        else:
            sizes = sample_sizes(allocation, costs, m0=self._m0_for_target(
                var0, owner, rho, allocation), at_least=s.n_pilot)
        sizes, held = self._bounded(sizes, levels, pilot[0])
        notes += held
        if s.budget_cpu_s is not None and \
                float(np.dot(costs[list(levels)], np.full(len(levels), s.n_pilot))) \
                + sum(costs[i] for i in unused) * s.n_pilot > s.budget_cpu_s:
            notes.append("the pilot alone exceeds budget_cpu_s: every used level keeps its "
                         "pilot runs")
        return LevelPlan(levels=levels, sizes=sizes, allocation=allocation, costs=costs,
                         measured=measured, note="; ".join(notes))

    def top_up(self, pilot: list[ModelOutput], plan: LevelPlan, prices: np.ndarray,
               estimate: tuple[float, float], spent: float, done: dict[int, int],
               reselect: bool = True) -> LevelPlan:
        """A further round: the allocation (``plan``'s unless ``reselect``) at the prices the
        latest round paid (``prices (K,)``, each config level's CPU seconds per run) and the
        estimate's (``(fixed, per run of a used level beyond its pilot)``), with the most runs
        whose CPU, with the ``spent`` so far, stays within ``budget_cpu_s``; ``done``: the
        rows each level has run (never fewer)."""
        s = self.settings
        assert s.budget_cpu_s is not None
        prices = np.asarray(prices, dtype=float)
        fixed, per_row = estimate
        allocation = plan.allocation
        if reselect:
            rho = _correlations(self._pilot_quantities(pilot)[0])
            step = np.array([s.surrogate_ratio if i in self.surrogate_levels else np.inf
                             for i in range(len(prices))])
            allocation = select_allocation(rho, prices + per_row, s.min_gain, max_step=step)
            if not {i for i in plan.levels if done[i] > s.n_pilot} <= set(allocation.levels):
                # a level the round before ran beyond its pilot stays: its CPU is spent, and
                # dropping it would waste it (the allocation among the same levels at the
                # new prices is the old one's ratios, near enough for one more round)
                allocation = plan.allocation
        levels = allocation.levels
        floor = np.array([done[i] for i in levels])

        def sized(m0: float) -> tuple[np.ndarray, list[str]]:
            m = np.maximum(np.floor(allocation.ratios * m0 + 1e-9).astype(np.int64), floor)
            m, notes = self._bounded(np.maximum.accumulate(m), levels, pilot[0])
            # (rows already run stay in: a surrogate held below them keeps them)
            return np.maximum.accumulate(np.maximum(m, floor)), notes

        def cost(m0: float) -> float:
            m = sized(m0)[0]
            return float(np.dot(prices[list(levels)], m - floor) + fixed +
                         per_row * (m.sum() - s.n_pilot * m.size))

        left = s.budget_cpu_s - spent
        lo, hi = 0.0, float(s.max_runs)
        if cost(hi) <= left:
            lo = hi
        while hi - lo > 0.5:  # (a monotone cost: the largest m_0 within what is left)
            mid = (lo + hi) / 2
            lo, hi = (mid, hi) if cost(mid) <= left else (lo, mid)
        sizes, notes = sized(lo)
        notes = [n for n in plan.note.split("; ") if n] + \
            [n for n in notes if n not in plan.note]
        if allocation.is_plain_mc and not plan.allocation.is_plain_mc:
            notes.append("at the first round's prices no cheaper level gains above "
                         f"min_gain = {s.min_gain:g}: the second round is plain Monte Carlo")
        return LevelPlan(levels=levels, sizes=sizes, allocation=allocation,
                         costs=prices, measured=True,
                         note="; ".join(notes), estimate_per_run=per_row,
                         rounds=plan.rounds + 1)

    def _bounded(self, sizes: np.ndarray, levels: tuple[int, ...], top: ModelOutput
                 ) -> tuple[np.ndarray, list[str]]:
        """``sizes`` held within a surrogate's memory and ``max_runs``, with notes saying so."""
        sizes, held = self._hold_surrogate_memory(sizes, levels, top)
        notes = [held] if held else []
        if sizes[-1] > self.settings.max_runs:
            notes.append(f"capped at max_runs = {self.settings.max_runs}")
            sizes = np.minimum(sizes, self.settings.max_runs)
        return sizes, notes

    def _hold_surrogate_memory(self, sizes: np.ndarray, levels: tuple[int, ...],
                               top: ModelOutput) -> tuple[np.ndarray, str]:
        """``sizes`` with each surrogate level's rows cut so that its values take at most
        ``surrogate_values`` floats (at least the rows of the level before it), and a note."""
        s = self.settings
        cols = sum(int(np.prod(v.shape[1:])) for v in top.scalars.values()) + \
            sum(int(np.prod(v.shape[1:])) for v in top.series.values())
        most = max(int(s.surrogate_values // max(cols, 1)), 1)
        out = sizes.copy()
        cut = False
        for j, i in enumerate(levels):
            if j and i in self.surrogate_levels and out[j] > max(most, out[j - 1]):
                out[j], cut = max(most, out[j - 1]), True
        out = np.maximum.accumulate(out)
        note = (f"surrogate rows held at {most} ({cols} values per row, surrogate_values = "
                f"{s.surrogate_values:g})") if cut else ""
        return out, note

    def _pilot_quantities(self, pilot: list[ModelOutput]
                          ) -> tuple[list[np.ndarray], np.ndarray, np.ndarray]:
        """Per level, the pilot's values ``(n_ok, 2Q)`` of the quantities and their centred
        squares on the rows no level failed; level 0's variances ``(Q,)`` and each quantity's
        output ``(Q,)``. Constant quantities (zero variance at level 0) are left out."""
        n = self.settings.n_pilot
        ok = usable_rows([p.failed for p in pilot], np.full(len(pilot), n))
        if ok.sum() < 3:
            raise MethodError(f"{self.label}: {int(ok.sum())} of {n} pilot rows ran at every "
                              f"level without failing; at least 3 are needed")
        cols: list[list[np.ndarray]] = [[] for _ in pilot]
        owner: list[str] = []
        for name in self._targets():
            idx = self._report_columns(pilot[0], name)
            owner += [name] * len(idx)
            for j, p in enumerate(pilot):
                v, _ = values(p, name, pilot[0].time)
                cols[j].append(v[:, idx])
        lv = [np.concatenate(c, axis=1) for c in cols]
        # an output a model leaves NaN by design (a time never reached) is no correlation
        ok &= np.all([np.isfinite(v).all(axis=1) for v in lv], axis=0)
        if ok.sum() < 3:
            raise MethodError(f"{self.label}: {int(ok.sum())} of {n} pilot rows have finite "
                              f"values of {', '.join(self._targets())} at every level; at "
                              f"least 3 are needed")
        lv = [v[ok] for v in lv]
        var0 = lv[0].var(axis=0)
        keep = var0 > 1e-24 * np.maximum(lv[0].mean(axis=0) ** 2, 1e-300)
        lv = [v[:, keep] for v in lv]
        centred = [v - v.mean(axis=0) for v in lv]
        return ([np.concatenate([c, c * c], axis=1) for c in centred], var0[keep],
                np.asarray(owner, dtype=object)[keep])

    def _m0_for_target(self, var0: np.ndarray, owner: np.ndarray, rho: np.ndarray,
                       allocation: Allocation) -> float:
        """The ``m_0`` at which every ``target_se`` output's mean reaches its standard error:
        ``sigma^2 g / se^2`` (PWG16 Lemma 3.3), the largest over its components and times."""
        assert self.settings.target_se is not None
        need = 1.0
        rho1 = rho[:var0.size][:, list(allocation.levels)]  # (the first powers)
        g = variance_factor(rho1, allocation.ratios)
        for name, se in self.settings.target_se.items():
            mine = owner == name
            if mine.any():
                need = max(need, float(np.max(var0[mine] * g[mine])) / se**2)
        return need

    def estimate(self, space: InputSpace, design: Design, outputs: ModelOutput) -> Estimate:
        raise MethodError(f"{self.label}: mfmc runs its levels in phases (propagate), not "
                          f"on one model's runs")

    def estimate_levels(self, runs: list[ModelOutput], plan: LevelPlan, design: Design,
                        seconds: list[float], pilot_seconds: list[float],
                        surrogate_cpu_s: float = 0.0, n_resamples: int | None = None,
                        overhead_cpu_s: float = 0.0) -> Estimate:
        """Statistics of every output from the used levels' runs (rows ``[0, m_i)`` of each).
        ``seconds``: every config level's model seconds; ``pilot_seconds``: per pilot run;
        ``surrogate_cpu_s``: the surrogate levels' PCE runs and fits, charged to the saving;
        ``n_resamples``: the bootstrap's (default ``bootstrap``); ``overhead_cpu_s``: the
        method's CPU beyond the models and the estimate (allocation, the estimate's pricing,
        moving rows between processes), charged to the saving."""
        resamples = self.settings.bootstrap if n_resamples is None else n_resamples
        t_cpu = time.process_time()
        sizes = plan.sizes
        ok = usable_rows([r.failed for r in runs], sizes)
        grid = runs[0].time
        names = list(self.context.outputs) or [*runs[0].scalars, *runs[0].series]
        stats: dict[str, OutputStats] = {}
        how: set[tuple[int, str]] = set()
        boot_seed = int(design.data.get("boot_seed", 0))
        equivalent: dict[str, float] = {}
        equivalent_std: dict[str, float] = {}
        nan_rows: dict[str, int] = {}
        for name in names:
            lv = []
            finite = ok.copy()
            for j, r in enumerate(runs):
                v, h = values(r, name, grid)
                lv.append(v)
                finite[:sizes[j]] &= np.isfinite(v).all(axis=1)
                if h != "same":
                    how.add((plan.levels[j], h))
            if (~finite & ok).any():
                nan_rows[name] = int((~finite & ok).sum())
            try:
                full = mfmc_statistics(lv, sizes, finite, n_resamples=0,
                                       estimator=self.settings.estimator)
            except ValueError as exc:
                raise MethodError(f"{self.label}: {name}: {exc}") from None
            cols = self._report_columns(runs[0], name)
            boot = mfmc_statistics([v[:, cols] for v in lv], sizes, finite,
                                   n_resamples=resamples, seed=boot_seed,
                                   estimator=self.settings.estimator) if resamples else None
            stats[name] = _output_stats(full, boot, cols, runs[0], name, finite[:sizes[0]])
            equivalent[name] = _least(full.equivalent_mc_runs)
            equivalent_std[name] = _least(full.equivalent_mc_runs_std)
        n_failed = int((~ok).sum())
        targets = [t for t in self._targets() if t in equivalent]
        eq = min((equivalent[t] for t in targets), default=float("nan"))
        eq_std = min((equivalent_std[t] for t in targets), default=float("nan"))
        c0 = float(plan.costs[0])
        # the saving at the prices the runs paid: the highest level's cost per run over all
        # its runs (the pilot's small calls may cost a vectorised model more per run), and the
        # estimate's own CPU (its bootstrap costs microseconds per row, as a cheap run does)
        m0 = int(sizes[0])
        c0_paid = float(seconds[plan.levels[0]]) / m0 if plan.measured and m0 else c0
        estimate_cpu_s = time.process_time() - t_cpu
        cpu = float(sum(seconds)) + surrogate_cpu_s + estimate_cpu_s + overhead_cpu_s
        diagnostics: dict[str, Any] = {
            # (a level left out of the estimate still ran its pilot)
            "n_runs": int(sum(r.n for r in runs))
            + (len(self.settings.fidelities) - len(plan.levels)) * self.settings.n_pilot,
            "n_failed": n_failed,
            "levels": "; ".join(_level_name(f) for f in self.settings.fidelities),
            "levels_used": ",".join(str(i) for i in plan.levels),
            "runs_per_level": np.array([int(sizes[plan.levels.index(i)])
                                        if i in plan.levels else self.settings.n_pilot
                                        for i in range(len(self.settings.fidelities))]),
            "cpu_per_level": np.asarray(seconds, dtype=float),
            "surrogate_cpu_s": surrogate_cpu_s,
            "cost_per_run": np.asarray(plan.costs, dtype=float),
            "costs": ("measured (the runs of the round before the last)" if plan.rounds > 1
                      else "measured (pilot, 2 significant digits)") if plan.measured
            else "given",
            "rounds": plan.rounds,
            "estimate_cpu_per_run": plan.estimate_per_run,
            "pilot_seconds_per_run": np.asarray(pilot_seconds, dtype=float),
            "estimated_variance_reduction": 1.0 / plan.allocation.variance_ratio,
            "equivalent_mc_runs": eq,
            "equivalent_mc_cpu_s": eq * c0,
            "equivalent_mc_runs_std": eq_std,
            "estimate_cpu_s": estimate_cpu_s,
            "overhead_cpu_s": overhead_cpu_s,
            "cpu_saving": self._cpu_saving(plan, min(eq, eq_std) * c0_paid, seconds, cpu),
            "plain_mc": bool(plan.allocation.is_plain_mc),
            "note": plan.note,
            "interpolated": ", ".join(f"level {i} {h}" for i, h in sorted(how)) or "none",
            "intervals": "mean: variance formula; std, skewness, kurtosis: group bootstrap",
            # a difference between the levels rarer than this may be in none of the highest
            # level's rows (95%, rule of three), unseen by the estimate and its intervals
            "unseen_difference_rate": 3.0 / max(int(sizes[0]), 1),
            "bootstrap": self.settings.bootstrap,
            "non_finite_rows": "; ".join(f"{k} ({v})" for k, v in nan_rows.items()) or "none",
        }
        # per output: which one limits the saving
        for name in equivalent:
            diagnostics[f"equivalent_mc_runs.{name}"] = equivalent[name]
            diagnostics[f"equivalent_mc_runs_std.{name}"] = equivalent_std[name]
        return Estimate(method=self.name, label=self.label, stats=stats,
                        diagnostics=diagnostics)

    @staticmethod
    def _cpu_saving(plan: LevelPlan, mc_cpu: float, seconds: list[float], cpu: float) -> float:
        """Plain-MC CPU for the standard errors reached over the CPU spent; for a fallback to
        plain MC, which is plain MC of the highest level, the share of the CPU its runs took
        (at most 1: the unused levels' pilots were spent for nothing)."""
        if not cpu > 0:
            return float("nan")
        if plan.allocation.is_plain_mc:
            return min(float(seconds[plan.levels[0]]) / cpu, 1.0)
        return mc_cpu / cpu


def _price_drift(prices: np.ndarray, earlier: np.ndarray, used: tuple[int, ...]) -> float:
    """The largest relative change of a used level's price per run from the round before
    (``earlier``, NaN: the pilot's, which a small call makes dearer, not a drift) to the
    latest (``prices``); 0 where no level has two main rounds' prices."""
    i = list(used)
    with np.errstate(invalid="ignore", divide="ignore"):
        change = np.abs(prices[i] / earlier[i] - 1.0)
    change = change[np.isfinite(change)]
    return float(change.max()) if change.size else 0.0


def _moving_cpu(driver_cpu: float, model_cpu: float) -> float:
    """The CPU seconds a level's round spent beyond its model's, moving rows between the
    processes, from the driver's CPU in that round and the model's: a model in the driver's
    process is in both, so the driver's excess is the moving; a model in another process (a
    guard, workers) is not in the driver's, whose CPU is then all moving, and the other side
    spends as much again (it serialises what the driver deserialises, and back)."""
    if driver_cpu >= model_cpu:
        return driver_cpu - model_cpu
    return 2.0 * driver_cpu


def _least(equivalent: np.ndarray | None) -> float:
    """The fewest equivalent Monte Carlo runs over an output's columns (NaN: none finite)."""
    v = np.asarray(equivalent if equivalent is not None else [], dtype=float)
    v = v[np.isfinite(v)]
    return float(v.min()) if v.size else float("nan")


def _level_name(changes: dict[str, Any]) -> str:
    if "surrogate" in changes:
        return f"surrogate of {changes['surrogate']}"
    return ", ".join(f"{k}={v}" for k, v in changes.items()) or "model as configured"


def _at_cap(allocation: Allocation, step: np.ndarray) -> bool:
    """Whether a capped level (a surrogate) got its largest ratio over the level before it."""
    r = allocation.ratios
    return any(np.isfinite(step[i]) and r[j] >= step[i] * r[j - 1] * (1 - 1e-9)
               for j, i in enumerate(allocation.levels) if j > 0)


def _correlations(rows: list[np.ndarray]) -> np.ndarray:
    """``(Q, K)`` correlation of every (centred) quantity of each level with level 0's."""
    a = rows[0]
    out = np.ones((a.shape[1], len(rows)))
    da = a - a.mean(axis=0)
    sa = np.sqrt((da * da).mean(axis=0))
    for j in range(1, len(rows)):
        db = rows[j] - rows[j].mean(axis=0)
        sb = np.sqrt((db * db).mean(axis=0))
        with np.errstate(invalid="ignore", divide="ignore"):
            out[:, j] = np.where((sa > 0) & (sb > 0), (da * db).mean(axis=0) / (sa * sb), 0.0)
    return out


def _output_stats(full: Any, boot: Any, cols: np.ndarray, run0: ModelOutput, name: str,
                  ok0: np.ndarray) -> OutputStats:
    """The MFMC estimates in the output's shape: ``(k,)`` or ``(T, k)``."""
    if name in run0.scalars:
        shape: tuple[int, ...] = (run0.scalars[name].shape[1],)
        y0 = run0.scalars[name][ok0]
    else:
        shape = run0.series[name].shape[1:]
        y0 = run0.series[name][ok0]
    k = shape[-1]
    ci = {"mean": full.ci["mean"].reshape((2, *shape))}
    for stat in ("std", "skewness", "kurtosis"):
        v = np.full((2, int(np.prod(shape))), np.nan)
        if boot is not None:
            v[:, cols] = boot.ci[stat]
        ci[stat] = v.reshape((2, *shape))
    d = y0 - y0.mean(axis=0)
    cov = np.einsum("n...i,n...j->...ij", d, d) / max(y0.shape[0], 1)
    var = (full.std.reshape(shape)) ** 2
    eye = np.eye(k, dtype=bool)
    cov = np.where(eye, var[..., :, None] * np.ones(k), cov)
    return OutputStats(mean=full.mean.reshape(shape), std=full.std.reshape(shape),
                       skewness=full.skewness.reshape(shape),
                       kurtosis=full.kurtosis.reshape(shape), cov=cov,
                       n_used=int(full.n_used[0]), moments_method="mfmc",
                       sem=full.sem.reshape(shape), ci=ci)


# -------------------- the levels' outputs side by side, on the highest level's grid

def on_grid(series: np.ndarray, grid: np.ndarray, target: np.ndarray) -> tuple[np.ndarray, str]:
    """A series ``(n, T, k)`` on ``grid (T,)`` at the times ``target (T0,)``: ``(n, T0, k)``
    and how: ``"same"`` grid, ``"sampled"`` (the target times picked from the grid, to 1e-9)
    or ``"interpolated"`` (linearly, held at the ends)."""
    if grid.shape == target.shape and np.array_equal(grid, target):
        return series, "same"
    tol = 1e-9 * max(float(np.max(np.abs(grid))) if grid.size else 1.0, 1.0)
    idx = np.clip(np.searchsorted(grid, target - tol), 0, grid.size - 1)
    if np.all(np.abs(grid[idx] - target) <= tol):
        return series[:, idx], "sampled"
    hi = np.clip(np.searchsorted(grid, target), 1, grid.size - 1)
    lo = hi - 1
    span = grid[hi] - grid[lo]
    w = np.clip(np.where(span > 0, (target - grid[lo]) / np.where(span > 0, span, 1), 0), 0, 1)
    return series[:, lo] * (1 - w)[None, :, None] + series[:, hi] * w[None, :, None], \
        "interpolated"


def values(out: ModelOutput, name: str, target: np.ndarray) -> tuple[np.ndarray, str]:
    """The output ``name`` flattened to ``(n, Q)``: a scalar's ``k`` components, or a series'
    ``T0 k`` values on the highest level's grid ``target`` (time-major), with how the grid was
    matched (``"same"`` for a scalar)."""
    if name in out.scalars:
        v = out.scalars[name]
        return v.reshape(v.shape[0], -1).astype(float), "same"
    s, how = on_grid(out.series[name], out.time, target)
    return s.reshape(s.shape[0], -1).astype(float), how


def usable_rows(failed: list[np.ndarray], sizes: np.ndarray) -> np.ndarray:
    """Rows ``(m_last,)`` that failed at no level they ran at."""
    ok = np.ones(int(sizes[-1]), dtype=bool)
    for f, m in zip(failed, sizes):
        ok[:int(m)] &= ~np.asarray(f[:int(m)], dtype=bool)
    return ok
