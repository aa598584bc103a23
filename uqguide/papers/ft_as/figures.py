"""Figures of the FT-AS nominal comparison (the paper's Figs 5-13).

FT-AS (the model's default FT-AS-A), Case 1 and Case 2 from one batch recorded every 0.1 s:

- ``ft_as_observer.png`` (Fig 5): FT-DO errors ``eps1``, ``eps2`` of FT-AS for t <= 60 s;
- ``ft_as_sliding.png`` (Figs 6-7): ``|s_1..3|`` and ``|s_4..6|``;
- ``ft_as_tracking.png`` (Figs 8-11): ``|r_e|``, ``|v_e|``, ``|sigma_e|``, ``|omega_e|`` with the
  paper's final-accuracy bounds;
- ``ft_as_force.png``, ``ft_as_torque.png`` (Figs 12-13): applied inputs per axis. The loop
  chatters at the sampling rate, so each curve is the min/max envelope over 0.1 s intervals
  (a decimated sample would alias).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ...report.figures import Figure, new_figure, save
from .report import PAPER_BOUNDS, nominal_runs

if TYPE_CHECKING:
    from ...models.ft_as import FTAS

COMPARED = ("FT-AS", "Case 1", "Case 2")
COLORS = {"FT-AS": "tab:red", "Case 1": "tab:blue", "Case 2": "tab:green"}
#: The paper's final accuracies per tracking panel (|r_e|, |v_e|: none, |sigma_e|, |omega_e|).
BOUNDS = {lab: (r, None, sigma, omega) for lab, (r, sigma, omega) in PAPER_BOUNDS.items()}


def _floor(x: np.ndarray) -> np.ndarray:
    # log axes: exact zeros (e.g. sign(0)) would vanish from the plot
    return np.maximum(x, 1e-14)


def nominal_figures(model: FTAS, out_dir: Path) -> list[Path]:
    """Write the five comparison figures of the nominal scenario; return their paths."""
    variants, res = nominal_runs(model)
    idx = {v.label: i for i, v in enumerate(variants)}
    t = res.time
    p = model.params
    subtitle = (
        f"h = {p.step:g} s, switch units: {p.switch_units}, Case 2 omega_chi = {p.omega_chi:g}"
    )
    paths = [
        _observer(res, idx["FT-AS"], t, out_dir, subtitle),
        _sliding(res, idx, t, out_dir, subtitle),
        _tracking(res, idx, t, out_dir, subtitle),
        _inputs(res, idx, t, out_dir, subtitle, "force", slice(0, 3), p.force_limit, "N"),
        _inputs(res, idx, t, out_dir, subtitle, "torque", slice(3, 6), p.torque_limit, "N m"),
    ]
    return paths


def _save(fig: Figure, out_dir: Path, name: str) -> Path:
    return save(fig, out_dir / name, dpi=110)


def _observer(res, i: int, t: np.ndarray, out_dir: Path, subtitle: str) -> Path:
    sel = t <= 60.0
    fig = new_figure((11, 7))
    axes = fig.subplots(2, 2, sharex=True)
    labels = (("x", "y", "z"), ("1", "2", "3"))
    rows = (("eps1", "eps_1 = psi_1 - e_2"), ("eps2", "eps_2 = psi_2 - d"))
    for row, (key, name) in enumerate(rows):
        for col, (sl, unit) in enumerate(((slice(0, 3), "m/s" if row == 0 else "m/s^2"),
                                          (slice(3, 6), "1/s" if row == 0 else "1/s^2"))):
            ax = axes[row, col]
            data = res.records[key][i][sel][:, sl]
            for k in range(3):
                ax.plot(t[sel], data[:, k], lw=1.0, label=f"{labels[col][k]}")
            ax.set_ylabel(f"{name} [{unit}]")
            ax.set_title(("translation" if col == 0 else "rotation (MRP)"), fontsize=9)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=8)
            t_in = res.settle["eps1"][i, 1]
            ax.axvline(t_in, color="k", ls=":", lw=0.8)
    for ax in axes[1]:
        ax.set_xlabel("t [s]")
    fig.suptitle(f"FT-DO estimation errors, FT-AS (paper Fig 5); dotted: |eps1| <= 1e-3 at "
                 f"{res.settle['eps1'][i, 1]:.2f} s\n{subtitle}", fontsize=10)  # fmt: skip
    fig.tight_layout()
    return _save(fig, out_dir, "ft_as_observer.png")


def _sliding(res, idx, t, out_dir, subtitle) -> Path:
    fig = new_figure((12, 4.5))
    axes = fig.subplots(1, 2)
    for ax, sl, title in ((axes[0], slice(0, 3), "|s_1..3| (position, paper Fig 6)"),
                          (axes[1], slice(3, 6), "|s_4..6| (attitude, paper Fig 7)")):  # fmt: skip
        for lab in COMPARED:
            s = np.linalg.norm(res.records["s"][idx[lab]][:, sl], axis=1)
            ax.semilogy(t, _floor(s), lw=0.9, color=COLORS[lab], label=lab)
        ax.axhline(1e-3, color="k", ls=":", lw=0.8)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    axes[1].set_xlim(0, 400)
    fig.suptitle(f"Sliding variables on the true errors\n{subtitle}", fontsize=10)
    fig.tight_layout()
    return _save(fig, out_dir, "ft_as_sliding.png")


def _tracking(res, idx, t, out_dir, subtitle) -> Path:
    fig = new_figure((12, 8))
    axes = fig.subplots(2, 2)
    spec = (
        ("r_e", "|r_e| [m]", "paper Fig 8", 0),
        ("v_e", "|v_e| [m/s]", "paper Fig 9", 1),
        ("sigma_e", "|sigma_e|", "paper Fig 10", 2),
        ("omega_e", "|omega_e| [rad/s]", "paper Fig 11", 3),
    )
    for ax, (key, ylabel, fig_no, b) in zip(axes.flat, spec):
        for lab in COMPARED:
            x = np.linalg.norm(res.records[key][idx[lab]], axis=1)
            ax.semilogy(t, _floor(x), lw=0.9, color=COLORS[lab], label=lab)
            bound = BOUNDS[lab][b]
            if bound is not None:
                ax.axhline(bound, color=COLORS[lab], ls=":", lw=0.8)
        ax.set_ylabel(ylabel)
        ax.set_xlabel("t [s]")
        ax.set_title(f"{fig_no}; dotted: paper's final accuracy", fontsize=9)
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.suptitle(f"Tracking errors\n{subtitle}", fontsize=10)
    fig.tight_layout()
    return _save(fig, out_dir, "ft_as_tracking.png")


def _inputs(res, idx, t, out_dir, subtitle, kind, sl, limit, unit) -> Path:
    fig = new_figure((13, 8))
    axes = fig.subplots(3, 2, sharex="col", gridspec_kw={"width_ratios": [1, 2]})
    lo, hi = res.records["u_applied_min"], res.records["u_applied_max"]
    peak = res.peak_applied[idx["Case 1"]][sl].max()
    # a log-like axis only where Case 1 leaves the limits by far (force: 3008 N vs 2 N)
    symlog = peak > 5 * limit
    for k in range(3):
        for col, t_end in enumerate((300.0, t[-1])):
            ax = axes[k, col]
            sel = t <= t_end
            for lab in COMPARED:
                i = idx[lab]
                ax.fill_between(t[sel], lo[i][sel, sl][:, k], hi[i][sel, sl][:, k],
                                color=COLORS[lab], alpha=0.45, lw=0.6, label=lab)  # fmt: skip
            for sgn in (-1, 1):
                ax.axhline(sgn * limit, color="k", ls="--", lw=0.8)
            if symlog:
                ax.set_yscale("symlog", linthresh=limit)
            ax.grid(alpha=0.3)
        axes[k, 0].set_ylabel(f"{kind} {'xyz'[k]} [{unit}]")
    axes[0, 0].set_title("first 300 s", fontsize=9)
    axes[0, 1].set_title("whole run", fontsize=9)
    axes[0, 1].legend(fontsize=8, loc="upper right")
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    fig_no = "12" if kind == "force" else "13"
    axis_note = "symlog axis; " if symlog else ""
    fig.suptitle(
        f"Applied {kind} (paper Fig {fig_no}), min/max over 0.1 s; dashed: +-{limit:g} {unit}; "
        f"{axis_note}Case 1 peak {peak:.3g} {unit}\n{subtitle}", fontsize=10,
    )  # fmt: skip
    fig.tight_layout()
    return _save(fig, out_dir, f"ft_as_{kind}.png")
