"""Monte Carlo propagation (uq-methods.md section 4.1).

Designs: pseudo-random (numpy ``Generator``), Latin hypercube and scrambled Sobol'
(``scipy.stats.qmc``), drawn on the unit cube and mapped to the inputs by their inverse CDFs.

Reproducibility: the samples are drawn in fixed-size chunks of ``chunk_size``, chunk ``i`` from
the child ``i`` of one ``SeedSequence`` derived from the run's seed and the method's label.
The numbers therefore depend on the seed, the label and ``chunk_size``, never on how many
workers evaluate the chunks. LHS and Sobol' are stratified within each chunk (a chunk is an
independent randomised replicate); keep ``chunk_size`` a power of two for Sobol'.

Statistics are the population estimators of uq-methods.md section 3 over the runs that did not
fail; failed runs are counted and their reasons tallied in the diagnostics.

Statistics are computed in streaming form, always (one code path, whatever the size or the
executor): each chunk is reduced where it ran to mergeable sums (count, mean, central moment
sums up to the 4th, comoments; :class:`~uqguide.stats.moments.MomentSums`) and the chunks are merged
in chunk order, so a 1e6-sample run never holds its time series, and the numbers do not depend
on which process reduced which chunk. Per-sample scalar outputs are kept (they are small).
The 95% intervals of mean, std, skewness and kurtosis are by default **tail-aware**
intervals (``intervals: tail``; :mod:`uqguide.stats.tail_intervals`): Hall's (1992)
skew-corrected interval of each statistic's influence function, and, where a handful of runs
carry the sum behind the statistic's variance (Kish's effective count below 10), a
**one-sided** interval, a stated floor such as "kurtosis >= L" (the upper end infinite): the
runs cannot bound it above. They need the central moments up to the 16th, which the chunks sum
like the others at the interval columns, so the intervals cost a few power sums instead of
``B`` weighted ones, and do not depend on the chunking or the workers. ``intervals: delta``
gives the symmetric delta-method intervals (:func:`~uqguide.stats.moments.delta_intervals`;
lognormal sigma 0.5, n = 1000: skewness / kurtosis coverage 81% / 65%, against 94% / 97% for
``tail``). ``intervals: bootstrap`` gives instead a **Poisson bootstrap** (Hanley &
MacGibbon 2006; Chamandy et al. 2012): resample ``b`` gives sample ``i`` of chunk ``c`` the
weight ``w_bi ~ Poisson(1)`` from the stream ``(boot_seed, c)``, so the weighted sums of a
resample are chunk-additive and merge like the plain ones. For large ``n`` it has the
multinomial bootstrap's distribution (a multinomial ``(n, 1/n)`` count is asymptotically
``Poisson(1)``); failed runs get weight 0. ``intervals: studentized`` keeps, per resample,
the central sums up to the 8th order too (they merge by Pébay's general-order formula) and
gives **bootstrap-t** intervals (:func:`~uqguide.stats.moments.studentized_intervals`): the
delta method and the percentile bootstrap both undercover the skewness and kurtosis of skewed
outputs (lognormal sigma 0.5, n = 1000: 81% / 65%), the studentised bootstrap less so (89% /
81%; ``benchmarks/interval_coverage.py``). Intervals of a series are computed at the report
times and the last step (``bootstrap_times: report``) or at every step (``all``; bootstrap:
``4 B T k`` multiply-adds per sample).

Quantiles (the config's ``quantiles``) are order statistics with distribution-free intervals
(:mod:`uqguide.stats.quantiles`): scalars from the kept per-sample values; series from each chunk's
values at every step (at the report times and the last step above
:data:`~uqguide.methods.mc_reduce.QUANTILE_ALL_FLOATS`), concatenated in chunk order. Events
(the config's ``events``) are counted over the good runs with Clopper-Pearson intervals.

The error budget (``sensitivity``): first-order Sobol' indices of every output on every input,
at the report times and the last step of a series and for each scalar, with 95% intervals,
from the same runs (:mod:`uqguide.methods.mc_sensitivity`); on by default up to 50 inputs from
500 to 1e6 runs.
"""

from __future__ import annotations

import logging
import os
import time
import zlib
from collections import Counter
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from typing import Any, Literal

import numpy as np
from pydantic import Field

from ..errors import MethodError
from ..core.inputs import InputSpace
from ..core.types import ModelOutput
from ..core.events import count_events
from ..stats.quantiles import lane_quantiles, order_statistic_quantiles
from ..stats.moments import OutputStats, statistics_from_sums
from .base import Design, Estimate, GeneratedRows, MethodSettings, RunPlan, StreamingMethod
from .mc_fold import FoldedSums
from .mc_reduce import (
    PER_RUN_KINDS, MonteCarloReducer, append_columns, ci_index, scalar_names, split_summary,
)
from .mc_sensitivity import add_indices, wanted

log = logging.getLogger(__name__)

#: Where ``fold`` keeps the merged sums in its accumulator (the rest: quantile values by output).
_SUMS = ("sums", "")

# Keep inverse CDFs finite: a unit-cube coordinate of exactly 0 or 1 maps to +-inf for a normal.
_U_EPS = 2.0**-53


class MonteCarloSettings(MethodSettings):
    """Settings of ``monte_carlo``.

    Attributes
    ----------
    n_samples : int
        Number of model runs.
    sampling : {"random", "lhs", "sobol"}
        Design of the samples within each chunk.
    chunk_size : int
        Samples per random stream (changes the numbers; fixed so that the worker count does not).
    intervals : {"tail", "delta", "bootstrap", "studentized"}
        How the 95% intervals of mean, std, skewness and kurtosis are computed: tail-aware
        (default; Hall's skew-corrected interval of the influence function, one-sided where a
        handful of runs carry the statistic's variance: :mod:`uqguide.stats.tail_intervals`;
        cheap, from the central sums up to the 16th), delta method (influence functions,
        symmetric; cheap), Poisson bootstrap (``bootstrap`` resamples,
        percentile intervals) or studentised Poisson bootstrap (bootstrap-t: each resample's
        statistic over its own delta-method standard error; the best coverage of the three on
        skewed outputs, for twice the bootstrap's sums: :func:`~uqguide.stats.moments.
        studentized_intervals`, ``benchmarks/interval_coverage.py``).
        Both treat the runs as independent: for ``lhs`` and ``sobol`` they are the error of a
        random design of the same size, an upper bound.
    bootstrap : int
        Bootstrap resamples of ``intervals: bootstrap`` (0: no intervals, whatever
        ``intervals`` says).
    bootstrap_times : {"report", "all"}
        Where a time series gets intervals: at the config's report times and the final step
        (default; cheap), or at every step.
    sensitivity : {"auto", "on", "off"}
        Given-data first-order Sobol' indices with 95% intervals (the error budget): ``auto``
        when the inputs are at most 50 and the runs from 500 to 1e6
        (:mod:`uqguide.methods.mc_sensitivity`).
    """

    n_samples: int = Field(ge=1, le=100_000_000)
    sampling: Literal["random", "lhs", "sobol"] = "random"
    chunk_size: int = Field(default=8192, ge=1, le=10_000_000)
    intervals: Literal["tail", "delta", "bootstrap", "studentized"] = "tail"
    bootstrap: int = Field(default=200, ge=0, le=100_000)
    bootstrap_times: Literal["report", "all"] = "report"
    sensitivity: Literal["auto", "on", "off"] = "auto"


def method_seed(seed: int, label: str) -> np.random.SeedSequence:
    """The SeedSequence of one method entry: the run's seed and a stable hash of the label, so
    that adding or reordering methods in a config does not change another method's numbers."""
    return np.random.SeedSequence([seed, zlib.crc32(label.encode())])


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
    return np.clip(u, _U_EPS, 1 - _U_EPS)


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

    def design(self, space: InputSpace, seed: int) -> Design:
        s = self.settings
        # The bootstrap stream is a fixed function of the same root, kept apart from the design.
        boot_seed = int(np.random.SeedSequence([seed, zlib.crc32(self.label.encode()), 1])
                        .generate_state(1)[0])
        if self.context.rows is not None:
            return Design(x=self.context.rows.x, data={"boot_seed": boot_seed})
        ss = method_seed(seed, self.label)
        x = GeneratedRows(s.n_samples, space.dim, s.chunk_size,
                          DesignChunks(space, s.n_samples, s.sampling, s.chunk_size, ss),
                          portable=True)
        return Design(x=x, data={"boot_seed": boot_seed})

    def plan(self, space: InputSpace) -> RunPlan:
        s = self.settings
        return RunPlan(runs=s.n_samples, chunk=min(s.chunk_size, s.n_samples))

    # ------------------------------------------------------------------ streaming estimate
    def chunk_bounds(self, n_runs: int) -> list[tuple[int, int]]:
        """The random-stream chunks of ``chunk_size``: the split is part of the numbers."""
        c = self.settings.chunk_size
        return [(s, min(n_runs, s + c)) for s in range(0, max(n_runs, 1), c)]

    def reducer(self, space: InputSpace, design: Design) -> MonteCarloReducer:
        return MonteCarloReducer(self.settings.bootstrap, int(design.data.get("boot_seed", 0)),
                                 self.context.report_times, self.settings.bootstrap_times,
                                 quantiles=self.context.quantile_levels is not None,
                                 n_total=design.n_runs, intervals=self.interval_kind,
                                 sensitivity=self.sensitivity_for(space, design.n_runs))

    def sensitivity_for(self, space: InputSpace, n_runs: int) -> bool:
        """Whether this run estimates the given-data Sobol' indices."""
        return wanted(self.settings.sensitivity, space.dim, n_runs)

    @property
    def interval_kind(self) -> str:
        """``delta``, ``bootstrap`` or ``none`` (``bootstrap: 0`` switches intervals off)."""
        return self.settings.intervals if self.settings.bootstrap > 0 else "none"

    def fold(self, acc: dict | None, summary: dict[str, np.ndarray]) -> dict:
        """Merge a chunk: moment sums by Chan's formulas (all outputs at once,
        :mod:`~uqguide.methods.mc_fold`), series values for the quantiles by concatenation
        (both in chunk order)."""
        acc = {_SUMS: FoldedSums()} if acc is None else acc
        acc[_SUMS].add(split_summary(summary))
        for key, v in summary.items():
            if key.startswith(PER_RUN_KINDS):
                kind, _, name = key.split(":", 2)
                append_columns(acc.setdefault((kind, name), []), v)
        return acc

    def estimate_reduced(self, space: InputSpace, design: Design, runs: ModelOutput,
                         acc: dict[tuple[str, str], Any] | None) -> Estimate:
        t0 = time.perf_counter()
        if acc is not None and _SUMS in acc:
            acc = {**acc[_SUMS].groups(), **{k: v for k, v in acc.items() if k != _SUMS}}
        n_failed = int(runs.failed.sum())
        reasons = Counter(r for r in runs.reasons[runs.failed])
        tally = "; ".join(f"{r} ({c})" for r, c in reasons.most_common())
        if n_failed:
            log.warning("%s: %d of %d runs failed; statistics use the other %d",
                        self.label, n_failed, runs.n, runs.n - n_failed)
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
                                               tail=self.settings.intervals == "tail")
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
        if self.sensitivity_for(space, design.n_runs):
            t_sobol = time.thread_time()  # (this thread: the estimator runs on it alone)
            lanes = {name: acc.get(("q", name)) or acc.get(("s", name)) or []
                     for name in stats}
            add_indices(stats, space, design.x, runs, lanes, self.context.report_times,
                        self.context.groups)
            sobol_seconds = time.thread_time() - t_sobol
        events = count_events(list(self.context.events), runs.scalars, ~runs.failed,
                              dict(self.context.components)) \
            if self.context.events else {}
        names = scalar_names(runs.scalars)  # (stacking them would copy every value)
        joint = acc.get(("j", ""))
        n_ok = runs.n - n_failed
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
        return Estimate(
            method=self.name, label=self.label, stats=stats, diagnostics=diagnostics,
            scalar_index=names,
            scalar_mean=joint.mean if (names and joint is not None and n_ok) else None,
            scalar_cov=(np.asarray(joint.cm) / n_ok
                        if (names and joint is not None and joint.cm is not None and n_ok)
                        else None),
            events=events,
        )


#: threads computing different outputs' quantiles at once (None: one per CPU). The selection
#: is exact, so the numbers do not depend on it; numpy's compares and partitions release the
#: GIL, and this tail runs in the driver after the workers are idle (7 outputs shaped like
#: 1e6 FTCAPN runs': 0.051 s on 2 threads against 0.084 s on one).
QUANTILE_THREADS: int | None = None


def _scalar_quantiles(y: np.ndarray, good: np.ndarray, levels: tuple[float, ...]
                      ) -> tuple[np.ndarray, np.ndarray]:
    return order_statistic_quantiles(y[good], levels)


def _run_jobs(jobs: dict[str, tuple[int, Callable[[], Any]]]) -> dict[str, Any]:
    """Each job's result by name; ``(size, call)`` jobs run on up to
    :data:`QUANTILE_THREADS` threads, the largest first so that the threads finish together."""
    threads = min(QUANTILE_THREADS or os.cpu_count() or 1, len(jobs))
    if threads <= 1:
        return {name: call() for name, (_, call) in jobs.items()}
    order = sorted(jobs, key=lambda name: -jobs[name][0])
    with ThreadPoolExecutor(threads, thread_name_prefix="quantiles") as pool:
        futures = {name: pool.submit(jobs[name][1]) for name in order}
        return {name: futures[name].result() for name in jobs}


def _put_quantiles(st: OutputStats, q: np.ndarray, ci: np.ndarray, levels: tuple[float, ...],
                   time_grid: np.ndarray, report_times: tuple[float, ...] | None) -> None:
    """Quantiles ``q (levels, ...)`` and intervals ``ci (2, levels, ...)`` of a scalar, or of
    a series at every step or at the quantile steps, into ``st``, NaN at the steps not kept."""
    if q.ndim == 3 and q.shape[1] != time_grid.size:
        full_q = np.full((len(levels), time_grid.size, q.shape[2]), np.nan)
        full_ci = np.full((2,) + full_q.shape, np.nan)
        idx = ci_index(time_grid, report_times, "report")
        full_q[:, idx], full_ci[:, :, idx] = q, ci
        q, ci = full_q, full_ci
    st.quantile_levels, st.quantiles, st.ci_quantiles = tuple(levels), q, ci
