"""FTCAPN figures: the nominal run as in the paper's Figures 3-5, and one replayed sample's path."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...report.figures import new_figure, save
from ...core.types import ModelOutput

if TYPE_CHECKING:
    from ...models.ftcapn.model import FTCAPN


def nominal_figures(model: FTCAPN, out_dir: Path) -> list[Path]:
    """LOS rate, range and relative speed of the nominal run against time (paper Figures 3-5),
    written as PNG files into ``out_dir``; returns their paths."""
    out = model.nominal(frozenset(["omega_s", "R", "speed", "t_stop"]))
    t_stop = float(out.scalars["t_stop"][0, 0])
    keep = out.time <= t_stop + model.params.dt
    paths = []
    for name, label, fig_no in (("omega_s", "LOS rate omega_s [rad/s]", 3),
                                ("speed", "relative speed [m/s]", 4),
                                ("R", "range R [m]", 5)):
        fig = new_figure((6, 4))
        ax = fig.add_subplot()
        ax.plot(out.time[keep], out.series[name][0, keep, 0])
        ax.set_xlabel("time [s]")
        ax.set_ylabel(label)
        ax.set_title(f"FTCAPN nominal run (paper Figure {fig_no}); stop at {t_stop:.1f} s")
        ax.grid(True, alpha=0.3)
        paths.append(save(fig, out_dir / f"ftcapn_nominal_{name}.png", dpi=100,
                          bbox_inches="tight"))
    return paths


def sample_figures(model: FTCAPN, out: ModelOutput, values: Mapping[str, float], out_dir: Path,
                   stem: str) -> list[Path]:
    """One replayed sample: the chaser's path relative to the target (``-r``, Table-2 axes; 3-D
    and two planes), and its range and LOS rate against time, with the stop marked."""
    r = -out.series["r"][0]  # chaser relative to target
    t = out.time
    t_stop = float(out.scalars["t_stop"][0, 0])
    fig = new_figure((12, 8), layout="constrained")
    ax3 = fig.add_subplot(2, 2, 1, projection="3d")
    ax3.plot(*r.T, lw=1.4)
    ax3.scatter([0], [0], [0], c="m", marker="*", s=80)
    ax3.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]",
            title="chaser relative to target (target at the star)")
    ax_xz = fig.add_subplot(2, 2, 2)
    ax_xz.plot(r[:, 0], r[:, 2], lw=1.4)
    ax_xz.scatter([0], [0], c="m", marker="*", s=80)
    ax_xz.set(xlabel="x [m]", ylabel="z [m]", title="x-z plane")
    ax_xz.set_aspect("equal", adjustable="datalim")
    ax_r = fig.add_subplot(2, 2, 3)
    ax_r.semilogy(t, out.series["R"][0, :, 0])
    ax_r.set(xlabel="time [s]", ylabel="range R [m]")
    ax_w = fig.add_subplot(2, 2, 4)
    ax_w.plot(t, out.series["omega_s"][0, :, 0])
    ax_w.set(xlabel="time [s]", ylabel="LOS rate omega_s [rad/s]")
    for ax in (ax_xz, ax_r, ax_w):
        ax.grid(True, alpha=0.3)
    for ax in (ax_r, ax_w):
        if np.isfinite(t_stop):
            ax.axvline(t_stop, color="grey", ls=":", label=f"stop {t_stop:.2f} s")
            ax.legend(fontsize=8)
    zem = float(out.scalars["zem"][0, 0])
    fig.suptitle(f"FTCAPN sample {stem}: zem {zem:.4g} m, maneuver frame "
                 f"{getattr(model.params, 'maneuver_frame', 'initial')}")
    return [save(fig, out_dir / f"{stem}_trajectory.png", dpi=100)]
