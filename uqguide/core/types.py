"""The values every layer exchanges: what a model returns, the statistics of an output, what a
method estimates, and where a scalar component sits in the stacked scalar vector.

They live here, below models, methods and results, so that each of those imports them from
below instead of from each other: a result reads an :class:`Estimate` without importing the
methods, a PCE reads a :class:`ModelOutput` without importing the models.
"""

from __future__ import annotations

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

    Attributes
    ----------
    time : ndarray, shape (T,)
        Time grid [s] shared by the whole batch (empty for models without time series).
    series : dict of str to ndarray, shape (n, T, k)
        Time-series outputs. A sample that stops early keeps its last value on the rest of
        the grid.
    scalars : dict of str to ndarray, shape (n, k)
        Scalar outputs.
    failed : ndarray of bool, shape (n,)
        True where the sample's evaluation failed; its output values are not to be used.
    reasons : ndarray of object, shape (n,)
        Why each failed sample failed (``""`` where it did not).
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
        """The outputs of some samples of the batch.

        Parameters
        ----------
        index : ndarray, shape (n,) of bool, or (m,) of int
            The samples to keep (a mask or their positions).

        Returns
        -------
        ModelOutput
            Same time grid; series ``(m, T, k)``, scalars ``(m, k)``, failures ``(m,)``.
        """
        return ModelOutput(
            time=self.time,
            series={k: v[index] for k, v in self.series.items()},
            scalars={k: v[index] for k, v in self.scalars.items()},
            failed=self.failed[index],
            reasons=self.reasons[index],
        )

    @staticmethod
    def concatenate(parts: Sequence[ModelOutput]) -> ModelOutput:
        """Join the outputs of consecutive chunks of one batch, in order (a single part is
        returned as it is, not copied).

        Parameters
        ----------
        parts : sequence of ModelOutput
            Chunks of ``n_i`` samples each, on one time grid (ModelError otherwise).

        Returns
        -------
        ModelOutput
            ``sum(n_i)`` samples, in the order of ``parts``.
        """
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

    Attributes
    ----------
    carriers : tuple of str
        The (smooth) outputs it is computed from; the model must offer them.
    function : callable
        ``function(carriers, inputs) -> y``: ``carriers`` maps each carrier's name to its values
        ``(n, k_c)`` (scalar) or ``(n, T, k_c)`` (series), ``inputs`` maps each uncertain
        input's name to its physical values ``(n,)``; ``y`` is ``(n, k)`` or ``(n, T, k)``.
    kind : {"scalar", "series"}
    """

    carriers: tuple[str, ...]
    function: Callable[[Mapping[str, np.ndarray], Mapping[str, np.ndarray]], np.ndarray]
    kind: str = "scalar"


class GeneratedRows:
    """Design rows ``(n, d)`` made on demand, chunk by chunk, by a pure function of the chunk
    number: a design that is never held whole (a 1e8-sample Monte Carlo design would be 5.6 GB).

    Slicing rows (``x[a:b]``) makes only the chunks that cover them; anything else (``np.asarray``,
    fancy indexing) makes the whole array, for small designs and tests.

    Parameters
    ----------
    n, d : int
        Rows and columns.
    chunk : int
        Rows per chunk (the last may be shorter).
    make : callable
        ``make(i) -> ndarray (m_i, d)``, the rows ``[i chunk, i chunk + m_i)``.
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
        """Rows ``[start, stop)``, making only the chunks that cover them.

        Parameters
        ----------
        start, stop : int
            Row range, clipped to ``[0, n]``.

        Returns
        -------
        ndarray, shape (stop - start, d)
        """
        start, stop = max(0, start), min(self.n, stop)
        if stop <= start:
            return np.empty((0, self.d))
        first, last = start // self.chunk, (stop - 1) // self.chunk
        parts = [self._make(i) for i in range(first, last + 1)]
        block = parts[0] if len(parts) == 1 else np.concatenate(parts)
        off = first * self.chunk
        return block[start - off:stop - off]

    def chunks(self) -> Iterator[tuple[int, np.ndarray]]:
        """Every chunk in order, made one at a time.

        Yields
        ------
        start : int
            Index of the chunk's first row.
        rows : ndarray, shape (m_i, d)
        """
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
    pickles them (for a 1e6-run FTCAPN study, 1.2 s of the driver's time and 56 MB through
    the pipes). The rows are the same bits wherever they are made: the maker is a pure
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

    Attributes
    ----------
    mean, std, skewness, kurtosis : ndarray, shape (..., k)
        ``...`` is ``(T,)`` for a time series and empty for a scalar output.
    cov : ndarray, shape (..., k, k)
    n_used : int
        Samples the estimate used (runs that did not fail), or surrogate draws.
    moments_method : str
        ``"sample"`` (population estimators on model runs), ``"mfmc"`` (multi-fidelity Monte
        Carlo over fidelity levels of the model), ``"exact"`` (from PCE
        coefficients) or ``"surrogate-sampling"`` (sampling a PCE surrogate).
    sem : ndarray, shape (..., k), optional
        Standard error of the mean (sample estimates only).
    ci : dict of str to ndarray, shape (2, ..., k)
        95% interval (low, high) per statistic name, where known.
    sobol_first, sobol_total : ndarray, shape (..., k, d), optional
        Sobol' indices per input: a PCE's from its coefficients, Monte Carlo's first-order
        ones from its runs (:mod:`uqguide.stats.sobol_given_data`; NaN at the steps of a series
        where none was computed).
    sobol_first_ci, sobol_total_ci : ndarray, shape (2, ..., k, d), optional
        Their 95% intervals (low, high), where the method gives them.
    sobol_estimator : str
        How the indices were estimated (``""``: no indices; ``"pce"``, ``"given-data"``,
        ``"saltelli"``).
    sobol_groups : tuple of str
        Names of the groups of inputs with indices (the config's ``groups``).
    sobol_group_first : ndarray, shape (..., k, G), optional
        First-order indices of those groups (given data; :mod:`uqguide.stats.sobol_groups`).
    sobol_group_first_ci : ndarray, shape (2, ..., k, G), optional
        Their 95% intervals.
    sobol_group_total, sobol_group_total_ci : ndarray, shape (..., k, G) / (2, ..., k, G)
        Total indices of the groups and their 95% intervals (a PCE's, or a pick-freeze
        design's, whose groups are frozen together: :mod:`uqguide.methods.sobol_saltelli`);
        None from given data.
    quantile_levels : tuple of float, optional
        Probabilities of the quantiles (the config's ``quantiles``).
    quantiles : ndarray, shape (q, ..., k), optional
        Quantiles at those levels (NaN at time steps where none were computed).
    ci_quantiles : ndarray, shape (2, q, ..., k), optional
        Their 95% intervals (order statistics; ``-inf`` / ``inf``: unbounded end).
    corrected : dict of str to ndarray, shape (..., k)
        A validated PCE's control-variate estimates of mean, std, skewness and kurtosis
        (:mod:`uqguide.pce.validation`); empty without a validation set.
    corrected_ci : dict of str to ndarray, shape (2, ..., k)
        Their 95% intervals (delta method over the validation runs).
    validation_error : ndarray, shape (..., k), optional
        The surrogate's out-of-sample relative error on the validation runs.
    sampling_se : dict of str to ndarray, shape (..., k)
        Standard errors of moments sampled from a surrogate (a derived output's replicate
        spread, :mod:`uqguide.pce.derived`); empty where the moments are exact.
    usable : ndarray of bool, shape (..., k), optional
        Where the surrogate is usable (its error at most the method's ``usable_error``); its
        own moments are NaN elsewhere. None: not judged (sampling methods).
    fallback : dict of str to ndarray, shape (..., k)
        Where a PCE withholds a moment (not usable, or not supported by its runs,
        :mod:`uqguide.pce.support`): the Monte Carlo estimate of its own fit and validation
        runs (:mod:`uqguide.pce.runs_estimate`); NaN where the PCE's own value is given.
    fallback_ci : dict of str to ndarray, shape (2, ..., k)
        Their 95% intervals.
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
        """One of the four moments by name.

        Parameters
        ----------
        name : {"mean", "std", "skewness", "kurtosis"}

        Returns
        -------
        ndarray, shape (..., k)
            In the output's unit (skewness and kurtosis: dimensionless).
        """
        if name not in STAT_NAMES:
            raise KeyError(name)
        value: np.ndarray = getattr(self, name)
        return value

    def quantile_table(self) -> tuple[tuple[float, ...], np.ndarray, np.ndarray] | None:
        """The quantiles with their levels and intervals, which are set together.

        Returns
        -------
        tuple or None
            ``(levels, quantiles, ci_quantiles)``: the probabilities ``(q,)``, the quantiles
            ``(q, ..., k)`` and their 95% intervals ``(2, q, ..., k)``, in the output's unit;
            None where no quantiles were computed.
        """
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
        """The columns of a ``k``-component scalar output.

        Parameters
        ----------
        output : str
            The output's name.
        k : int
            Its number of components.

        Returns
        -------
        list of ScalarIndex, length k
        """
        return [ScalarIndex(output, j, k) for j in range(k)]

    @staticmethod
    def stacked(scalars: Iterable[tuple[str, int]]) -> list[ScalarIndex]:
        """The columns of several scalar outputs stacked in order.

        Parameters
        ----------
        scalars : iterable of (str, int)
            Each output's name and number of components.

        Returns
        -------
        list of ScalarIndex
            One per column, ``sum(k)`` in all.
        """
        return [ix for name, k in scalars for ix in ScalarIndex.of(name, k)]

    @staticmethod
    def parse(names: Sequence[str]) -> list[ScalarIndex]:
        """The columns named ``names`` (as stored in a result file).

        Parameters
        ----------
        names : sequence of str
            ``"output"`` or ``"output[j]"`` per column.

        Returns
        -------
        list of ScalarIndex, same length
            Each output's component count is that of its columns in ``names``.
        """
        split = []
        for nm in names:
            base, _, rest = nm.partition("[")
            split.append((base, int(rest.rstrip("]")) if rest else 0))
        counts: dict[str, int] = {}
        for base, _ in split:
            counts[base] = counts.get(base, 0) + 1
        return [ScalarIndex(base, j, counts[base]) for base, j in split]


@dataclass
class Estimate:
    """The statistics a method produced, with its diagnostics.

    Attributes
    ----------
    method : str
        Registered method name.
    label : str
        The config's label of this method entry.
    stats : dict of str to OutputStats
        Per output name.
    diagnostics : dict
        Counters and quality figures: ``n_runs``, ``n_failed``, and method-specific ones
        (``loo_error``, ``degree``, ``n_terms``, ``n_components``, ...). Values are numbers,
        strings or small arrays.
    scalar_index : list of ScalarIndex
        The columns of the stacked scalar vector.
    scalar_mean, scalar_cov : ndarray, shape (m,), (m, m)
        Joint mean and covariance of all scalar outputs stacked (docs/statistics.md#statistics).
    events : dict of str to EventEstimate
        Probability of each of the config's events.
    surrogate : object, optional
        The fitted surrogate of a PCE method (:class:`uqguide.pce.surrogate.Surrogate`), kept
        in the result file; None for sampling methods.
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
        carriers of derived outputs, which are not part of the result).

        Parameters
        ----------
        outputs : collection of str
            The outputs to keep; the stacked scalar mean and covariance shrink to their
            columns.
        """
        self.stats = {k: v for k, v in self.stats.items() if k in outputs}
        if not self.scalar_index or self.scalar_mean is None:
            return
        keep = [i for i, ix in enumerate(self.scalar_index) if ix.output in outputs]
        self.scalar_index = [self.scalar_index[i] for i in keep]
        self.scalar_mean = self.scalar_mean[keep]
        if self.scalar_cov is not None:
            self.scalar_cov = self.scalar_cov[np.ix_(keep, keep)]
