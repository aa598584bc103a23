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

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...report.figures import colormap, new_figure, save
from ...models.dynamics.rotating_body_frame import spin_attitude
from ...models.gmm_ftc.target import target_geometry
from ..chief_drawing import draw_chief_3d, draw_chief_xy
from .report import nominal_runs

if TYPE_CHECKING:
    from ...models.gmm_ftc.model import GMMFTC

SNAPSHOT_DT = 30.0
"""Seconds between the target attitude snapshots of the LVLH figure."""


def body_trajectory_figure(model: GMMFTC, path: Path) -> Path:
    """[C] Fig 6: the approach in the body frame, 3-D and x-y projection."""
    clean, _ = nominal_runs(model)
    r = clean.r[0]
    geom = target_geometry(model.params.panel_half_thickness, model.params.antenna_half_width)
    fig = new_figure((12, 5.5))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    draw_chief_3d(ax, geom)
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
    draw_chief_xy(ax2, geom)
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
    return save(fig, path, dpi=120)


def lvlh_trajectory_figure(model: GMMFTC, path: Path) -> Path:
    """[C] Fig 12: the path in LVLH (x-y) with the target's attitude over time."""
    p = model.params
    clean, _ = nominal_runs(model)
    t = clean.time
    r_l = clean.r_l[0]
    geom = target_geometry(p.panel_half_thickness, p.antenna_half_width)
    w = np.asarray([p.spin_rate])
    goals = np.array([spin_attitude(w, ts)[0] @ clean.goal for ts in t])
    fig = new_figure((13, 6.2))
    axes = fig.subplots(1, 2)
    cmap = colormap("viridis")
    for ax, (t0, t1) in zip(axes, ((0.0, p.t_check), (p.t_check, t[-1]))):
        sel = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
        snaps = np.arange(t0, t1 + 1e-9, SNAPSHOT_DT)
        ax.plot(goals[sel, 0], goals[sel, 1], color="tab:green", lw=1, ls="--",
                label="desired position (moves with the target)")
        ax.plot(r_l[sel, 0], r_l[sel, 1], color="tab:red", lw=1.5, label="servicer path")
        for ts in snaps:
            c = cmap((ts - t0) / max(t1 - t0, 1e-9))
            draw_chief_xy(ax, geom, spin_attitude(w, ts)[0], color=c)
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
    return save(fig, path, dpi=120)


def time_history_figure(model: GMMFTC, path: Path) -> Path:
    """[C] Figs 7-11: errors, velocity and control in the body frame; position and thrust in
    LVLH."""
    p = model.params
    clean, _ = nominal_runs(model)
    t = clean.time
    e = clean.r[0] - clean.goal
    fig = new_figure((12, 10))
    axes = fig.subplots(3, 2, sharex=True)
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
    return save(fig, path, dpi=110)


def nominal_figures(model: GMMFTC, out_dir: Path) -> list[Path]:
    """Write the three nominal figures into ``out_dir``; return their paths."""
    return [
        body_trajectory_figure(model, out_dir / "gmm_ftc_body_trajectory.png"),
        lvlh_trajectory_figure(model, out_dir / "gmm_ftc_lvlh_trajectory.png"),
        time_history_figure(model, out_dir / "gmm_ftc_time_histories.png"),
    ]
