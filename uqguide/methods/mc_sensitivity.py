"""The error budget of a Monte Carlo run: given-data first-order Sobol' indices from the runs it
already made (:mod:`uqguide.stats.sobol_given_data`), with no second pass over the model.

What the estimator needs is the ``(inputs, outputs)`` rows of the good runs:

- the inputs are made again from the design (a Monte Carlo design is a pure function of the
  chunk number: :class:`~uqguide.core.types.GeneratedRows`), then the failed runs dropped;
- a scalar output's per-run values are kept anyway (``runs.scalars``);
- a series' values at the report times and the last step are the per-run lanes the chunks
  already send for quantiles (``q::``, at every step or at those steps), or, without
  quantiles, lanes kept at those steps only for this (``s::``,
  :class:`~uqguide.methods.mc_reduce.MonteCarloReducer`). Either way they are written in place
  by pool workers and joined in chunk order, so the rows line up with the design's good rows
  and the indices do not depend on the worker count.

When: ``sensitivity: auto`` (the default) estimates them when the run has at most
:data:`AUTO_MAX_INPUTS` inputs and from :data:`AUTO_MIN_RUNS` to :data:`AUTO_MAX_RUNS` runs:
below that the estimator's bins hold too few runs for a useful budget (at 500 runs the standard
error of an index is about 0.04); above 50 inputs the table is no longer a budget one reads;
above 1e6 runs the series values kept at the report times would grow past a few hundred MB
(32 GB for FTCAPN at 1e8 runs) for indices known to 0.002 long before. ``on`` estimates them
whatever the size (from :data:`~uqguide.stats.sobol_given_data.MIN_RUNS` good runs), ``off``
never.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from ..core.inputs import InputSpace
from ..core.types import GeneratedRows, ModelOutput, OutputStats
from ..stats.sobol_given_data import MIN_RUNS, first_order_indices, n_bins, rank_bins
from ..stats.sobol_groups import group_indices
from .mc_reduce import ci_index

log = logging.getLogger(__name__)

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
    """Set ``sobol_first`` and ``sobol_first_ci`` of every output in ``stats`` (and the
    ``sobol_group_*`` of the groups of inputs, :mod:`uqguide.stats.sobol_groups`).

    Parameters
    ----------
    stats : dict of str to OutputStats
        Monte Carlo's statistics by output (changed in place).
    space : InputSpace
    x : ndarray or GeneratedRows, shape (n, d)
        The design's inputs, every run.
    runs : ModelOutput
        The failure mask, the time grid and the per-run scalars.
    lanes : dict of str to sequence of ndarray
        Per series output, its kept per-run values in chunk order, lane-major ``(L, n_c)``
        (a row per kept step and component), at every step or at :func:`ci_index`'s steps.
    report_times : tuple of float, optional
    groups : sequence of (str, tuple of int)
        Groups of inputs with an index of their own (name, input columns).
    """
    good = ~runs.failed
    x_ok = good_inputs(x, good)
    d = space.dim
    steps = ci_index(runs.time, report_times, "report") if runs.time.size else None
    n = x_ok.shape[0]
    # the inputs sorted once for every output (a sort of each input costs what the bin sums
    # of seven output columns do)
    binned = rank_bins(x_ok) if n >= max(MIN_RUNS, 3 * n_bins(n)) else None
    for name, st in stats.items():
        if name in runs.scalars:
            y = runs.scalars[name][good]
            est = first_order_indices(x_ok, y.T, binned=binned)
            k = y.shape[1]
            st.sobol_first = est.first.reshape(k, d)
            st.sobol_first_ci = est.ci.reshape(2, k, d)
            if groups:
                gf, gci = group_indices(x_ok, y.T, [cols for _, cols in groups])
                st.sobol_group_first, st.sobol_group_first_ci = gf, gci
        elif name in lanes and steps is not None:
            k = st.mean.shape[-1]
            t_all = st.mean.shape[0]
            # the report steps of each chunk's values, then joined: quantiles may keep every
            # step (156 of FTCAPN's, 1.2 GB at 1e6 runs), the indices need 21
            parts = [p if p.shape[0] == steps.size * k else
                     p.reshape(p.shape[0] // k, k, -1)[steps].reshape(steps.size * k, -1)
                     for p in lanes[name]]
            if not parts:
                continue
            rows = parts[0] if len(parts) == 1 else np.concatenate(parts, axis=1)
            est = first_order_indices(x_ok, rows, binned=binned)
            first = np.full((t_all, k, d), np.nan)
            ci = np.full((2, t_all, k, d), np.nan)
            first[steps] = est.first.reshape(steps.size, k, d)
            ci[:, steps] = est.ci.reshape(2, steps.size, k, d)
            st.sobol_first, st.sobol_first_ci = first, ci
            if groups:
                n_g = len(groups)
                gf, gci = group_indices(x_ok, rows, [cols for _, cols in groups])
                st.sobol_group_first = np.full((t_all, k, n_g), np.nan)
                st.sobol_group_first_ci = np.full((2, t_all, k, n_g), np.nan)
                st.sobol_group_first[steps] = gf.reshape(steps.size, k, n_g)
                st.sobol_group_first_ci[:, steps] = gci.reshape(2, steps.size, k, n_g)
        else:
            continue
        st.sobol_estimator = "given-data"
        st.sobol_groups = tuple(name for name, _ in groups) if groups else ()
