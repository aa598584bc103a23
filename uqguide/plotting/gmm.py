"""Figures of the GMM proximity comparison (Wang et al. 2022, Figs. 4 and 5).

- ``gmm_trajectories.png`` (Fig. 4): the three controllers' paths around the chief's boxes: a
  3-D view, the LVLH x-y plane, and two magnified regions (the part the paths come closest to,
  and the goal next to the -x antenna), with collisions marked;
- ``gmm_delta_v.png`` (Fig. 5): accumulated delta-v over time.

Paths are the sampled states at every control period (1 s), one colour per controller; a path
that crossed a part (swept test) is drawn dashed and the parts it hit are listed in the legend.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from mpl_toolkits.mplot3d.art3d import Poly3DCollection  # noqa: E402

if TYPE_CHECKING:
    from ..models.gmm.geometry import ChiefGeometry, Part
    from ..models.gmm.sampled_sim import SampledRun

COLORS = {"APF-TSMC": "tab:red", "GMM-TSMC": "tab:blue", "GMM-NTSMC": "tab:green"}
PART_COLORS = {"solid": "0.55", "plate": "tab:cyan", "segment": "k"}


def _box_faces(lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """The non-degenerate faces of a box as (4, 3) corner arrays."""
    faces = []
    for a in range(3):
        b, c = [k for k in range(3) if k != a]
        if lo[b] == hi[b] or lo[c] == hi[c]:
            continue
        for v in {lo[a], hi[a]}:
            quad = np.empty((4, 3))
            quad[:, a] = v
            quad[:, b] = [lo[b], hi[b], hi[b], lo[b]]
            quad[:, c] = [lo[c], lo[c], hi[c], hi[c]]
            faces.append(quad)
    return faces


def _draw_part_3d(ax, part: Part) -> None:
    lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
    if part.kind == "segment":
        ax.plot(*np.stack([lo, hi]).T, color=PART_COLORS["segment"], lw=3)
        return
    alpha = 0.25 if part.kind == "solid" else 0.45
    ax.add_collection3d(Poly3DCollection(_box_faces(lo, hi), facecolor=PART_COLORS[part.kind],
                                         edgecolor="0.3", lw=0.5, alpha=alpha))


def _draw_part_xy(ax, part: Part) -> None:
    lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
    if part.kind == "solid":
        ax.add_patch(plt.Rectangle(lo[:2], *(hi - lo)[:2], facecolor="0.85", edgecolor="0.3"))
    else:
        ax.plot([lo[0], hi[0]], [lo[1], hi[1]], color=PART_COLORS[part.kind],
                lw=4 if part.kind == "plate" else 2.5, solid_capstyle="butt")


_AXIS = "xyz"


def _cross_section(ax, geometry: ChiefGeometry, k: int, runs: dict[str, SampledRun]) -> None:
    """Paths near part ``k`` projected along the part's longest axis, with its collision box."""
    part = geometry.parts[k]
    lo, hi = np.asarray(part.lo, float), np.asarray(part.hi, float)
    a = int(np.argmax(hi - lo))
    b, c = [i for i in range(3) if i != a]
    clo, chi = geometry.collision_lo[k], geometry.collision_hi[k]
    ax.add_patch(plt.Rectangle((clo[b], clo[c]), chi[b] - clo[b], chi[c] - clo[c],
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
                      out_dir: str, filename: str = "gmm_trajectories.png") -> str:
    """Fig. 4: paths of the controllers around the chief; returns the PNG's path.

    Parameters
    ----------
    runs : dict of str to SampledRun
        One single-sample run per controller (display name -> run).
    geometry : ChiefGeometry
    goal : ndarray, shape (3,)
        Goal position [m].
    out_dir : str
    """
    os.makedirs(out_dir, exist_ok=True)
    fig = plt.figure(figsize=(13, 10))
    ax3 = fig.add_subplot(2, 2, 1, projection="3d")
    axes = [fig.add_subplot(2, 2, k) for k in (2, 3, 4)]
    for part in geometry.parts:
        _draw_part_3d(ax3, part)
        for ax in (axes[0], axes[2]):
            _draw_part_xy(ax, part)
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
    path = os.path.join(out_dir, filename)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_delta_v(runs: dict[str, SampledRun], out_dir: str, filename: str = "gmm_delta_v.png") -> str:
    """Fig. 5: accumulated delta-v ([W 24]) of each controller over time; returns the path."""
    os.makedirs(out_dir, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for name, run in runs.items():
        ax.plot(run.time, run.delta_v_history[0], color=COLORS.get(name),
                label=f"{name}: {run.delta_v[0]:.3f} m/s")
    ax.set(xlabel="time (s)", ylabel="accumulated delta-v (m/s)", title="Total velocity change")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    path = os.path.join(out_dir, filename)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
