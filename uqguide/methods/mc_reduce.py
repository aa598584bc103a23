"""The Monte Carlo chunk reduction, which runs in worker processes (kept apart from
:mod:`uqguide.methods.monte_carlo` so that a worker imports numpy and uqguide's statistics,
not scipy's samplers and chaospy: a process pool starts in a fraction of the time).

See :mod:`uqguide.methods.monte_carlo` for the statistics, the chunk order and the Poisson
bootstrap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.types import ModelOutput, ScalarIndex
from ..stats.moments import MomentSums


# CDF of Poisson(1) at k = 0..19 (the mass beyond 19 is 1.9e-19, below double resolution).
_POISSON1_CDF = np.cumsum([math.exp(-1.0) / math.factorial(k) for k in range(20)])


def poisson1(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Poisson(1) counts as floats, by inverting the CDF of uniforms: ``k`` is the number of
    CDF values ``<= u`` (exact up to the resolution of the uniforms; a few times faster than
    ``rng.poisson`` for lambda = 1: one comparison pass per reachable ``k``)."""
    u = rng.random(shape)
    w = np.zeros(shape, dtype=np.uint8)
    top = u.max(initial=0.0)
    for c in _POISSON1_CDF:
        if c > top:
            break
        w += u >= c
    return w.astype(float)


def ci_index(time_grid: np.ndarray, report_times: tuple[float, ...] | None,
             bootstrap_times: str) -> np.ndarray | None:
    """Time indices where a series gets bootstrap intervals: the steps nearest the report
    times and the last step (``None``: every step)."""
    if bootstrap_times == "all" or time_grid.size == 0:
        return None
    idx = [int(np.argmin(np.abs(time_grid - t))) for t in (report_times or ())]
    idx.append(time_grid.size - 1)
    return np.unique(idx)


#: Quantiles of a series are exact at every step while the kept values (runs x steps x
#: components over all series outputs) stay below this many floats (256 MiB); above it, at the
#: report times and the last step only. Fixed by the config (sample count, grid, outputs), so
#: the choice never depends on the chunking or the workers.
QUANTILE_ALL_FLOATS = 2**25


def quantile_index(time_grid: np.ndarray, report_times: tuple[float, ...] | None,
                   n_total: int, width: int) -> np.ndarray | None:
    """Time indices where series keep their values for quantiles (``None``: every step).

    ``width`` is the number of components of all series outputs together."""
    if n_total * time_grid.size * max(width, 1) <= QUANTILE_ALL_FLOATS:
        return None
    return ci_index(time_grid, report_times, "report")


@dataclass(frozen=True)
class MonteCarloReducer:
    """Reduces one chunk of Monte Carlo runs to mergeable sums (runs in the worker).

    Summary keys are ``"m:<field>:<output>"`` (plain sums with comoments),
    ``"h:<field>:<output>"`` (plain sums with the orders 5-16 of the interval columns, for the
    tail-aware, delta-method and studentised intervals, flattened as the bootstrap's columns under
    ``studentized``), ``"b:<field>:<output>"`` (Poisson-bootstrap sums of the interval
    columns, when ``intervals`` is ``bootstrap``, or ``studentized``: then with each resample's
    orders 5-8) and
    ``"j:<field>:"`` (all scalar outputs stacked, for their joint covariance) and, when
    quantiles are asked for, ``"q::<output>"``: the good runs' values of each series at the
    quantile steps (:func:`quantile_index`), merged by concatenation in chunk order. With
    ``sensitivity`` and no quantiles, ``"s::<output>"`` keeps the same values at the report
    times and the last step only, for the given-data Sobol' indices (with quantiles, those
    read the quantiles' values: a series is kept once).
    """

    bootstrap: int
    boot_seed: int
    report_times: tuple[float, ...] | None
    bootstrap_times: str
    quantiles: bool = False
    n_total: int = 0
    intervals: str = "tail"
    sensitivity: bool = False

    @staticmethod
    def per_run(key: str) -> bool:
        """Whether a summary entry holds per-run values (``q::`` or ``s::``, lane-major, a
        column per good run) rather than sums: a process pool's workers write those in place
        (:mod:`uqguide.driver.execution.shared_rows`)."""
        return key.startswith(PER_RUN_KINDS)

    def __call__(self, out: ModelOutput, index: int) -> dict[str, np.ndarray]:
        ok = ~out.failed
        m = out.n
        summary: dict[str, np.ndarray] = {}
        if not ok.any():
            # Nothing to sum: an empty summary merges as the identity (its failures are
            # counted from the chunk's mask), and an all-failed chunk may carry no time grid.
            return summary
        # The model's arrays are reduced where they lie: a boolean mask would copy every
        # series of the chunk, a full slice is a view.
        keep: slice | np.ndarray = slice(None) if ok.all() else ok
        idx = ci_index(out.time, self.report_times, self.bootstrap_times)
        if self.intervals in ("delta", "tail"):
            for name, y in [*out.series.items(), *out.scalars.items()]:
                y_ok = y[keep]
                _put(summary, "m", name, MomentSums.of(y_ok))
                cols = y_ok[:, idx] if (y.ndim == 3 and idx is not None) else y_ok
                _put(summary, "h", name, MomentSums.of(cols, comoments=False, high=True))
            self._scalars_and_quantiles(summary, out, ok, keep)
            return summary
        w = None
        if self.bootstrap > 0:
            # Weights for every run of the chunk (failed ones then dropped), so a sample's
            # weights do not depend on which other samples failed.
            rng = np.random.default_rng([self.boot_seed, index])
            w = poisson1(rng, (self.bootstrap, m))[:, ok]
        blocks, spans = [], []
        for name, y in [*out.series.items(), *out.scalars.items()]:
            y_ok = y[keep]
            _put(summary, "m", name, MomentSums.of(y_ok))
            cols = y_ok[:, idx] if (y.ndim == 3 and idx is not None) else y_ok
            # explicit width: reshape(0, -1) is ambiguous for a chunk in which every run failed
            blocks.append(cols.reshape(cols.shape[0], int(np.prod(cols.shape[1:]))))
            spans.append((name, blocks[-1].shape[1]))
        student = self.intervals == "studentized"
        if w is not None and blocks:
            # One weighted reduction of every interval column side by side: a few large
            # matrix products instead of one small product per output and power.
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
        return summary

    def _scalars_and_quantiles(self, summary: dict[str, np.ndarray], out: ModelOutput,
                               ok: np.ndarray, keep: slice | np.ndarray) -> None:
        """The joint sums of the stacked scalars and the series values kept for quantiles."""
        stacked = stack_scalars(out.scalars, ok)
        _put(summary, "j", "", MomentSums.of(stacked))
        if self.quantiles and out.series:
            width = sum(y.shape[2] for y in out.series.values())
            q_idx = quantile_index(out.time, self.report_times, self.n_total, width)
            for name, y in out.series.items():
                # lane-major (a row per step and component, the runs along it), a copy: the
                # driver selects order statistics along rows without transposing, and the
                # chunk's buffer is released once the summary leaves the worker
                kept = y[keep] if q_idx is None else y[keep][:, q_idx]
                summary[f"q::{name}"] = np.ascontiguousarray(
                    kept.reshape(kept.shape[0], -1).T)
        elif self.sensitivity and out.series:
            s_idx = ci_index(out.time, self.report_times, "report")
            for name, y in out.series.items():
                kept = y[keep][:, s_idx]
                summary[f"s::{name}"] = np.ascontiguousarray(
                    kept.reshape(kept.shape[0], -1).T)


#: Prefixes of the summary entries that hold per-run values (quantiles', sensitivity's).
PER_RUN_KINDS = ("q::", "s::")


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
    both are column blocks of one array and ``v`` continues it (consecutive chunks written in
    place by pool workers): the quantile selection then makes a few long passes instead of a
    short pass a chunk."""
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
    """All scalar outputs of the good runs side by side ``(n_ok, m)``, in the column order of
    :func:`scalar_names`."""
    cols = [y[ok] for y in scalars.values()]
    if not cols:
        return np.empty((int(ok.sum()), 0))
    return np.concatenate(cols, axis=1)

