"""Figures of the GMM proximity comparison (Wang et al. 2022, Figs. 4 and 5).

- ``gmm_trajectories.png`` (Fig. 4): the three controllers' paths around the chief's boxes: a
  3-D view, the LVLH x-y plane, and two magnified regions (the part the paths come closest to,
  and the goal next to the -x antenna), with collisions marked;
- ``gmm_delta_v.png`` (Fig. 5): accumulated delta-v over time.

Paths are the sampled states at every control period (1 s), one colour per controller; a path
that crossed a part (swept test) is drawn dashed and the parts it hit are listed in the legend.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib.patches import Rectangle

from ...report.figures import new_figure, save
from ...core.types import ModelOutput
from ..chief_drawing import PART_COLORS, draw_chief_3d, draw_chief_xy
from .report import CONTROLLER_LABEL, nominal_runs

if TYPE_CHECKING:
    from ...models.gmm.geometry import ChiefGeometry
    from ...models.gmm.model import GMMProximity
    from ...models.gmm.loop import SampledRun

COLORS = {"APF-TSMC": "tab:red", "GMM-TSMC": "tab:blue", "GMM-NTSMC": "tab:green"}


_AXIS = "xyz"


def _cross_section(ax, geometry: ChiefGeometry, k: int, runs: dict[str, SampledRun]) -> None:
    """Paths near part ``k`` projected along the part's longest axis, with its collision box."""
    part = geometry.parts[k]
    lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
    a = int(np.argmax(hi - lo))
    b, c = [i for i in range(3) if i != a]
    clo, chi = geometry.collision_lo[k], geometry.collision_hi[k]
    ax.add_patch(Rectangle((clo[b], clo[c]), chi[b] - clo[b], chi[c] - clo[c],
                           facecolor=PART_COLORS[part.kind], alpha=0.35, edgecolor="k",
                           label=None))
    ax.plot([lo[b], hi[b]], [lo[c], hi[c]], "k+-", lw=1, ms=10)  # zero-thickness skeleton
    centre = 0.5 * (lo + hi)
    for name, run in runs.items():
        r = run.r[0]
        near = (r[:, a] >= lo[a] - 0.5) & (r[:, a] <= hi[a] + 0.5)
        rr = np.where(near[:, None], r, np.nan)
        ax.plot(rr[:, b], rr[:, c], "--" if run.hits[0].any() else "-", color=COLORS.get(name))
    # zoom: twice the largest closest approach, at least the part's cross-section and 1.5 m
    closest = max(float(run.clearance[0, k]) for run in runs.values())
    half = max(1.5, 2 * closest, 0.6 * float(max(hi[b] - lo[b], hi[c] - lo[c])))
    ax.set(xlim=(centre[b] - half, centre[b] + half), ylim=(centre[c] - half, centre[c] + half),
           xlabel=f"{_AXIS[b]} (m)", ylabel=f"{_AXIS[c]} (m)")
    ax.set_aspect("equal")
    ax.text(0.02, 0.02, f"paths with {_AXIS[a]} in [{lo[a] - 0.5:g}, {hi[a] + 0.5:g}] m",
            transform=ax.transAxes, fontsize=8)


def _legend_label(name: str, geometry: ChiefGeometry, run: SampledRun) -> str:
    hit = [nm for nm, h in zip(geometry.names, run.hits[0]) if h]
    return f"{name}: dv {run.delta_v[0]:.3f} m/s" + (f", hits {', '.join(hit)}" if hit else "")


def plot_trajectories(runs: dict[str, SampledRun], geometry: ChiefGeometry, goal: np.ndarray,
                      out_dir: Path, filename: str = "gmm_trajectories.png") -> Path:
    """Fig. 4: paths of the controllers around the chief; returns the PNG's path.

    ``runs``: one single-sample run per controller (display name -> run); ``goal`` (3,) [m].
    """
    fig = new_figure((13, 10))
    ax3 = fig.add_subplot(2, 2, 1, projection="3d")
    axes = [fig.add_subplot(2, 2, k) for k in (2, 3, 4)]
    draw_chief_3d(ax3, geometry)
    for ax in (axes[0], axes[2]):
        draw_chief_xy(ax, geometry)
    start = next(iter(runs.values())).r[0, 0]
    for name, run in runs.items():
        r = run.r[0]
        style = "--" if run.hits[0].any() else "-"
        color = COLORS.get(name)
        ax3.plot(*r.T, style, color=color, lw=1.4)
        for ax in (axes[0], axes[2]):
            ax.plot(r[:, 0], r[:, 1], style, color=color, lw=1.4,
                    label=_legend_label(name, geometry, run) if ax is axes[0] else None)
    ax3.scatter(*np.stack([start, goal]).T, c=["k", "m"], marker="*", s=80)
    for ax in (axes[0], axes[2]):
        ax.scatter([start[0], goal[0]], [start[1], goal[1]], c=["k", "m"], marker="*", s=80,
                   zorder=5)
    ax3.set(xlabel="x (m)", ylabel="y (m)", zlabel="z (m)", title="(a) 3-D view (LVLH)")
    ax3.set_box_aspect((1, 1, 0.6))

    axes[0].set(xlabel="x radial (m)", ylabel="y along-track (m)", title="(b) LVLH x-y plane")
    axes[0].set_aspect("equal")

    # (c) the thin part the paths come closest to, seen along its longest axis (an antenna is
    # then a square, a panel a bar), with the path points abreast of the part
    clear = np.min([run.clearance[0] for run in runs.values()], axis=0)
    thin = [i for i, p in enumerate(geometry.parts) if p.kind != "solid"]
    k = thin[int(np.argmin(clear[thin]))]
    _cross_section(axes[1], geometry, k, runs)
    axes[1].set_title(f"(c) along {geometry.parts[k].name} (closest {clear[k]:.3f} m)")
    # (d) the goal on the -x face, next to the -x antenna
    axes[2].set(xlim=(goal[0] - 3.0, goal[0] + 1.5), ylim=(goal[1] - 2.25, goal[1] + 2.25),
                xlabel="x (m)", ylabel="y (m)", title="(d) around the goal")
    axes[2].set_aspect("equal")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(f"Deputy paths: {', '.join(runs)} (dashed: collided)")
    fig.legend(loc="lower center", ncol=len(runs), fontsize=9, frameon=False)
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    return save(fig, out_dir / filename, dpi=110)


def plot_delta_v(runs: dict[str, SampledRun], out_dir: Path,
                 filename: str = "gmm_delta_v.png") -> Path:
    """Fig. 5: accumulated delta-v ([W 24]) of each controller over time; returns the path."""
    fig = new_figure((7, 4.5))
    ax = fig.add_subplot()
    for name, run in runs.items():
        ax.plot(run.time, run.delta_v_history[0], color=COLORS.get(name),
                label=f"{name}: {run.delta_v[0]:.3f} m/s")
    ax.set(xlabel="time (s)", ylabel="accumulated delta-v (m/s)", title="Total velocity change")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    return save(fig, out_dir / filename, dpi=110)


def nominal_figures(model: GMMProximity, out_dir: Path) -> list[Path]:
    """The paper's Fig. 4 (trajectories around the chief) and Fig. 5 (delta-v over time)."""
    runs = nominal_runs(model, record_every=1)
    goal = np.asarray(model.params.r_f)
    return [plot_trajectories(runs, model.geometry(), goal, out_dir), plot_delta_v(runs, out_dir)]


def sample_figures(model: GMMProximity, out: ModelOutput, values: Mapping[str, float],
                   out_dir: Path, stem: str) -> list[Path]:
    """One replayed sample's path around the chief with its geometry (the layout of the
    paper's Fig. 4), recorded at every control step."""
    vals = {k: np.array([v], dtype=float) for k, v in values.items()}
    run = model.run(vals, 1, record_every=1)
    name = CONTROLLER_LABEL[model.params.controller]
    return [plot_trajectories({name: run}, model.geometry(), np.asarray(model.params.r_f),
                              out_dir, filename=f"{stem}_trajectory.png")]
