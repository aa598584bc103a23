"""Figures of the GMM-FTC nominal scenario ([C] section 4.2), from the noise-free run.

- ``gmm_ftc_body_trajectory.png`` ([C] Fig 6): the approach in the target's body frame, 3-D
  with the target's parts and in the x-y plane;
- ``gmm_ftc_lvlh_trajectory.png`` ([C] Fig 12): the same path in LVLH (x-y plane) with the
  target's attitude (panels, and one antenna in red as in the paper) every ``SNAPSHOT_DT``
  seconds and the goal moving with the target;
- ``gmm_ftc_time_histories.png`` ([C] Figs 7-9, 10-11): body-frame position error (linear and
  log), velocity, control, and the LVLH position and thrust.
"""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from ..models.gmm.geometry import ChiefGeometry  # noqa: E402

if TYPE_CHECKING:
    from ..models.gmm_ftc.model import GMMFTC

SNAPSHOT_DT = 30.0
"""Seconds between the target attitude snapshots of the LVLH figure."""

PART_COLORS = {"solid": "0.35", "plate": "tab:blue", "segment": "tab:orange"}


def _box_edges(lo: np.ndarray, hi: np.ndarray) -> list[np.ndarray]:
    """The 12 edges (each (2, 3)) of an axis-aligned box (degenerate boxes give repeats)."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    edges = []
    for i in range(8):
        for j in range(i + 1, 8):
            if np.sum(corners[i] != corners[j]) == 1:
                edges.append(corners[[i, j]])
    return edges


def _draw_parts_3d(ax, geometry: ChiefGeometry) -> None:
    for part in geometry.parts:
        lo, hi = np.asarray(part.lo), np.asarray(part.hi)
        for e in _box_edges(lo, hi):
            ax.plot(e[:, 0], e[:, 1], e[:, 2], color=PART_COLORS[part.kind],
                    lw=2.5 if part.kind == "segment" else 1.0)


def _part_outline_xy(part) -> np.ndarray:
    """Closed x-y outline (m, 2) of a part's projection."""
    lo, hi = np.asarray(part.lo), np.asarray(part.hi)
    return np.array([[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]],
                     [lo[0], lo[1]]])


def _draw_parts_xy(ax, geometry: ChiefGeometry, C: np.ndarray | None = None,
                   color: str | tuple | None = None, antenna_red: bool = False) -> None:
    """Parts projected on the x-y plane, rotated by ``C`` (body -> LVLH, (3, 3)) if given.

    ``color`` overrides the per-kind colours (snapshots coloured by time)."""
    for part in geometry.parts:
        xy = _part_outline_xy(part)
        if C is not None:
            xy = (np.c_[xy, np.zeros(len(xy))] @ C.T)[:, :2]
        c = PART_COLORS[part.kind] if color is None else color
        if antenna_red and part.name == "antenna+y":
            c = "red"
        ax.plot(xy[:, 0], xy[:, 1], color=c, lw=2.0 if part.kind == "segment" else 1.0)


def body_trajectory_figure(model: GMMFTC, path: str) -> str:
    """[C] Fig 6: the approach in the body frame, 3-D and x-y projection."""
    from ..models.gmm_ftc.report import nominal_runs
    from ..models.gmm_ftc.target import target_geometry

    clean, _ = nominal_runs(model)
    r = clean.r[0]
    geom = target_geometry(model.params.panel_half_thickness, model.params.antenna_half_width)
    fig = plt.figure(figsize=(12, 5.5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    _draw_parts_3d(ax, geom)
    ax.plot(r[:, 0], r[:, 1], r[:, 2], color="tab:red", lw=1.5, label="servicer path")
    ax.scatter(*r[0], color="tab:blue", s=40, label="initial position")
    ax.scatter(*clean.goal, color="red", s=40, marker="*", label="desired position")
    ax.set_xlabel("x_b [m]")
    ax.set_ylabel("y_b [m]")
    ax.set_zlabel("z_b [m]")
    lims = [(min(-7.5, r[:, i].min() - 0.5), max(7.5, r[:, i].max() + 0.5)) for i in range(2)]
    lims.append((-3.0, 3.0))
    ax.set_xlim(*lims[0])
    ax.set_ylim(*lims[1])
    ax.set_zlim(*lims[2])
    ax.set_box_aspect([hi - lo for lo, hi in lims])  # equal scales: the cube looks a cube
    ax.set_title("(a) trajectory in the target body frame")
    ax.legend(loc="upper left", fontsize=8)
    ax2 = fig.add_subplot(1, 2, 2)
    _draw_parts_xy(ax2, geom)
    ax2.plot(r[:, 0], r[:, 1], color="tab:red", lw=1.5)
    ax2.plot(*r[0, :2], "o", color="tab:blue")
    ax2.plot(*clean.goal[:2], "*", color="red", ms=12)
    ax2.set_aspect("equal")
    ax2.set_xlabel("x_b [m]")
    ax2.set_ylabel("y_b [m]")
    ax2.grid(alpha=0.3)
    ax2.set_title("(b) projection on the x-O-y plane")
    fig.suptitle(f"GMM-FTC approach to the spinning target (w = {model.params.spin_rate} rad/s, "
                 f"noise-free), min clearance {clean.scalars['min_clearance'][0]:.2f} m")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def lvlh_trajectory_figure(model: GMMFTC, path: str) -> str:
    """[C] Fig 12: the path in LVLH (x-y) with the target's attitude over time."""
    from ..models.dynamics.rotating_body_frame import spin_attitude
    from ..models.gmm_ftc.report import nominal_runs
    from ..models.gmm_ftc.target import target_geometry

    p = model.params
    clean, _ = nominal_runs(model)
    t = clean.time
    r_l = clean.r_l[0]
    geom = target_geometry(p.panel_half_thickness, p.antenna_half_width)
    w = np.asarray([p.spin_rate])
    goals = np.array([spin_attitude(w, ts)[0] @ clean.goal for ts in t])
    fig, axes = plt.subplots(1, 2, figsize=(13, 6.2))
    cmap = plt.get_cmap("viridis")
    for ax, (t0, t1) in zip(axes, ((0.0, p.t_check), (p.t_check, t[-1]))):
        sel = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
        snaps = np.arange(t0, t1 + 1e-9, SNAPSHOT_DT)
        ax.plot(goals[sel, 0], goals[sel, 1], color="tab:green", lw=1, ls="--",
                label="desired position (moves with the target)")
        ax.plot(r_l[sel, 0], r_l[sel, 1], color="tab:red", lw=1.5, label="servicer path")
        for ts in snaps:
            c = cmap((ts - t0) / max(t1 - t0, 1e-9))
            _draw_parts_xy(ax, geom, spin_attitude(w, ts)[0], color=c, antenna_red=False)
            i = int(np.argmin(np.abs(t - ts)))
            ax.plot(*r_l[i, :2], "o", color=c, mec="k", ms=6)
            ax.annotate(f"{ts:g} s", r_l[i, :2], textcoords="offset points", xytext=(5, 5),
                        fontsize=7)
        if t0 == 0.0:
            ax.plot(*r_l[0, :2], "o", color="tab:blue", ms=8, label="initial position")
        ax.set_aspect("equal")
        ax.set_xlabel("x_l (radial) [m]")
        ax.set_ylabel("y_l (along-track) [m]")
        ax.grid(alpha=0.3)
        ax.set_title(f"{t0:g}-{t1:g} s: target and servicer every {SNAPSHOT_DT:g} s "
                     "(same colour = same time)", fontsize=10)
        ax.legend(loc="lower left", fontsize=8)
    fig.suptitle("GMM-FTC in LVLH: the servicer follows the target's counter-clockwise spin")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def time_history_figure(model: GMMFTC, path: str) -> str:
    """[C] Figs 7-11: errors, velocity and control in the body frame; position and thrust in
    LVLH."""
    from ..models.gmm_ftc.report import nominal_runs

    p = model.params
    clean, _ = nominal_runs(model)
    t = clean.time
    e = clean.r[0] - clean.goal
    fig, axes = plt.subplots(3, 2, figsize=(12, 10), sharex=True)
    comps = ("x", "y", "z")
    panels = [
        (axes[0, 0], e, "position error r - r_f [m] (Fig 7)"),
        (axes[1, 0], clean.v[0], "velocity r' [m/s] (Fig 8)"),
        (axes[2, 0], clean.u[0], "control u, body [m/s^2] (Fig 9)"),
        (axes[1, 1], clean.r_l[0], "position in LVLH [m] (Fig 10)"),
        (axes[2, 1], clean.u_l[0], "thrust C u in LVLH [m/s^2] (cf. Fig 11)"),
    ]
    for ax, y, title in panels:
        for i, c in enumerate(comps):
            ax.plot(t, y[:, i], label=c)
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
        ax.axvline(p.t_check, color="0.5", ls=":", lw=1)
        ax.legend(fontsize=8)
    for ax in axes[2]:  # the t = 0 command (s2(0) ~ 13 m/s) would flatten the rest
        ax.set_ylim(-0.08, 0.08)
        ax.text(0.98, 0.05, f"|u(0)| = {np.linalg.norm(clean.u[0, 0]):.3f} m/s^2 (off scale)",
                ha="right", transform=ax.transAxes, fontsize=8)
    ax = axes[0, 1]
    ax.semilogy(t, np.maximum(np.linalg.norm(e, axis=1), 1e-14), label="|r - r_f| [m]")
    ax.semilogy(t, np.maximum(np.linalg.norm(clean.v[0], axis=1), 1e-14), label="|r'| [m/s]")
    ax.semilogy(t, np.maximum(clean.s2[0], 1e-14), label="|s2| [m/s]")
    ax.axhline(p.converge_tol, color="k", ls="--", lw=1, label=f"{p.converge_tol:g}")
    ax.axvline(clean.scalars["t_converge"][0], color="tab:red", ls=":", lw=1,
               label=f"t_converge = {clean.scalars['t_converge'][0]:.1f} s")
    ax.set_ylim(1e-12, 1e2)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title("convergence (log scale)", fontsize=10)
    for ax in axes[2]:
        ax.set_xlabel("t [s]")
    fig.suptitle("GMM-FTC nominal run (noise-free)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def nominal_figures(model: GMMFTC, out_dir: str) -> list[str]:
    """Write the three nominal figures into ``out_dir``; return their paths."""
    os.makedirs(out_dir, exist_ok=True)
    return [
        body_trajectory_figure(model, os.path.join(out_dir, "gmm_ftc_body_trajectory.png")),
        lvlh_trajectory_figure(model, os.path.join(out_dir, "gmm_ftc_lvlh_trajectory.png")),
        time_history_figure(model, os.path.join(out_dir, "gmm_ftc_time_histories.png")),
    ]
