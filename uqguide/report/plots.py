"""Figures of a result: statistics over time, scalar distributions and the cost of each method.

:func:`series_figure` (mean +- std, std, skewness, kurtosis over time, one line per method),
:func:`envelope_figure` (quantile envelopes), :func:`scalar_figure` (Monte Carlo histograms with
each PCE's density from :data:`SURROGATE_DRAWS` draws of its kept surrogate; a 0/1 output as a
probability with its interval) and :func:`cost_figure` (the cost table as bars and a table); the
error budget over time is :func:`uqguide.report.budget_plot.budget_figure`. Figures are made and
written through :mod:`uqguide.report.figures` (no ``pyplot``: no global state, no display, nothing
to close); axis labels carry the output's SI unit.

What each figure shows and why: docs/guide.md#the-figures.
"""

from __future__ import annotations

import logging
import re
import textwrap
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats as sps

from ..core import atomic
from .budget_plot import budget_figure, has_budget
from .figures import Figure, new_figure, save
from ..models.base import OutputInfo
from .tables import cost_table
from ..results.result import MethodRun, Result
from ..results.statistics import FROM_RUNS, OutputStatistics, result_statistics
from ..stats.moments import overflowed

log = logging.getLogger(__name__)

METHOD_SHORT = {"monte_carlo": "MC", "pce_tensor": "tensor PCE", "pce_smolyak": "Smolyak PCE",
                "pce_adaptive": "adaptive PCE"}
#: Method colours (tab10 without its grey); the reference method is drawn in black.
_COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
            "#bcbd22", "#17becf"]
DPI = 130


@dataclass(frozen=True)
class FigureFile:
    """A written figure: its path, what it shows (``series``, ``scalar``, ``cost``) and of what."""

    path: Path
    kind: str
    output: str = ""
    component: str = ""


def unit_label(unit: str) -> str:
    """``[unit]`` for axis labels; ``[-]`` for a dimensionless quantity."""
    return "[-]" if unit in ("", "1", "-") else f"[{unit}]"


def method_label(r: MethodRun) -> str:
    """A method's legend entry: label, short method name and runs (``"mc1000 (MC, 1000 runs)"``)."""
    short = METHOD_SHORT.get(r.estimate.method, r.estimate.method)
    return f"{r.label} ({short}, {r.n_runs} run{'' if r.n_runs == 1 else 's'})"


def _of(result: Result, output: str) -> dict[str, OutputStatistics]:
    """The statistics of ``output`` by method label, of the methods that have them."""
    return {label: d[output] for label, d in result_statistics(result).items() if output in d}


def _described_runs(result: Result, output: str
                    ) -> list[tuple[MethodRun, OutputStatistics, dict]]:
    """``(run, its statistics of output, its line style)`` of each method that has them, in the
    result's order."""
    styles, described = _styles(result), _of(result, output)
    return [(r, described[r.label], styles[r.label]) for r in result.runs
            if r.label in described]


def _is_sample(v: OutputStatistics | None) -> bool:
    return v is not None and v.moments_method in FROM_RUNS


def _styles(result: Result) -> dict[str, dict]:
    """Line style per method label: reference black and thick, sample methods solid, PCE dashed."""
    styles, k = {}, 0
    for r in result.runs:
        sample = r.estimate.method == "monte_carlo"
        if r.label == result.reference:
            styles[r.label] = {"color": "black", "lw": 2.2, "ls": "-"}
            continue
        styles[r.label] = {"color": _COLOURS[k % len(_COLOURS)], "lw": 1.6,
                           "ls": "-" if sample else ("--", "-.", ":")[k % 3]}
        k += 1
    return styles


def _comp_suffix(o: OutputInfo, c: int) -> str:
    return f"[{o.components[c]}]" if o.components[c] else ""


# ---------------------------------------------------------------------------- time series
def series_figure(result: Result, output: str, component: int = 0) -> Figure:
    """Mean +- std, std, skewness and kurtosis over time [s] of one series output component."""
    o = result.output(output)
    name = f"{o.name}{_comp_suffix(o, component)}"
    u = unit_label(o.unit)
    t = result.time
    fig = new_figure((11.0, 7.8), layout="constrained")
    (ax_m, ax_s), (ax_g, ax_k) = fig.subplots(2, 2, sharex=True)
    handles, labels = [], []
    span = float(t[-1] - t[0]) if t.size > 1 else 1.0
    n_ci = 0
    for r, s, st in _described_runs(result, output):
        dodge = 0.006 * span * n_ci
        n_ci += any(m.ci is not None for m in s.moments)
        mean, std = s.moment("mean").value[:, component], s.moment("std").value[:, component]
        # Light fills overlap into grey where methods agree; thin edges keep each band visible.
        ax_m.fill_between(t, mean - std, mean + std, color=st["color"], alpha=0.07, lw=0)
        for edge in (mean - std, mean + std):
            ax_m.plot(t, edge, color=st["color"], lw=0.7, ls=st["ls"], alpha=0.7)
        (h,) = ax_m.plot(t, mean, **st)
        ax_s.plot(t, std, **st)
        ax_g.plot(t, s.moment("skewness").value[:, component], **st)
        ax_k.plot(t, s.moment("kurtosis").value[:, component], **st)
        for ax, m in zip((ax_m, ax_s, ax_g, ax_k), s.moments):
            if m.ci is None:
                continue
            lo, hi = m.ci[0][:, component], m.ci[1][:, component]
            val = m.value[:, component]
            ok = np.isfinite(lo) & np.isfinite(hi) & np.isfinite(val)
            if ok.any():
                # Bars of several methods at one report time are dodged sideways to stay apart.
                ax.errorbar(t[ok] + dodge, val[ok], yerr=[np.maximum(val[ok] - lo[ok], 0),
                                                  np.maximum(hi[ok] - val[ok], 0)],
                            fmt="none", ecolor=st["color"], elinewidth=1.2, capsize=3)
        handles.append(h)
        labels.append(method_label(r))
    g0 = ax_g.axhline(0.0, color="grey", ls=":", lw=1.2)
    ax_k.axhline(3.0, color="grey", ls=":", lw=1.2)
    ax_m.set(title="Mean, shaded: mean $\\pm$ 1 std", ylabel=f"{name} {u}")
    ax_s.set(title="Standard deviation", ylabel=f"std of {name} {u}")
    ax_g.set(title="Skewness", ylabel=f"skewness of {name} [-]", xlabel="time [s]")
    ax_k.set(title="Kurtosis (non-excess)", ylabel=f"kurtosis of {name} [-]", xlabel="time [s]")
    for ax in (ax_g, ax_k):
        if not any(np.isfinite(ln.get_ydata()).any() for ln in ax.get_lines()[:-1]):
            ax.text(0.5, 0.6, "undefined: the std is zero\n(every run agrees)",
                    transform=ax.transAxes, ha="center", va="center", color="dimgrey")
    for ax in (ax_m, ax_s, ax_g, ax_k):
        ax.grid(True, alpha=0.3)
        ax.set_xlim(t[0] - 0.01 * span, t[-1] + 0.03 * span)
    fig.suptitle(f"{result.name}: {name} {u} over time\n{textwrap.fill(o.description, 110)}",
                 fontsize=12)
    fig.legend(handles + [g0], labels + ["Gaussian (skewness 0, kurtosis 3)"],
               loc="outside lower center", ncol=min(3, len(handles) + 1), fontsize=9,
               title="Bars: 95% bootstrap intervals of Monte Carlo estimates at the report "
                     "times", title_fontsize=8)
    return fig


def has_quantiles(result: Result, output: str) -> bool:
    """Whether any method of ``result`` computed quantiles of ``output``."""
    return any(v.quantiles for v in _of(result, output).values())


def envelope_figure(result: Result, output: str, component: int = 0) -> Figure:
    """Quantile envelopes over time of one series output component, per method.

    Band: the outermost pair of levels; line: the median (or middle level); dotted: the outer
    quantiles' 95% intervals where the runs bound them; dashed: mean +- k std with the k a
    Gaussian gives the outer levels. Quantiles at the report times only (above the memory cap)
    show as markers. docs/statistics.md#quantiles-and-events.
    """
    o = result.output(output)
    name = f"{o.name}{_comp_suffix(o, component)}"
    u = unit_label(o.unit)
    t = result.time
    fig = new_figure((10.0, 5.6), layout="constrained")
    ax = fig.add_subplot()
    title_levels = ""
    for r, s, st in _described_runs(result, output):
        if not s.quantiles:
            continue
        lv = s.quantile_levels
        lo_i, hi_i, mid_i = 0, len(lv) - 1, int(np.argmin(np.abs(np.asarray(lv) - 0.5)))
        q = [qs.value[:, component] for qs in s.quantiles]
        ok = np.isfinite(q[lo_i]) & np.isfinite(q[hi_i])
        dense = ok.sum() > 2 and ok.all()
        mark: dict[str, Any] = {} if dense else {"marker": "o", "ms": 4}
        if dense:
            ax.fill_between(t, q[lo_i], q[hi_i], color=st["color"], alpha=0.12, lw=0)
        for i in (lo_i, hi_i):
            ax.plot(t[ok], q[i][ok], color=st["color"], lw=1.1, ls=st["ls"], **mark)
            for end in (0, 1):
                e = np.asarray(s.quantiles[i].ci)[end, :, component]
                fine = ok & np.isfinite(e)
                if fine.any():
                    ax.plot(t[fine], e[fine], color=st["color"], lw=0.6, ls=":")
        ax.plot(t[ok], q[mid_i][ok], color=st["color"], lw=1.8, ls=st["ls"],
                label=f"{method_label(r)}: q{lv[mid_i]:g} and q{lv[lo_i]:g}-q{lv[hi_i]:g}",
                **mark)
        if lv[lo_i] < 0.5 < lv[hi_i]:
            k = float(sps.norm.isf(lv[lo_i]))
            m, sd = s.moment("mean").value[:, component], s.moment("std").value[:, component]
            ax.plot(t, m - k * sd, color=st["color"], lw=0.8, ls="--", alpha=0.7)
            ax.plot(t, m + k * sd, color=st["color"], lw=0.8, ls="--", alpha=0.7,
                    label=f"{r.label}: mean $\\pm$ {k:.3g} std (Gaussian reading)")
        title_levels = f"{lv[lo_i]:g} to {lv[hi_i]:g}"
    ax.set(xlabel="time [s]", ylabel=f"{name} {u}",
           title=f"{result.name}: {name}, quantile envelope {title_levels}\n(dotted: 95% "
                 f"intervals of the outer quantiles, where the runs bound them)")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return fig


# ---------------------------------------------------------------------------- scalars
def _plot_range(samples: list[np.ndarray]) -> tuple[float, float, int]:
    """x range of the histograms: the pooled samples' 0.1-99.9% quantiles (heavy tails would
    squash the body), widened to the full range when that costs little; and the clipped count."""
    pooled = np.concatenate(samples)
    lo, hi = np.quantile(pooled, [0.001, 0.999])
    full_lo, full_hi = float(pooled.min()), float(pooled.max())
    if full_hi - full_lo <= 1.5 * (hi - lo):
        lo, hi = full_lo, full_hi
    if hi <= lo:
        lo, hi = lo - 0.5 * max(abs(lo), 1e-12), hi + 0.5 * max(abs(hi), 1e-12)
    outside = int(np.sum((pooled < lo) | (pooled > hi)))
    return float(lo), float(hi), outside


def _bins(y: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Bin edges on ``[lo, hi]``: Freedman-Diaconis for this sample, 10 to 70 bins (a small
    sample gets coarse bins rather than a comb of empty ones)."""
    inside = y[(y >= lo) & (y <= hi)]
    n = 10
    if inside.size > 1:
        n = np.histogram_bin_edges(inside, bins="fd", range=(lo, hi)).size - 1
    return np.linspace(lo, hi, int(np.clip(n, 10, 70)) + 1)


def _moment_density(mean: float, std: float, skew: float) -> sps.rv_continuous | None:
    if not (np.isfinite(mean) and np.isfinite(std) and std > 0):
        return None
    return sps.pearson3(skew if np.isfinite(skew) else 0.0, loc=mean, scale=std)


#: Surrogate draws behind a PCE's kernel density estimate (fixed seed: the same figure twice).
SURROGATE_DRAWS = 100_000


def _surrogate_draws(result: Result, r: MethodRun, output: str,
                     n: int = SURROGATE_DRAWS) -> np.ndarray | None:
    """``(n, k)`` draws of the method's kept surrogate of ``output`` (None: no surrogate)."""
    from ..errors import ConfigError, ResultError

    if r.estimate.surrogate is None:
        return None
    try:
        sur = result.surrogate(r.label)
    except (ResultError, ConfigError) as exc:
        log.warning("%s: surrogate not usable for the plot (%s)", r.label, exc)
        return None
    if output not in sur.names:
        return None
    u = np.random.default_rng(20260101).random((n, len(result.input_names)))
    y = sur.at_unit(np.clip(u, 2.0**-53, 1 - 2.0**-53), [output])[output]
    y = np.asarray(y, dtype=float).reshape(n, -1)
    return y[np.isfinite(y).all(axis=1)]


def _kde(y: np.ndarray, xs: np.ndarray) -> np.ndarray:
    """Gaussian kernel density of draws ``y`` at ``xs``; a non-negative output whose draws
    reach down to 0 (a miss distance) is reflected at 0, so the kernel's mass below 0 is not
    lost: a plain KDE halves the density at the boundary where the output piles up."""
    with np.errstate(over="ignore", invalid="ignore"):
        finite_spread = bool(np.isfinite(np.var(y)))
    if not finite_spread and np.isfinite(y).all():
        # draws near 1e300, whose variance overflows: the density of y 2^-k at xs 2^-k,
        # times 2^-k (a power of two scales exactly)
        scale = float(np.ldexp(1.0, -int(np.frexp(np.max(np.abs(y)))[1])))
        return _kde(y * scale, xs * scale) * scale
    plain = sps.gaussian_kde(y)
    if y.min() >= 0 and y.min() < 0.1 * y.std():
        both = np.concatenate([y, -y])
        # the same kernel width as the plain estimate (Scott's rule on y itself)
        kde = sps.gaussian_kde(both, bw_method=plain.factor * y.std() / both.std())
        return np.where(xs >= 0, 2 * kde(xs), 0.0)
    return np.asarray(plain(xs))


def _is_binary(samples: dict[str, np.ndarray]) -> bool:
    """Whether every sample of every Monte Carlo method is 0 or 1 (and both occur or not)."""
    return bool(samples) and all(np.isin(y, (0.0, 1.0)).all() for y in samples.values())


def _probability_panel(ax, result: Result, output: str, c: int,
                       samples: dict[str, np.ndarray], styles: dict) -> None:
    """P(output = 1) per method with its 95% interval (a 0/1 output is not a density)."""
    from ..core.events import clopper_pearson

    labels, p, lo, hi, colours = [], [], [], [], []
    described = _of(result, output)
    for r in result.runs:
        s = described.get(r.label)
        if r.label in samples:
            y = samples[r.label]
            k = int(y.sum())
            a, b = clopper_pearson(k, y.size)
            val = k / y.size
        elif s is not None:
            val = float(s.moment("mean").value[c])
            if s.corrected:
                val = float(s.corrected[0].value[c]) if not np.isfinite(val) else val
                a, b = s.corrected[0].interval((c,))
            else:
                a = b = val
        else:
            continue
        labels.append(method_label(r))
        p.append(val)
        lo.append(val - a if np.isfinite(a) else 0.0)
        hi.append(b - val if np.isfinite(b) else 0.0)
        colours.append(styles[r.label]["color"])
    ypos = np.arange(len(labels))[::-1]
    ax.barh(ypos, p, xerr=[np.maximum(lo, 0), np.maximum(hi, 0)], color=colours, alpha=0.8,
            capsize=4)
    for y, v, h in zip(ypos, p, hi):
        # beyond the interval's upper end, so the whisker never runs through the number
        ax.text(v + max(h, 0.0), y, f"  {v:.4g}", va="center", fontsize=9)
    ax.set(yticks=ypos, yticklabels=labels, xlabel=f"P({output} = 1) [-] (95% interval)",
           xlim=(0, max(1e-3, 1.3 * max([a + b for a, b in zip(p, hi)], default=1.0))))
    ax.grid(True, axis="x", alpha=0.3)


def _stats_text(mean: float, std: float, skew: float, kurt: float,
                sample: bool = True, n_used: int | None = None) -> str:
    over = overflowed(mean, std, skew, kurt, sample, n_used)
    text = {name: "overflow" if over[name] else format(v, spec) for name, v, spec in (
        ("mean", mean, ".4g"), ("std", std, ".4g"), ("skewness", skew, ".3g"),
        ("kurtosis", kurt, ".3g"))}
    return (f"mean {text['mean']}, std {text['std']}, skew {text['skewness']}, "
            f"kurt {text['kurtosis']}")


def scalar_figure(result: Result, output: str) -> Figure:
    """Histograms of the Monte Carlo samples of a scalar output, with each PCE's density.

    One panel per component; module docstring for what the PCE curve is.
    """
    o = result.output(output)
    k = o.k
    ncols = min(k, 3)
    nrows = -(-k // ncols)
    width = 5.6 * ncols + (2.0 if ncols == 1 else 1.0)
    fig = new_figure((width, 4.6 * nrows + 1.6), layout="constrained")
    axes = np.atleast_1d(fig.subplots(nrows, ncols, squeeze=False)).ravel()
    styles = _styles(result)
    u = unit_label(o.unit)
    notes = set()
    described = _of(result, output)
    for c in range(k):
        ax = axes[c]
        name = f"{o.name}{_comp_suffix(o, c)}"
        samples = {}
        for r in result.runs:
            if _is_sample(described.get(r.label)) and output in r.scalars:
                y = np.asarray(r.scalars[output])[~np.asarray(r.failed, bool), c]
                y = y[np.isfinite(y)]
                if y.size:
                    samples[r.label] = y
        if _is_binary(samples):
            _probability_panel(ax, result, output, c, samples, styles)
            ax.set_title(name if k > 1 else None)
            continue
        draws, densities = {}, {}
        for r in result.runs:
            s = described.get(r.label)
            if _is_sample(s):
                continue
            extra = getattr(r, "surrogate_scalars", None) or {}
            got = None if output in extra else _surrogate_draws(result, r, output)
            if output in extra:
                draws[r.label] = np.asarray(extra[output])[:, c]
            elif got is not None and got.shape[0] > 1 and np.ptp(got[:, c]) > 0:
                draws[r.label] = got[:, c]
            elif s is not None:
                mean, std, skew, _ = (float(m.value[c]) for m in s.moments)
                dist = _moment_density(mean, std, skew)
                if dist is not None:
                    densities[r.label] = dist
        pooled = list(samples.values()) + list(draws.values())
        if pooled:
            lo, hi, outside = _plot_range(pooled)
        else:
            pts = [d.ppf([0.001, 0.999]) for d in densities.values()]
            lo, hi, outside = (float(np.min(pts)), float(np.max(pts)), 0) if pts else (0, 1, 0)
        ref = result.reference if result.reference in samples else \
            max(samples, key=lambda lab: samples[lab].size, default=None)
        xs = np.linspace(lo, hi, 400)
        for r, s, st in _described_runs(result, output):
            mean, std, skew, kurt = (float(m.value[c]) for m in s.moments)
            text = _stats_text(mean, std, skew, kurt, s.moments_method == "sample", s.n_used)
            if r.label in samples and np.ptp(samples[r.label]) == 0:
                # One run, or runs that all agree: a histogram of one value says nothing.
                ax.axvline(samples[r.label][0], color=st["color"], lw=st["lw"], ls=st["ls"],
                           label=f"{method_label(r)}: single value "
                                 f"{samples[r.label][0]:.4g} (no spread)")
            elif r.label in samples:
                y = samples[r.label]
                bins = _bins(y, lo, hi)
                if r.label == ref:
                    ax.hist(y, bins=bins, density=True, color=st["color"], alpha=0.25)
                ax.hist(y, bins=bins, density=True, histtype="step", color=st["color"],
                        lw=st["lw"], label=f"{method_label(r)} histogram: {text}")
            elif r.label in draws:
                ax.plot(xs, _kde(draws[r.label], xs), color=st["color"], ls=st["ls"], lw=2.0,
                        label=f"{method_label(r)} surrogate density (KDE of "
                              f"{draws[r.label].size:,} draws): {text}")
            elif r.label in densities:
                ax.plot(xs, densities[r.label].pdf(xs), color=st["color"], ls=st["ls"], lw=2.0,
                        label=f"{method_label(r)}*: {text}")
                notes.add("* density implied by the PCE's mean, std and skewness (Pearson III); "
                          "the result holds no surrogate")
        ax.set(xlabel=f"{name} {u}", ylabel=f"probability density [1/{o.unit}]"
               if o.unit not in ("", "1", "-") else "probability density [-]",
               title=name if k > 1 else None, xlim=(lo, hi))
        ax.grid(True, alpha=0.3)
        if samples and not draws and not densities and \
                all(np.ptp(y) == 0 for y in samples.values()):
            ax.set(ylabel="single value (no spread)", yticks=[])
        if outside:
            ax.text(0.99, 0.97, f"{outside} samples outside the axis\n(0.1-99.9% quantiles shown)",
                    transform=ax.transAxes, ha="right", va="top", fontsize=8, color="dimgrey")
    for ax in axes[k:]:
        ax.set_visible(False)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.suptitle(f"{result.name}: distribution of {o.name} {u}\n"
                 f"{textwrap.fill(o.description, int(10 * width))}", fontsize=12)
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncol=1, fontsize=9,
                   title="; ".join(sorted(notes)) or None, title_fontsize=8)
    return fig


# ---------------------------------------------------------------------------- cost
def cost_figure(result: Result) -> Figure:
    """Model runs and wall seconds per method (log scales), above the cost table."""
    df = cost_table(result)
    labels = [method_label(r) for r in result.runs]
    n = len(labels)
    fig = new_figure((11.0, 3.2 + 0.45 * n + 0.35 * n), layout="constrained")
    gs = fig.add_gridspec(2, 2, height_ratios=[1.0 + 0.35 * n, 0.4 + 0.3 * n])
    ax_runs, ax_time = fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[0, 1], sharey=None)
    ax_tab = fig.add_subplot(gs[1, :])
    ypos = np.arange(n)[::-1]
    runs = df["runs"].to_numpy(dtype=float)
    colours = [_styles(result)[r.label]["color"] for r in result.runs]
    ax_runs.barh(ypos, runs, color=colours, alpha=0.8)
    for y, v in zip(ypos, runs):
        ax_runs.text(v, y, f" {int(v)}", va="center", fontsize=9)
    ax_runs.set(xscale="log", xlabel="model runs [-]", title="Model runs",
                yticks=ypos, yticklabels=labels, xlim=(0.8, runs.max() * 8))
    model_s = df["model_s"].to_numpy(dtype=float)
    fit_s = df["fit_s"].to_numpy(dtype=float)
    h = 0.38
    for seconds, shift, colour, what in ((model_s, h / 2, "#4c72b0", "model runs"),
                                         (fit_s, -h / 2, "#dd8452", "fitting / statistics")):
        ax_time.barh(ypos + shift, np.maximum(seconds, 1e-4), height=h, color=colour, label=what)
        for y, v in zip(ypos, seconds):
            ax_time.text(max(v, 1e-4), y + shift, f" {v:.3g}", va="center", fontsize=8)
    top = max(float(np.max(model_s)), float(np.max(fit_s)), 1e-3)
    ax_time.set(xscale="log", xlabel="wall time [s]", title="Wall time", yticks=ypos,
                yticklabels=[r.label for r in result.runs], xlim=(1e-4, top * 20))
    # Below the axis: inside it, the legend would cover the labels of the longest bars.
    ax_time.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.2), ncol=2,
                   frameon=False)
    for ax in (ax_runs, ax_time):
        ax.grid(True, axis="x", alpha=0.3)
    ax_tab.axis("off")
    cells = [[_cell(v) for v in row] for row in df.itertuples(index=False)]
    tab = ax_tab.table(cellText=cells, colLabels=[str(c) for c in df.columns], loc="center",
                       cellLoc="center")
    tab.auto_set_font_size(False)
    tab.set_fontsize(9)
    tab.auto_set_column_width(list(range(len(df.columns))))
    tab.scale(1.0, 1.4)
    fig.suptitle(f"{result.name}: cost of each method (model {result.model}; model_s, fit_s: "
                 f"wall seconds)", fontsize=12)
    return fig


def _cell(v: object) -> str:
    if isinstance(v, float):
        return f"{v:.4g}" if np.isfinite(v) else ""
    return str(v)


# ---------------------------------------------------------------------------- files
def _safe(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_")


def write_figures(result: Result, out_dir: str | Path, dpi: int = DPI) -> list[FigureFile]:
    """Write every figure of ``result`` as PNG into ``out_dir``.

    Files: ``<name>_<output>[_<component>].png`` per series output component,
    ``<name>_<output>_hist.png`` per scalar output, ``<name>_cost.png``; with quantiles also
    ``<name>_<output>[_<component>]_envelope.png``; with Sobol' indices of a series also
    ``<name>_<output>[_<component>]_budget.png`` (:mod:`uqguide.report.budget_plot`).
    Each is written whole or not at all; ``out_dir`` is made when missing.
    """
    out = Path(out_dir)
    atomic.make_folder(out)
    stem = _safe(result.name)
    files = []
    # per series component: (file suffix, kind, whether the result has it, the figure)
    per_step = (("", "series", lambda name: True, series_figure),
                ("_envelope", "envelope", partial(has_quantiles, result), envelope_figure),
                ("_budget", "budget", partial(has_budget, result), budget_figure))
    for o in result.outputs:
        if not _of(result, o.name):
            continue
        if o.kind == "series" and result.time.size:
            for c, comp in enumerate(o.components):
                base = f"{stem}_{_safe(o.name)}{'_' + _safe(comp) if comp else ''}"
                for suffix, kind, shown, figure in per_step:
                    if shown(o.name):
                        path = out / f"{base}{suffix}.png"
                        save(figure(result, o.name, c), path, dpi=dpi)
                        files.append(FigureFile(path, kind, o.name, comp))
        elif o.kind == "scalar":
            path = out / f"{stem}_{_safe(o.name)}_hist.png"
            save(scalar_figure(result, o.name), path, dpi=dpi)
            files.append(FigureFile(path, "scalar", o.name))
    path = out / f"{stem}_cost.png"
    save(cost_figure(result), path, dpi=dpi)
    files.append(FigureFile(path, "cost"))
    log.info("wrote %d figures into %s", len(files), out)
    return files
