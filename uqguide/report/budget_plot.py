"""The error budget of a series over time: each input's first-order Sobol' index against time,
one panel per method, the 95% interval as a band.

Lines rather than stacked areas: the indices of a correlated input need not sum to at most 1,
a given-data index near 0 may be slightly negative, and an interval band cannot stack. Monte
Carlo has indices at the report times and the last step only (markers with error bars, no line
between); a PCE at every step (lines and bands). Each input keeps one colour in every panel.
Only the inputs whose index reaches :data:`MIN_SHOWN` somewhere are drawn (at most
:data:`MAX_LINES`, the largest first); the legend names how many others there are.
"""

from __future__ import annotations

import numpy as np

from .budget import ESTIMATORS
from .figures import Figure, input_colour, new_figure
from ..results.result import Result
from ..results.statistics import result_statistics

MIN_SHOWN = 0.02
MAX_LINES = 10


def has_budget(result: Result, output: str) -> bool:
    """Whether some method has Sobol' indices of the series ``output``."""
    described = result_statistics(result)
    return any((s := d.get(output)) is not None and s.sobol_first is not None
               and np.isfinite(np.asarray(s.sobol_first)).any() for d in described.values())


def budget_figure(result: Result, output: str, component: int = 0) -> Figure:
    """First-order indices of one component of a series output with indices
    (:func:`has_budget`) over time, one panel per method."""
    described = result_statistics(result)
    # A method with no usable surrogate keeps its indices as NaN: it gets no panel.
    panels = [(label, d[output]) for label, d in described.items()
              if output in d and d[output].sobol_first is not None
              and np.isfinite(np.asarray(d[output].sobol_first)[:, component]).any()]
    o = result.output(output)
    comp = o.components[component]
    fig = new_figure((8.0, 3.4 * max(len(panels), 1) + 0.8), layout="constrained")
    axes = fig.subplots(max(len(panels), 1), 1, squeeze=False, sharex=True)[:, 0]
    t = result.time
    names = list(result.input_names)
    for ax, (label, s) in zip(axes, panels):
        first = np.asarray(s.sobol_first)[:, component]          # (T, d)
        ci = None if s.sobol_first_ci is None else np.asarray(s.sobol_first_ci)[:, :, component]
        at = np.flatnonzero(np.isfinite(first).any(axis=1))
        peak = np.nanmax(np.where(np.isfinite(first[at]), first[at], -np.inf), axis=0)
        order = [i for i in np.argsort(-peak, kind="stable") if peak[i] >= MIN_SHOWN]
        shown = order[:MAX_LINES]
        # Sampled indices are known at the report times only: markers with their intervals,
        # no line drawn through the steps between, where nothing was estimated.
        sampled = s.sobol_estimator in ("given-data", "saltelli")
        for i in shown:
            colour = input_colour(i)  # the input's own, in every panel and figure
            if sampled:
                err = None if ci is None else np.abs(ci[:, at, i] - first[at, i])
                ax.errorbar(t[at], first[at, i], yerr=err, color=colour, marker="o", ms=4,
                            ls="none", elinewidth=1.0, capsize=3, label=names[i])
                continue
            ax.plot(t[at], first[at, i], color=colour, lw=1.4, label=names[i])
            if ci is not None:
                ax.fill_between(t[at], ci[0, at, i], ci[1, at, i], color=colour, alpha=0.18,
                                lw=0)
        left = len(names) - len(shown)
        if left:
            ax.plot([], [], " ", label=f"{left} other input{'s' * (left > 1)} "
                                       f"(index < {MIN_SHOWN:g} throughout)")
        how = ESTIMATORS.get(s.sobol_estimator, "from the PCE coefficients")
        ax.set_title(f"{label}: {how}", fontsize=10)
        ax.set_ylabel("first-order Sobol' index")
        ax.set_ylim(min(-0.05, float(np.nanmin(first[at])) - 0.02) if at.size else -0.05, 1.05)
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="best")
    axes[-1].set_xlabel("time [s]")
    what = f"{output}[{comp}]" if comp else output
    fig.suptitle(f"{result.name}: error budget of {what} over time (95% intervals as bands)",
                 fontsize=11)
    return fig
