"""The values every layer exchanges: what a model returns, the statistics of an output, what a
method estimates, and where a scalar component sits in the stacked scalar vector.

They live here, below models, methods and results, so that each of those imports them from
below instead of from each other: a result reads an :class:`Estimate` without importing the
methods, a PCE reads a :class:`ModelOutput` without importing the models.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..errors import ModelError
from .events import EventEstimate

#: The four statistics every method reports, in table order.
STAT_NAMES = ("mean", "std", "skewness", "kurtosis")
#: Fewest runs a sample moment needs to say anything of the output: whatever the output, the
#: (population) standard deviation of one run is 0, the skewness of two runs 0 and their
#: kurtosis 1, the kurtosis of three runs 1.5. With fewer, a sample estimate is NaN and the
#: tables print "needs n runs".
RUNS_NEEDED = {"mean": 1, "std": 2, "skewness": 3, "kurtosis": 4}


@dataclass
class ModelOutput:
    """What a model returns for a batch of ``n`` samples.

    ``time (T,)``: time grid [s] shared by the batch (empty for models without series);
    ``series``: ``(n, T, k)`` per output, a sample that stops early keeping its last value on
    the rest of the grid; ``scalars``: ``(n, k)``; ``failed (n,)``: the sample's evaluation
    failed, its values are not to be used; ``reasons (n,)``: why (``""`` where it did not).
    """

    time: np.ndarray
    series: dict[str, np.ndarray] = field(default_factory=dict)
    scalars: dict[str, np.ndarray] = field(default_factory=dict)
    failed: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    reasons: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=object))

    @property
    def n(self) -> int:
        return int(self.failed.shape[0])

    def subset(self, index: np.ndarray) -> ModelOutput:
        """The outputs of some samples (a mask ``(n,)`` or positions ``(m,)``), on the same time
        grid."""
        return ModelOutput(
            time=self.time,
            series={k: v[index] for k, v in self.series.items()},
            scalars={k: v[index] for k, v in self.scalars.items()},
            failed=self.failed[index],
            reasons=self.reasons[index],
        )

    @staticmethod
    def concatenate(parts: Sequence[ModelOutput]) -> ModelOutput:
        """Join the outputs of consecutive chunks of one batch, in order, on one time grid
        (ModelError otherwise); a single part is returned as it is, not copied."""
        if not parts:
            raise ModelError("cannot concatenate an empty list of model outputs")
        first = parts[0]
        if len(parts) == 1:
            # one part (a chunk evaluated in one model call, the usual case): nothing to join,
            # and np.concatenate would copy every series of the chunk
            return first
        for p in parts[1:]:
            if p.time.shape != first.time.shape or not np.array_equal(p.time, first.time):
                raise ModelError("chunks of one run must share the time grid")
        return ModelOutput(
            time=first.time,
            series={k: np.concatenate([p.series[k] for p in parts]) for k in first.series},
            scalars={k: np.concatenate([p.scalars[k] for p in parts]) for k in first.scalars},
            failed=np.concatenate([p.failed for p in parts]),
            reasons=np.concatenate([p.reasons for p in parts]),
        )


@dataclass(frozen=True)
class DerivedOutput:
    """How a model computes a non-smooth output from smooth ones (its *carriers*).

    A miss distance is the norm of a miss vector: the vector is smooth in the inputs, its norm
    has a cone where the vector passes through zero, on which a polynomial surrogate converges
    badly. A surrogate method may fit the carriers instead and apply ``function`` to draws of
    their surrogates (:mod:`uqguide.pce.derived`); sampling methods just use the model's value.

    ``function(carriers, inputs) -> y``: ``carriers`` maps each carrier's name to its values
    ``(n, k_c)`` (scalar) or ``(n, T, k_c)`` (series), ``inputs`` each uncertain input's name to
    its physical values ``(n,)``; ``y`` is ``(n, k)`` or ``(n, T, k)`` as ``kind``.
    """

    carriers: tuple[str, ...]
    function: Callable[[Mapping[str, np.ndarray], Mapping[str, np.ndarray]], np.ndarray]
    kind: str = "scalar"


class GeneratedRows:
    """Design rows ``(n, d)`` made on demand, chunk by chunk, by a pure function of the chunk
    number: a design that is never held whole (a 1e8-sample Monte Carlo design would be 5.6 GB).

    Slicing rows (``x[a:b]``) makes only the chunks that cover them; anything else (``np.asarray``,
    fancy indexing) makes the whole array, for small designs and tests. ``make(i)`` returns the
    rows ``[i chunk, i chunk + m_i)`` (the last chunk may be shorter).
    """

    dtype = np.dtype(float)
    ndim = 2

    def __init__(self, n: int, d: int, chunk: int, make: Any, portable: bool = False) -> None:
        self.n, self.d, self.chunk, self._make = n, d, chunk, make
        self.portable = portable

    def lazy(self, start: int, stop: int) -> RowRange | np.ndarray:
        """Rows ``[start, stop)`` to send to another process: a :class:`RowRange` that makes
        them there when ``make`` pickles (``portable``), else the rows themselves."""
        return RowRange(self, start, stop) if self.portable else self.rows(start, stop)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n, self.d)

    @property
    def size(self) -> int:
        return self.n * self.d

    def __len__(self) -> int:
        return self.n

    def rows(self, start: int, stop: int) -> np.ndarray:
        """Rows ``[start, stop)`` (clipped to ``[0, n]``), making only the chunks covering them."""
        start, stop = max(0, start), min(self.n, stop)
        if stop <= start:
            return np.empty((0, self.d))
        first, last = start // self.chunk, (stop - 1) // self.chunk
        parts = [self._make(i) for i in range(first, last + 1)]
        block = parts[0] if len(parts) == 1 else np.concatenate(parts)
        off = first * self.chunk
        return block[start - off:stop - off]

    def prefix(self, n: int) -> GeneratedRows:
        """The first ``n`` rows (the same bits, made by the same chunks), not made yet."""
        return GeneratedRows(min(n, self.n), self.d, self.chunk, self._make, self.portable)

    def chunks(self) -> Iterator[tuple[int, np.ndarray]]:
        """Every chunk as (index of its first row, rows ``(m_i, d)``), made one at a time."""
        for i, start in enumerate(range(0, self.n, self.chunk)):
            yield start, self._make(i)

    def __getitem__(self, key: Any) -> np.ndarray:
        if isinstance(key, slice) and key.step in (None, 1):
            start, stop, _ = key.indices(self.n)
            return self.rows(start, stop)
        return np.asarray(self)[key]

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        x = self.rows(0, self.n)
        return x if dtype is None else x.astype(dtype)


class RowRange:
    """Rows ``[start, stop)`` of a :class:`GeneratedRows`, made where they are used.

    A pool worker that gets one makes its chunk's inputs itself: the driver neither draws nor
    pickles them. The rows are the same bits wherever they are made: the maker is a pure
    function of the chunk number.
    """

    ndim = 2

    def __init__(self, rows: GeneratedRows, start: int, stop: int) -> None:
        self.source, self.start, self.stop = rows, start, stop

    @property
    def shape(self) -> tuple[int, int]:
        return (self.stop - self.start, self.source.d)

    def __len__(self) -> int:
        return self.stop - self.start

    def __array__(self, dtype: Any = None, copy: Any = None) -> np.ndarray:
        x = self.source.rows(self.start, self.stop)
        return x if dtype is None else x.astype(dtype)


@dataclass
class OutputStats:
    """Statistics of one output, from samples or from a surrogate.

    Shapes: ``...`` is ``(T,)`` for a series and empty for a scalar; ``d`` inputs, ``G`` groups,
    ``q`` quantile levels; intervals are 95% (low, high) on a leading axis of 2.

    - ``mean``, ``std``, ``skewness``, ``kurtosis`` ``(..., k)``; ``cov`` ``(..., k, k)``.
    - ``n_used``: runs that did not fail, or surrogate draws.
    - ``moments_method``: ``"sample"`` (population estimators on runs), ``"mfmc"``
      (multi-fidelity Monte Carlo), ``"exact"`` (PCE coefficients) or ``"surrogate-sampling"``.
    - ``sem``: standard error of the mean (sample estimates only); ``ci``: per statistic name.
    - ``sobol_first``, ``sobol_total`` ``(..., k, d)`` and their ``_ci``: a PCE's from its
      coefficients, Monte Carlo's first-order ones from its runs
      (:mod:`uqguide.stats.sobol_given_data`; NaN at steps where none was computed);
      ``sobol_estimator``: ``""`` (none), ``"pce"``, ``"given-data"``, ``"saltelli"``.
    - ``sobol_groups``: the config's ``groups``; ``sobol_group_first`` ``(..., k, G)`` and its
      ``_ci`` (given data, :mod:`uqguide.stats.sobol_groups`); ``sobol_group_total`` and its
      ``_ci``: a PCE's or a pick-freeze design's (:mod:`uqguide.methods.sobol_saltelli`), None
      from given data.
    - ``quantile_levels``: the config's ``quantiles``; ``quantiles`` ``(q, ..., k)`` (NaN at
      steps where none were computed); ``ci_quantiles``: order statistics, ``-inf`` / ``inf``
      an unbounded end.
    - ``corrected`` and ``corrected_ci``: a validated PCE's control-variate estimates
      (:mod:`uqguide.pce.validation`, delta method); empty without a validation set.
    - ``validation_error``: the surrogate's out-of-sample relative error.
    - ``sampling_se``: standard errors of moments sampled from a surrogate (a derived output's
      replicate spread, :mod:`uqguide.pce.derived`); empty where the moments are exact.
    - ``usable``: where the surrogate's error is at most ``usable_error`` (its own moments NaN
      elsewhere); None: not judged (sampling methods).
    - ``fallback`` and ``fallback_ci``: where a PCE withholds a moment (:mod:`uqguide.pce.support`),
      the Monte Carlo estimate of its own runs (:mod:`uqguide.pce.runs_estimate`); NaN where the
      PCE's own value is given.
    """

    mean: np.ndarray
    std: np.ndarray
    skewness: np.ndarray
    kurtosis: np.ndarray
    cov: np.ndarray
    n_used: int
    moments_method: str = "sample"
    sem: np.ndarray | None = None
    ci: dict[str, np.ndarray] = field(default_factory=dict)
    sobol_first: np.ndarray | None = None
    sobol_total: np.ndarray | None = None
    quantile_levels: tuple[float, ...] | None = None
    quantiles: np.ndarray | None = None
    ci_quantiles: np.ndarray | None = None
    sobol_first_ci: np.ndarray | None = None
    sobol_total_ci: np.ndarray | None = None
    sobol_estimator: str = ""
    sobol_groups: tuple[str, ...] = ()
    sobol_group_first: np.ndarray | None = None
    sobol_group_first_ci: np.ndarray | None = None
    sobol_group_total: np.ndarray | None = None
    sobol_group_total_ci: np.ndarray | None = None
    corrected: dict[str, np.ndarray] = field(default_factory=dict)
    corrected_ci: dict[str, np.ndarray] = field(default_factory=dict)
    validation_error: np.ndarray | None = None
    usable: np.ndarray | None = None
    sampling_se: dict[str, np.ndarray] = field(default_factory=dict)
    fallback: dict[str, np.ndarray] = field(default_factory=dict)
    fallback_ci: dict[str, np.ndarray] = field(default_factory=dict)

    def stat(self, name: str) -> np.ndarray:
        """One of the four moments by name, ``(..., k)``."""
        if name not in STAT_NAMES:
            raise KeyError(name)
        value: np.ndarray = getattr(self, name)
        return value

    def quantile_table(self) -> tuple[tuple[float, ...], np.ndarray, np.ndarray] | None:
        """``(levels (q,), quantiles (q, ..., k), ci_quantiles (2, q, ..., k))``, which are set
        together; None where no quantiles were computed."""
        if self.quantiles is None:
            return None
        if self.quantile_levels is None or self.ci_quantiles is None:
            raise ValueError("quantiles need their levels and intervals (set all three)")
        return self.quantile_levels, self.quantiles, self.ci_quantiles


@dataclass(frozen=True)
class ScalarIndex:
    """One column of the stacked scalar vector: component ``component`` of output ``output``.

    Its :attr:`name` is ``"output"`` for a one-component output and ``"output[j]"`` otherwise
    (how tables and result files name it); code compares the fields, never the name.
    """

    output: str
    component: int = 0
    n_components: int = 1

    @property
    def name(self) -> str:
        if self.n_components == 1:
            return self.output
        return f"{self.output}[{self.component}]"

    @staticmethod
    def of(output: str, k: int) -> list[ScalarIndex]:
        """The ``k`` columns of a ``k``-component scalar output."""
        return [ScalarIndex(output, j, k) for j in range(k)]

    @staticmethod
    def stacked(scalars: Iterable[tuple[str, int]]) -> list[ScalarIndex]:
        """The columns of several scalar outputs (name, components) stacked in order."""
        return [ix for name, k in scalars for ix in ScalarIndex.of(name, k)]

    @staticmethod
    def parse(names: Sequence[str]) -> list[ScalarIndex]:
        """The columns named ``"output"`` or ``"output[j]"`` (as stored in a result file); each
        output's component count is that of its columns in ``names``."""
        split = [nm.partition("[") for nm in names]
        counts = Counter(base for base, _, _ in split)
        return [ScalarIndex(base, int(rest.rstrip("]")) if rest else 0, counts[base])
                for base, _, rest in split]


@dataclass
class Estimate:
    """The statistics a method produced, with its diagnostics.

    ``method``: registered name; ``label``: the config's label of this entry; ``stats``: per
    output; ``diagnostics``: counters and quality figures (``n_runs``, ``n_failed``,
    ``loo_error``, ``degree``, ...), numbers, strings or small arrays; ``scalar_index``: the
    columns of the stacked scalar vector, with their joint ``scalar_mean (m,)`` and
    ``scalar_cov (m, m)`` (docs/statistics.md#statistics); ``events``: per config event;
    ``surrogate``: a PCE method's :class:`uqguide.pce.surrogate.Surrogate`, kept in the result
    file (None for sampling methods).
    """

    method: str
    label: str
    stats: dict[str, OutputStats]
    diagnostics: dict[str, Any] = field(default_factory=dict)
    scalar_index: list[ScalarIndex] = field(default_factory=list)
    scalar_mean: np.ndarray | None = None
    scalar_cov: np.ndarray | None = None
    events: dict[str, EventEstimate] = field(default_factory=dict)
    surrogate: Any = None

    @property
    def scalar_names(self) -> list[str]:
        """Names ``output[component]`` of the stacked scalar vector."""
        return [ix.name for ix in self.scalar_index]

    def restrict(self, outputs: Collection[str]) -> None:
        """Keep only the statistics of ``outputs`` (a surrogate method also estimates the
        carriers of derived outputs, which are not part of the result); the stacked scalar mean and
        covariance shrink to their columns."""
        self.stats = {k: v for k, v in self.stats.items() if k in outputs}
        if not self.scalar_index or self.scalar_mean is None:
            return
        keep = [i for i, ix in enumerate(self.scalar_index) if ix.output in outputs]
        self.scalar_index = [self.scalar_index[i] for i in keep]
        self.scalar_mean = self.scalar_mean[keep]
        if self.scalar_cov is not None:
            self.scalar_cov = self.scalar_cov[np.ix_(keep, keep)]
