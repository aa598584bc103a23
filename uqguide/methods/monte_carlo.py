"""Monte Carlo propagation: the design, the chunk reduction, the fold and the error budget.

Chunk ``i`` of ``chunk_size`` unit-cube samples (random, Latin hypercube or scrambled Sobol')
comes from child ``i`` of one ``SeedSequence`` of the seed and the label; each chunk is reduced
where it ran (:class:`MonteCarloReducer`), merged in chunk order (:class:`FoldedSums`) and
estimated by :meth:`MonteCarlo.estimate_reduced`, so the numbers never depend on the workers.
Pool workers import this module: keep its top-level imports light. Intervals, quantiles and
events: ``docs/statistics.md``; the error budget (:func:`add_indices`): ``docs/error-budget.md``.
"""

from __future__ import annotations

import math
import os
import time
import zlib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import partial
from typing import Annotated, Any, Literal, Union

import numpy as np
from pydantic import Discriminator, Field, Tag

from ..errors import ConfigError, MethodError
from ..core.inputs import InputSpace
from ..core.types import Estimate, GeneratedRows, ModelOutput, OutputStats, ScalarIndex
from ..core.events import EventEstimate, EventSpec, component_index, count_events
from ..core.strict import StrictModel
from ..stats.quantiles import lane_quantiles, order_statistic_quantiles
from ..stats.moments import MomentSums, delta_standard_errors, statistics_from_sums
from ..stats.verdicts import sequence_decided
from .base import Design, MethodSettings, Propagated, Runner, RunPlan, StreamingMethod


#: Where ``fold`` keeps the merged sums in its accumulator (the rest: quantile values by output).
_SUMS = ("sums", "")

# Keep inverse CDFs finite: a unit-cube coordinate of exactly 0 or 1 maps to +-inf for a normal.
U_EPS = 2.0**-53


#: Rows per chunk of ``monte_carlo`` by default: what a vectorised model is called with (and
#: the least ``mfmc`` calls it with, so that both pay the same per run).
CHUNK_ROWS = 8192


class PrecisionTarget(StrictModel):
    """``stop_when: {target_rel_se, statistic, output}``: stop once the statistic of a scalar
    output is known to this relative standard error (delta method, :func:`relative_se`)."""

    target_rel_se: float = Field(gt=0.0, lt=1.0, description="the relative standard error "
                                                             "to reach")
    statistic: Literal["mean", "std", "skewness", "kurtosis"] = "std"
    output: str
    #: a multi-component output: one of its components (None: every component must reach it)
    component: int | str | None = None

    def describe(self) -> str:
        """E.g. ``"rel. SE of std(zem) <= 0.01"`` (stored in the diagnostics)."""
        comp = f"[{self.component}]" if self.component is not None else ""
        return f"rel. SE of {self.statistic}({self.output}{comp}) <= {self.target_rel_se:g}"


def _stop_kind(v: Any) -> str:
    return "PrecisionTarget" if isinstance(v, (dict, PrecisionTarget)) else "decided"


#: A mapping is a precision target (its errors name its keys), anything else the word.
StopWhen = Annotated[Union[Annotated[Literal["decided"], Tag("decided")],
                           Annotated[PrecisionTarget, Tag("PrecisionTarget")]],
                     Discriminator(_stop_kind)]


class MonteCarloSettings(MethodSettings):
    """Settings of ``monte_carlo``."""

    n_samples: int = Field(ge=1, le=100_000_000, description="number of model runs")
    sampling: Literal["random", "lhs", "sobol"] = Field(
        default="random", description="design of the samples within each chunk")
    chunk_size: int = Field(default=CHUNK_ROWS, ge=1, le=10_000_000,
                            description="samples per random stream (changes the numbers; fixed "
                                        "so that the worker count does not)")
    intervals: Literal["tail", "delta", "bootstrap", "studentized"] = Field(
        default="tail", description="how the 95% intervals of mean, std, skewness and kurtosis "
                                    "are computed: tail-aware, delta method, Poisson bootstrap "
                                    "or studentised Poisson bootstrap (docs/statistics.md)")
    bootstrap: int = Field(default=200, ge=0, le=100_000,
                           description="bootstrap resamples of intervals: bootstrap (0: no "
                                       "intervals, whatever intervals says)")
    bootstrap_times: Literal["report", "all"] = Field(
        default="report", description="where a time series gets intervals: at the report "
                                      "times and the final step, or at every step")
    sensitivity: Literal["auto", "on", "off"] = Field(
        default="auto", description="given-data first-order Sobol' indices with 95% intervals "
                                    "(the error budget): auto when the inputs are at most 50 "
                                    "and the runs from 500 to 1e6")
    stop_when: StopWhen | None = Field(
        default=None, description="decided: stop after the first chunk at which every "
                                  "requirement of the config is decided by its confidence "
                                  "sequence; or a precision target {target_rel_se, statistic, "
                                  "output}: stop after the first chunk at which the statistic's "
                                  "relative standard error is at most the target (n_samples is "
                                  "the cap; docs/requirements.md)")


def method_seed(seed: int, label: str, *keys: int) -> np.random.SeedSequence:
    """The SeedSequence of one method entry (of its stream ``keys`` when given): the run's seed
    and a stable hash of the label, so that adding or reordering methods in a config does not
    change another method's numbers."""
    return np.random.SeedSequence([seed, zlib.crc32(label.encode()), *keys])


def stream_seed(seed: int, label: str, k: int) -> int:
    """An integer seed of the method's stream ``k`` (``k >= 1``: apart from the design's)."""
    return int(method_seed(seed, label, k).generate_state(1)[0])


def chunk_seed(seed: np.random.SeedSequence, i: int) -> np.random.SeedSequence:
    """Child ``i`` of ``seed``, as ``seed.spawn`` would give it, without spawning the others."""
    return np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, i),
                                  pool_size=seed.pool_size)


def unit_chunk(d: int, n: int, sampling: str, chunk_size: int, seed: np.random.SeedSequence,
               i: int) -> np.ndarray:
    """Chunk ``i`` of the points ``(n, d)`` in the open unit cube: rows
    ``[i chunk_size, min(n, (i + 1) chunk_size))``, drawn from child ``i`` of ``seed``."""
    m = min(chunk_size, n - i * chunk_size)
    rng = np.random.default_rng(chunk_seed(seed, i))
    if sampling == "random":
        u = rng.random((m, d))
    elif sampling == "lhs":
        from scipy.stats import qmc  # slow to import: only LHS and Sobol' need it

        u = qmc.LatinHypercube(d=d, seed=rng).random(m)
    else:
        from scipy.stats import qmc

        # Draw the next power of two and keep the first m: a prefix of a scrambled Sobol'
        # sequence, which avoids scipy's balance warning for non-powers of two.
        p = int(np.ceil(np.log2(max(m, 1))))
        u = qmc.Sobol(d=d, scramble=True, seed=rng).random_base2(p)[:m]
    return np.clip(u, U_EPS, 1 - U_EPS)


def unit_samples(d: int, n: int, sampling: str, chunk_size: int,
                 seed: np.random.SeedSequence) -> np.ndarray:
    """Points ``(n, d)`` in the open unit cube, drawn chunk by chunk from children of ``seed``
    (all chunks of :func:`unit_chunk` joined)."""
    parts = [unit_chunk(d, n, sampling, chunk_size, seed, i)
             for i in range(-(-n // chunk_size))]
    return np.concatenate(parts) if parts else np.empty((0, d))


class DesignChunks:
    """``make(i)``: chunk ``i`` of a Monte Carlo design in SI units, where and when it is
    evaluated (never held whole); picklable, so a pool worker can make its own chunk."""

    def __init__(self, space: InputSpace, n: int, sampling: str, chunk_size: int,
                 seed: np.random.SeedSequence) -> None:
        self.space, self.n, self.sampling, self.chunk_size, self.seed = (
            space, n, sampling, chunk_size, seed)

    def __call__(self, i: int) -> np.ndarray:
        d, n, c = self.space.dim, self.n, self.chunk_size
        if not d:
            return np.empty((min(c, n - i * c), 0))
        return self.space.from_unit(unit_chunk(d, n, self.sampling, c, self.seed, i))


class MonteCarlo(StreamingMethod):
    """Monte Carlo sampling with streaming sample-moment statistics and Poisson-bootstrap
    intervals."""

    name = "monte_carlo"
    summary = "Monte Carlo: random, Latin hypercube or scrambled Sobol' samples; sample moments"
    Settings = MonteCarloSettings
    settings: MonteCarloSettings
    example_settings = {"n_samples": 4096, "chunk_size": 1024, "bootstrap": 100}
    #: A data file's rows are a Monte Carlo sample when they are iid draws from the inputs
    #: (the config checks each column's fit and warns): the statistics are the same sums.
    own_design = ""

    def check(self, index: int) -> None:
        """ConfigError for ``stop_when: decided`` without requirements to decide."""
        target = self.settings.stop_when
        if target == "decided" and not self.context.requirements:
            where = f"methods[{index}].stop_when"
            raise ConfigError(f"{where}: 'decided' stops when every requirement is decided, "
                              f"and the config lists no requirements; add requirements: or "
                              f"remove stop_when", field=where)

    def propagate(self, space: InputSpace, design: Design, runner: Runner) -> Propagated:
        """As every streaming method's; with ``stop_when: decided``, the stage ends after the
        first chunk at which every requirement is decided, and the estimate is of the runs
        folded until then (the first chunks of the design: the same rows and numbers)."""
        if self.settings.stop_when is None:
            return super().propagate(space, design, runner)
        latest: dict[str, Any] = {}

        def fold(acc: dict | None, summary: dict[str, np.ndarray]) -> dict:
            latest["acc"] = self.fold(acc, summary)  # (what the stop rule reads)
            return latest["acc"]

        out, acc = runner.run(design.x, 0, self.chunks(design.n_runs, runner.batch_size),
                              reduce=(self.reducer(space, design), fold),
                              stop=lambda runs: self._stop(runs, latest.get("acc")))
        short = design
        if out.n < design.n_runs:
            x = design.x
            rows = x.prefix(out.n) if isinstance(x, GeneratedRows) else x[:out.n]
            # the reducer ran with the cap's choice of sensitivity: the estimate keeps it
            short = Design(x=rows, data={**design.data, "sensitivity": self.sensitivity_for(
                space, design.n_runs)})
        return self.estimated(lambda: self.estimate_reduced(space, short, out, acc),
                              short.x, out, runner)

    def check_model(self, model: Any, index: int) -> None:
        """ConfigError for a precision target on an output the runs do not report as a
        scalar, or on a component it does not have."""
        target = self.settings.stop_when
        if not isinstance(target, PrecisionTarget):
            return
        where = f"methods[{index}].stop_when"
        known = self.context.outputs
        scalars = [o for o in known if model.output_info(o).kind == "scalar"]
        if target.output not in scalars:
            what = "a time series" if target.output in known else "not an output of the run"
            raise ConfigError(f"{where}.output: {target.output!r} is {what}; a precision "
                              f"target is on a scalar output; allowed: "
                              f"{', '.join(scalars) or 'none'}", field=f"{where}.output")
        if target.component is not None:
            try:
                component_index(self._target_event(target),
                                tuple(self.context.components[target.output]))
            except ValueError as exc:
                raise ConfigError(f"{where}.component: {exc}", field=f"{where}.component") \
                    from None

    @staticmethod
    def _target_event(target: PrecisionTarget) -> EventSpec:
        """An event on the target's output and component (to pick its column as events do)."""
        return EventSpec(name="target", output=target.output, component=target.component,
                         below=0.0)

    def _stop(self, out: ModelOutput, acc: dict | None) -> bool:
        """Whether the run may stop after the runs ``out`` (and their sums ``acc``) folded so
        far (``stop_when``)."""
        target = self.settings.stop_when
        if not isinstance(target, PrecisionTarget):
            return self._decided(out, acc)
        y = out.scalars[target.output][~out.failed]
        if target.component is not None:
            comps = tuple(self.context.components[target.output])
            col = component_index(self._target_event(target), comps)
            y = y[:, col:col + 1]
        return bool(np.all(relative_se(y, target.statistic) <= target.target_rel_se))

    def _decided(self, out: ModelOutput, acc: dict | None) -> bool:
        """Whether the confidence sequence of every requirement excludes its target over the
        runs ``out`` (and their sums ``acc``) folded so far."""
        reqs = self.context.requirements
        counts = count_events([r.event() for r in reqs if r.time is None], out.scalars,
                              ~out.failed, dict(self.context.components))
        counts.update(self._timed_events(acc))
        return all(sequence_decided(counts[r.name].n_in, counts[r.name].n_used, r.confidence,
                                    r.target) for r in reqs)

    def _timed_events(self, acc: dict | None) -> dict[str, EventEstimate]:
        """The requirements at a time (``time:``) counted over the per-run values of their
        series at its nearest step, as the reducer kept them (``t::`` entries)."""
        out = {}
        for r in self.context.requirements:
            if r.time is None:
                continue
            comps = tuple(self.context.components[r.output])
            lanes = (acc or {}).get(("t", r.at)) or [np.empty((len(comps), 0))]
            y = np.concatenate(lanes, axis=1).T
            out.update(count_events([r.event()], {r.at: y}, np.ones(y.shape[0], dtype=bool),
                                    {r.at: comps}))
        return out

    def design(self, space: InputSpace, seed: int) -> Design:
        s = self.settings
        boot_seed = stream_seed(seed, self.label, 1)
        if self.context.rows is not None:
            return Design(x=self.context.rows.x, data={"boot_seed": boot_seed})
        ss = method_seed(seed, self.label)
        x = GeneratedRows(s.n_samples, space.dim, s.chunk_size,
                          DesignChunks(space, s.n_samples, s.sampling, s.chunk_size, ss),
                          portable=True)
        return Design(x=x, data={"boot_seed": boot_seed})

    def plan(self, space: InputSpace) -> RunPlan:
        s = self.settings
        return RunPlan(runs=s.n_samples, chunk=min(s.chunk_size, s.n_samples),
                       exact=s.stop_when is None)  # (n_samples is the cap)

    def chunk_bounds(self, n_runs: int) -> list[tuple[int, int]]:
        """The random-stream chunks of ``chunk_size``: the split is part of the numbers."""
        c = self.settings.chunk_size
        return [(s, min(n_runs, s + c)) for s in range(0, max(n_runs, 1), c)]

    def reducer(self, space: InputSpace, design: Design) -> MonteCarloReducer:
        return MonteCarloReducer(self.settings.bootstrap, int(design.data.get("boot_seed", 0)),
                                 self.context.report_times, self.settings.bootstrap_times,
                                 quantiles=self.context.quantile_levels is not None,
                                 n_total=design.n_runs, intervals=self.interval_kind,
                                 sensitivity=self.sensitivity_for(space, design.n_runs),
                                 at_times=tuple((r.output, r.time)
                                                for r in self.context.requirements
                                                if r.time is not None))

    def sensitivity_for(self, space: InputSpace, n_runs: int) -> bool:
        return wanted(self.settings.sensitivity, space.dim, n_runs)

    @property
    def interval_kind(self) -> str:
        """``delta``, ``bootstrap`` or ``none`` (``bootstrap: 0`` switches intervals off)."""
        return self.settings.intervals if self.settings.bootstrap > 0 else "none"

    def fold(self, acc: dict | None, summary: dict[str, np.ndarray]) -> dict:
        """Merge a chunk: moment sums by :class:`FoldedSums`, per-run values by concatenation."""
        acc = {_SUMS: FoldedSums()} if acc is None else acc
        acc[_SUMS].add(split_summary(summary))
        for key, v in summary.items():
            if key.startswith(PER_RUN_KINDS):
                kind, _, name = key.split(":", 2)
                append_columns(acc.setdefault((kind, name), []), v)
        return acc

    def estimate_reduced(self, space: InputSpace, design: Design, runs: ModelOutput,
                         acc: dict[tuple[str, str], Any] | None) -> Estimate:
        from ..pce.outputs import failure_summary  # (pool workers import this module)

        t0 = time.perf_counter()
        if acc is not None and _SUMS in acc:
            acc = {**acc[_SUMS].groups(), **{k: v for k, v in acc.items() if k != _SUMS}}
        n_failed = int(runs.failed.sum())
        tally = failure_summary(runs)
        if not acc:
            from ..core.failures import render_reasons

            raise MethodError(f"{self.label}: every one of the {runs.n} runs failed, no "
                              f"statistics ({tally})\n\nFailed runs\n"
                              + render_reasons(self.label, runs.n, runs.reasons[runs.failed]))
        stats = {}
        jobs: dict[str, tuple[int, Callable[[], tuple[np.ndarray, np.ndarray]]]] = {}
        levels = self.context.quantile_levels
        for (kind, name), sums in acc.items():
            if kind != "m" or name == "":
                continue
            is_series = sums.mean.ndim == 2
            idx = ci_index(runs.time, self.context.report_times, self.settings.bootstrap_times) \
                if is_series else None
            stats[name] = statistics_from_sums(sums, acc.get(("b", name)), idx,
                                               delta=acc.get(("h", name)),
                                               tail=self.settings.intervals == "tail",
                                               uncertain=space.dim > 0)
            if levels is not None:
                if is_series:  # lane-major values, chunks joined where adjacent
                    lanes = acc.get(("q", name)) or []
                    k = sums.mean.shape[-1]
                    steps = lanes[0].shape[0] // k if lanes else sums.mean.shape[0]
                    jobs[name] = (sum(c.size for c in lanes), partial(
                        lane_quantiles, lanes or [np.empty((steps * k, 0))], (steps, k),
                        levels))
                else:
                    y = runs.scalars[name]
                    jobs[name] = (y.size, partial(_scalar_quantiles, y, ~runs.failed, levels))
        for name, (q, ci) in _run_jobs(jobs).items():
            _put_quantiles(stats[name], q, ci, levels or (), runs.time, self.context.report_times)
        sobol_seconds = 0.0
        if design.data.get("sensitivity", self.sensitivity_for(space, design.n_runs)):
            t_sobol = time.thread_time()  # (this thread: the estimator runs on it alone)
            lanes = {name: acc.get(("q", name)) or acc.get(("s", name)) or []
                     for name in stats}
            add_indices(stats, space, design.x, runs, lanes, self.context.report_times,
                        self.context.groups)
            sobol_seconds = time.thread_time() - t_sobol
        events = count_events(list(self.context.events), runs.scalars, ~runs.failed,
                              dict(self.context.components)) \
            if self.context.events else {}
        events.update(self._timed_events(acc))
        names = scalar_names(runs.scalars)  # (stacking them would copy every value)
        n_ok = runs.n - n_failed
        joint = acc.get(("j", "")) if names and n_ok else None
        diagnostics = {
            "n_runs": runs.n,
            "n_failed": n_failed,
            "failure_reasons": tally,
            "sampling": "data" if self.context.rows is not None else self.settings.sampling,
            "bootstrap": self.settings.bootstrap,
            "bootstrap_kind": "poisson",
            "intervals": self.interval_kind,
            "fit_seconds": time.perf_counter() - t0,
            "sensitivity_cpu_seconds": sobol_seconds,
        }
        if self.settings.stop_when is not None:
            target = self.settings.stop_when
            diagnostics.update(stop_when=target if isinstance(target, str) else
                               target.describe(),
                               n_samples_cap=self.settings.n_samples)
        return Estimate(
            method=self.name, label=self.label, stats=stats, diagnostics=diagnostics,
            scalar_index=names,
            scalar_mean=None if joint is None else joint.mean,
            scalar_cov=None if joint is None or joint.cm is None else np.asarray(joint.cm) / n_ok,
            events=events,
        )


#: Threads computing different outputs' quantiles at once (None: one per CPU); the selection
#: is exact, so the numbers do not depend on it (``docs/methods.md#inside-monte-carlo``).
QUANTILE_THREADS: int | None = None


def _scalar_quantiles(y: np.ndarray, good: np.ndarray, levels: tuple[float, ...]
                      ) -> tuple[np.ndarray, np.ndarray]:
    return order_statistic_quantiles(y[good], levels)


def _run_jobs(jobs: dict[str, tuple[int, Callable[[], Any]]]) -> dict[str, Any]:
    """Each ``(size, call)`` job's result by name, the largest started first."""
    threads = min(QUANTILE_THREADS or os.cpu_count() or 1, len(jobs))
    if threads <= 1:
        return {name: call() for name, (_, call) in jobs.items()}
    from concurrent.futures import ThreadPoolExecutor

    order = sorted(jobs, key=lambda name: -jobs[name][0])
    with ThreadPoolExecutor(threads, thread_name_prefix="quantiles") as pool:
        futures = {name: pool.submit(jobs[name][1]) for name in order}
        return {name: futures[name].result() for name in jobs}


def _put_quantiles(st: OutputStats, q: np.ndarray, ci: np.ndarray, levels: tuple[float, ...],
                   time_grid: np.ndarray, report_times: tuple[float, ...] | None) -> None:
    """Quantiles ``q (levels, ...)`` and intervals ``ci (2, levels, ...)`` of a scalar, or of
    a series at every step or at the quantile steps, into ``st``, NaN at the steps not kept."""
    if q.ndim == 3 and q.shape[1] != time_grid.size:
        idx = ci_index(time_grid, report_times, "report")
        q, ci = at_steps(q, idx, time_grid.size, 1), at_steps(ci, idx, time_grid.size, 2)
    st.quantile_levels, st.quantiles, st.ci_quantiles = tuple(levels), q, ci


def at_steps(values: np.ndarray, steps: np.ndarray | None, n_steps: int, axis: int = 0
             ) -> np.ndarray:
    """``values`` whose axis ``axis`` holds the time steps ``steps``, spread over ``n_steps``
    steps with NaN at the others (``steps`` None: ``values`` as they are)."""
    if steps is None:
        return values
    out = np.full(values.shape[:axis] + (n_steps,) + values.shape[axis + 1:], np.nan)
    out[(slice(None),) * axis + (steps,)] = values
    return out


# -------------------- the chunk reduction, run where the chunk ran (in pool workers)

# CDF of Poisson(1) at k = 0..19 (the mass beyond 19 is 1.9e-19, below double resolution).
_POISSON1_CDF = np.cumsum([math.exp(-1.0) / math.factorial(k) for k in range(20)])


def poisson1(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Poisson(1) counts as floats, by inverting the CDF of uniforms (a few times faster than
    ``rng.poisson``)."""
    u = rng.random(shape)
    w = np.zeros(shape, dtype=np.uint8)
    top = u.max(initial=0.0)
    for c in _POISSON1_CDF:
        if c > top:
            break
        w += u >= c
    return w.astype(float)


def relative_se(y: np.ndarray, statistic: str) -> np.ndarray:
    """The delta-method standard error of a statistic of the runs ``y (n, k)`` over its
    magnitude, by column (the SE the ``delta`` and ``tail`` intervals stand on; inf for fewer
    than two runs or a statistic of zero, so that no target is met)."""
    n = y.shape[0]
    if n < 2:
        return np.full(y.shape[1:], np.inf)
    sums = MomentSums.of(y, comoments=False, high=True)
    mus = tuple(m / n for m in sums.central_sums())
    est = statistics_from_sums(sums, uncertain=False)
    se = delta_standard_errors(mus, n)[statistic]
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = se / np.abs(getattr(est, statistic))
    return np.where(np.isfinite(rel), rel, np.inf)


def nearest_step(time_grid: np.ndarray, t: float) -> int:
    """The step of ``time_grid`` nearest ``t`` (the earlier of two as near): where a report
    time and a requirement's ``time`` are read."""
    return int(np.argmin(np.abs(time_grid - t)))


def ci_index(time_grid: np.ndarray, report_times: tuple[float, ...] | None,
             bootstrap_times: str) -> np.ndarray | None:
    """Time indices where a series gets bootstrap intervals: the steps nearest the report
    times and the last step (``None``: every step)."""
    if bootstrap_times == "all" or time_grid.size == 0:
        return None
    idx = [nearest_step(time_grid, t) for t in (report_times or ())]
    idx.append(time_grid.size - 1)
    return np.unique(idx)


#: Quantiles of a series are exact at every step while the kept values (runs x steps x
#: components over all series outputs) stay below this many floats (256 MiB); above it, at the
#: report times and the last step only. Fixed by the config (sample count, grid, outputs), so
#: the choice never depends on the chunking or the workers.
QUANTILE_ALL_FLOATS = 2**25


def quantile_index(time_grid: np.ndarray, report_times: tuple[float, ...] | None,
                   n_total: int, width: int) -> np.ndarray | None:
    """Time indices where series keep their values for quantiles (``None``: every step);
    ``width``: the components of all series outputs together."""
    if n_total * time_grid.size * max(width, 1) <= QUANTILE_ALL_FLOATS:
        return None
    return ci_index(time_grid, report_times, "report")


@dataclass(frozen=True)
class MonteCarloReducer:
    """Reduces one chunk of Monte Carlo runs to mergeable sums (runs in the worker).

    Summary keys: ``"m:<field>:<output>"`` (sums with comoments), ``"h:..."`` (sums with the
    orders 5-16 of the interval columns), ``"b:..."`` (Poisson-bootstrap sums of the interval
    columns), ``"j:<field>:"`` (the scalars stacked, for their joint covariance), and per-run
    values in chunk order: ``"q::<output>"`` (a series at the quantile steps,
    :func:`quantile_index`) or, for the Sobol' indices without quantiles, ``"s::<output>"``
    (at the report steps), ``"t::<output>@<time>"`` (a series at a requirement's time). The
    layout: ``docs/methods.md#inside-monte-carlo``.
    """

    bootstrap: int
    boot_seed: int
    report_times: tuple[float, ...] | None
    bootstrap_times: str
    quantiles: bool = False
    n_total: int = 0
    intervals: str = "tail"
    sensitivity: bool = False
    #: ``(output, time)`` of the requirements at a time: the series' values at the nearest step
    at_times: tuple[tuple[str, float], ...] = ()

    @staticmethod
    def per_run(key: str) -> bool:
        """Whether a summary entry holds per-run values (lane-major, a column per good run),
        which a process pool's workers write in place."""
        return key.startswith(PER_RUN_KINDS)

    def __call__(self, out: ModelOutput, index: int) -> dict[str, np.ndarray]:
        ok = ~out.failed
        summary: dict[str, np.ndarray] = {}
        if not ok.any():
            # an empty summary merges as the identity; an all-failed chunk may have no grid
            return summary
        # a full slice is a view; a boolean mask would copy every series of the chunk
        keep: slice | np.ndarray = slice(None) if ok.all() else ok
        idx = ci_index(out.time, self.report_times, self.bootstrap_times)
        closed_form = self.intervals in ("delta", "tail")
        blocks, spans = [], []
        for name, y in [*out.series.items(), *out.scalars.items()]:
            y_ok = y[keep]
            _put(summary, "m", name, MomentSums.of(y_ok))
            cols = y_ok[:, idx] if (y.ndim == 3 and idx is not None) else y_ok
            if closed_form:
                _put(summary, "h", name, MomentSums.of(cols, comoments=False, high=True))
                continue
            # explicit width: reshape(0, -1) is ambiguous for a chunk in which every run failed
            blocks.append(cols.reshape(cols.shape[0], int(np.prod(cols.shape[1:]))))
            spans.append((name, blocks[-1].shape[1]))
        student = self.intervals == "studentized"
        if self.bootstrap > 0 and blocks:
            # weights drawn for every run, failed ones then dropped: a run's weights do not
            # depend on which others failed
            w = poisson1(np.random.default_rng([self.boot_seed, index]),
                         (self.bootstrap, out.n))[:, ok]
            # every interval column side by side: a few large products, not one per output
            boot = MomentSums.weighted(np.concatenate(blocks, axis=1), w, high=student)
            c0 = 0
            for name, c in spans:
                sl = slice(c0, c0 + c)
                hi = boot.high[:, :, sl] if boot.high is not None else None
                _put(summary, "b", name, MomentSums(boot.n, boot.mean[:, sl], boot.m2[:, sl],
                                                    boot.m3[:, sl], boot.m4[:, sl], None, hi))
                c0 += c
        if student:
            # the full sample's own standard errors, which the bootstrap-t pivot rescales
            for (name, _), cols in zip(spans, blocks):
                _put(summary, "h", name, MomentSums.of(cols, comoments=False, high=True))
        self._scalars_and_quantiles(summary, out, ok, keep)
        for name, t in self.at_times:
            y = out.series[name][keep][:, nearest_step(out.time, t)]
            summary[f"t::{name}@{t:g}"] = np.ascontiguousarray(y.T)
        return summary

    def _scalars_and_quantiles(self, summary: dict[str, np.ndarray], out: ModelOutput,
                               ok: np.ndarray, keep: slice | np.ndarray) -> None:
        """The joint sums of the stacked scalars and the series values kept per run."""
        stacked = stack_scalars(out.scalars, ok)
        _put(summary, "j", "", MomentSums.of(stacked))
        if not out.series or not (self.quantiles or self.sensitivity):
            return
        if self.quantiles:
            width = sum(y.shape[2] for y in out.series.values())
            kind, steps = "q", quantile_index(out.time, self.report_times, self.n_total, width)
        else:
            kind, steps = "s", ci_index(out.time, self.report_times, "report")
        for name, y in out.series.items():
            # lane-major copies: the driver selects order statistics along rows, and the
            # chunk's buffer is released once the summary leaves the worker
            kept = y[keep] if steps is None else y[keep][:, steps]
            summary[f"{kind}::{name}"] = np.ascontiguousarray(kept.reshape(kept.shape[0], -1).T)


#: Prefixes of the summary entries that hold per-run values (quantiles', sensitivity's, the
#: requirements at a time').
PER_RUN_KINDS = ("q::", "s::", "t::")


def _put(summary: dict[str, np.ndarray], kind: str, name: str, sums: MomentSums) -> None:
    for f, v in sums.arrays().items():
        summary[f"{kind}:{f}:{name}"] = v


def split_summary(summary: dict[str, np.ndarray]) -> dict[tuple[str, str], MomentSums]:
    """The moment sums of a chunk summary by ``(kind, output)`` (per-run values left out)."""
    groups: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    for key, v in summary.items():
        if key.startswith(PER_RUN_KINDS):
            continue
        kind, f, name = key.split(":", 2)
        groups.setdefault((kind, name), {})[f] = v
    return {k: MomentSums.from_arrays(g) for k, g in groups.items()}


def append_columns(lanes: list[np.ndarray], v: np.ndarray) -> None:
    """Append the lane-major chunk ``v (L, n)`` to ``lanes``, joined with the last one when
    ``v`` continues it in one array (chunks written in place by pool workers): the quantile
    selection then makes a few long passes instead of one per chunk."""
    if lanes:
        a, root = lanes[-1], lanes[-1].base
        if (isinstance(root, np.ndarray) and root is v.base and root.ndim == a.ndim == v.ndim
                == 2 and root.flags.c_contiguous and a.shape[0] == v.shape[0] == root.shape[0]
                and a.strides == v.strides == root.strides):
            c0 = (a.ctypes.data - root.ctypes.data) // root.itemsize
            c1 = (v.ctypes.data - root.ctypes.data) // root.itemsize
            if c1 == c0 + a.shape[1] and c1 + v.shape[1] <= root.shape[1]:
                lanes[-1] = root[:, c0:c1 + v.shape[1]]
                return
    lanes.append(v)


def scalar_names(scalars: dict[str, np.ndarray]) -> list[ScalarIndex]:
    """The columns of the stacked scalar vector (without stacking anything)."""
    return ScalarIndex.stacked((name, y.shape[1]) for name, y in scalars.items())


def stack_scalars(scalars: dict[str, np.ndarray], ok: np.ndarray) -> np.ndarray:
    """All scalar outputs of the good runs side by side ``(n_ok, m)``, as :func:`scalar_names`."""
    cols = [y[ok] for y in scalars.values()]
    if not cols:
        return np.empty((int(ok.sum()), 0))
    return np.concatenate(cols, axis=1)


# -------------------- the driver's merge of the chunk sums, all outputs at once

Key = tuple[str, str]


@dataclass
class _Pack:
    """Groups with the same fields (comoments or not, orders 5-8 or not), merged as one."""

    keys: list[Key]
    shapes: list[tuple[int, ...]]
    sums: MomentSums  # flat fields, ``high`` (orders, total), comoments flat
    outer: tuple[np.ndarray, np.ndarray] | None  # a comoment is delta[I] * delta[J]

    @classmethod
    def of(cls, groups: list[tuple[Key, MomentSums]], accumulates: bool = True) -> _Pack:
        """The groups joined; ``accumulates``: this pack takes the later chunks (it keeps the
        comoments' gather index, made once)."""
        keys = [k for k, _ in groups]
        shapes = [s.mean.shape for _, s in groups]
        first = groups[0][1]

        def joined(field: str) -> np.ndarray:
            return np.concatenate([getattr(s, field).ravel() for _, s in groups])

        high = None
        if first.high is not None:
            rows = len(first.high)
            high = np.concatenate([np.asarray(s.high).reshape(rows, -1) for _, s in groups],
                                  axis=1)
        cm = joined("cm") if first.cm is not None else None
        flat = MomentSums(first.n, joined("mean"), joined("m2"), joined("m3"), joined("m4"),
                          cm, high)
        outer = _outer_index(shapes) if cm is not None and accumulates else None
        return cls(keys, shapes, flat, outer)

    def matches(self, groups: list[tuple[Key, MomentSums]]) -> bool:
        return [k for k, _ in groups] == self.keys and \
            [s.mean.shape for _, s in groups] == self.shapes

    def merge(self, other: _Pack) -> None:
        """Merge ``other`` (the next chunk's groups, same layout) into this one: exactly
        :meth:`MomentSums.merge` of each group."""
        gather = None
        if self.outer is not None:
            i, j = self.outer

            def gather(delta: np.ndarray) -> np.ndarray:
                return delta[i] * delta[j]
        self.sums = self.sums.merge(other.sums, outer=gather)

    def groups(self) -> dict[Key, MomentSums]:
        out, at, cm_at = {}, 0, 0
        s = self.sums
        for key, shape in zip(self.keys, self.shapes, strict=True):
            size = int(np.prod(shape))
            sl = slice(at, at + size)
            cm = None
            if s.cm is not None:
                k = shape[-1] if shape else 1
                cm = s.cm[cm_at:cm_at + size * k].reshape(shape + (k,))
                cm_at += size * k
            out[key] = MomentSums(
                s.n, s.mean[sl].reshape(shape), s.m2[sl].reshape(shape),
                s.m3[sl].reshape(shape), s.m4[sl].reshape(shape), cm,
                s.high[:, sl].reshape((len(s.high),) + shape) if s.high is not None else None)
            at += size
        return out


def _outer_index(shapes: list[tuple[int, ...]]) -> tuple[np.ndarray, np.ndarray]:
    """Flat indices ``I, J`` into the groups' joined means such that the joined comoments'
    element is ``delta[I] * delta[J]`` (each group's ``(..., k, k)`` outer product)."""
    rows, cols, at = [], [], 0
    for shape in shapes:
        k = shape[-1] if shape else 1
        lead = int(np.prod(shape[:-1])) if shape else 1
        base = at + np.arange(lead)[:, None, None] * k
        rows.append(np.broadcast_to(base + np.arange(k)[None, :, None], (lead, k, k)).ravel())
        cols.append(np.broadcast_to(base + np.arange(k)[None, None, :], (lead, k, k)).ravel())
        at += lead * k
    return np.concatenate(rows), np.concatenate(cols)


class FoldedSums:
    """The merged sums of the chunks so far, groups of the same fields merged as one.

    ``add`` merges a chunk's groups (in chunk order); ``groups`` gives every group's
    :class:`MomentSums` in first-seen order, equal bit for bit to merging each group on its own
    (``docs/methods.md#inside-monte-carlo``).
    """

    def __init__(self) -> None:
        self._packs: dict[tuple[bool, bool], _Pack] = {}
        self._apart: dict[Key, MomentSums] = {}
        self._unpacked: set[tuple[bool, bool]] = set()
        self._order: dict[Key, None] = {}

    def add(self, groups: dict[Key, MomentSums]) -> None:
        kinds: dict[tuple[bool, bool], list[tuple[Key, MomentSums]]] = {}
        for key, s in groups.items():
            self._order.setdefault(key)
            if np.ndim(s.n) == 0:
                kinds.setdefault((s.cm is not None, s.high is not None), []).append((key, s))
            else:  # per-resample counts
                self._merge_apart(key, s)
        for kind, members in kinds.items():
            pack = self._packs.get(kind)
            if pack is not None and not pack.matches(members):
                # a chunk laid out otherwise: group by group from now on
                self._apart.update(self._packs.pop(kind).groups())
                self._unpacked.add(kind)
                pack = None
            if kind in self._unpacked:
                for key, s in members:
                    self._merge_apart(key, s)
            elif pack is None:
                self._packs[kind] = _Pack.of(members)
            else:
                pack.merge(_Pack.of(members, accumulates=False))

    def _merge_apart(self, key: Key, s: MomentSums) -> None:
        self._apart[key] = self._apart[key].merge(s) if key in self._apart else s

    def groups(self) -> dict[Key, MomentSums]:
        out = dict(self._apart)
        for pack in self._packs.values():
            out.update(pack.groups())
        return {k: out[k] for k in self._order}


# -------------------- the error budget: given-data first-order Sobol' indices
# from the good runs' inputs (made again from the design) and the per-run values the chunks
# kept, joined in chunk order (docs/methods.md#inside-monte-carlo, docs/error-budget.md)

#: ``sensitivity: auto`` gives indices up to this many inputs ...
AUTO_MAX_INPUTS = 50
#: ... from this many runs ...
AUTO_MIN_RUNS = 500
#: ... up to this many (``sensitivity: on`` beyond; the memory budget counts what it keeps).
AUTO_MAX_RUNS = 1_000_000


def wanted(setting: str, n_inputs: int, n_runs: int) -> bool:
    """Whether a run with this ``sensitivity`` setting, inputs and runs gets indices."""
    if setting == "off" or n_inputs == 0:
        return False
    if setting == "on":
        return True
    return n_inputs <= AUTO_MAX_INPUTS and AUTO_MIN_RUNS <= n_runs <= AUTO_MAX_RUNS


def good_inputs(x: np.ndarray | GeneratedRows, good: np.ndarray) -> np.ndarray:
    """The inputs ``(n_good, d)`` of the runs that did not fail, made chunk by chunk."""
    if not isinstance(x, GeneratedRows):
        return np.asarray(x, dtype=float)[good]
    out = np.empty((int(good.sum()), x.d))
    at = 0
    for start, rows in x.chunks():
        keep = good[start:start + rows.shape[0]]
        m = int(keep.sum())
        out[at:at + m] = rows[keep]
        at += m
    return out


def add_indices(stats: dict[str, OutputStats], space: InputSpace, x: np.ndarray | GeneratedRows,
                runs: ModelOutput, lanes: dict[str, Sequence[np.ndarray]],
                report_times: tuple[float, ...] | None,
                groups: Sequence[tuple[str, tuple[int, ...]]] = ()) -> None:
    """Set the given-data ``sobol_first*`` (and ``sobol_group_*``) of every output in
    ``stats``, in place.

    ``x (n, d)``: every run's inputs; ``runs``: the failure mask, grid and scalars; ``lanes``:
    per series, its kept per-run values in chunk order, lane-major ``(L, n_c)``, at every step
    or at :func:`ci_index`'s; ``groups``: the inputs' groups (name, columns).
    """
    # (imported here: pool workers import this module)
    from ..stats.sobol_given_data import MIN_RUNS, first_order_indices, n_bins, rank_bins
    from ..stats.sobol_groups import group_indices

    good = ~runs.failed
    x_ok = good_inputs(x, good)
    d = space.dim
    steps = ci_index(runs.time, report_times, "report") if runs.time.size else None
    n = x_ok.shape[0]
    # the inputs sorted once for every output
    binned = rank_bins(x_ok) if n >= max(MIN_RUNS, 3 * n_bins(n)) else None
    for name, st in stats.items():
        if name in runs.scalars:
            rows, at = runs.scalars[name][good].T, None
        elif name in lanes and steps is not None and lanes[name]:
            k = st.mean.shape[-1]
            # the report steps of each chunk's values, then joined (quantiles may keep every
            # step, far more than the indices need)
            parts = [p if p.shape[0] == steps.size * k else
                     p.reshape(p.shape[0] // k, k, -1)[steps].reshape(steps.size * k, -1)
                     for p in lanes[name]]
            rows = parts[0] if len(parts) == 1 else np.concatenate(parts, axis=1)
            at = steps
        else:
            continue
        # a scalar's (k,) lanes, or a series' (steps, k) spread over its (T, k)
        shape = st.mean.shape if at is None else (at.size, st.mean.shape[-1])
        t_all = st.mean.shape[0]
        est = first_order_indices(x_ok, rows, binned=binned)
        st.sobol_first = at_steps(est.first.reshape(*shape, d), at, t_all)
        st.sobol_first_ci = at_steps(est.ci.reshape(2, *shape, d), at, t_all, 1)
        if groups:
            g = len(groups)
            gf, gci = group_indices(x_ok, rows, [cols for _, cols in groups])
            st.sobol_group_first = at_steps(gf.reshape(*shape, g), at, t_all)
            st.sobol_group_first_ci = at_steps(gci.reshape(2, *shape, g), at, t_all, 1)
        st.sobol_estimator = "given-data"
        st.sobol_groups = tuple(name for name, _ in groups) if groups else ()
