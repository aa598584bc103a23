"""The nominal [C] scenario beside the paper (``uqguide simulate``; claims C1-C7).

Two runs of the configured scenario: noise-free (the deterministic reference, recorded at every
control step for the figures), and with the configured per-period thruster error
(``thrust_noise``) for ``N_NOISE_SEEDS`` keyed noise streams in one batch, for every one of
which claim C1 must hold. The paper's figures are [C] section 4.2's bounds; the amplitude claims
C3/C4 hold only after the initial transient, so the report shows the full-run maxima as misses
with the time after which they hold
(docs/papers.md#gmm-controllers-what-reproduces-and-what-does-not).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from ...models.gmm_ftc import noise
from ...models.gmm_ftc.loop import LoopRun
from ...models.gmm_ftc.law import fixed_time_bound
from ...models.gmm_ftc.target import target_geometry
from ..cache import per_model
from ..rows import ReportRow

if TYPE_CHECKING:
    from ...models.gmm_ftc.model import GMMFTC

N_NOISE_SEEDS = 16
"""Noise realisations of the nominal report."""


@per_model
def nominal_runs(model: GMMFTC) -> tuple[LoopRun, LoopRun | None]:
    """The noise-free run (every step recorded) and the noisy batch (``None`` without noise).

    Cached per model: ``simulate`` asks for the report and the figures of the same runs.
    """
    values = model.nominal_values(1)
    fine = replace(model.settings(thrust_noise=0.0), record_every=1)
    clean = model.simulate(values, 1, settings=fine)
    noisy = None
    if model.params.thrust_noise > 0:
        seeds = model.params.noise_seed + np.arange(N_NOISE_SEEDS)
        rep = {k: np.repeat(v, N_NOISE_SEEDS) for k, v in values.items()}
        noisy = model.simulate(rep, N_NOISE_SEEDS, noise_keys=noise.seed_keys(seeds))
    return clean, noisy


def _collisions(run: LoopRun, names: tuple[str, ...]) -> str:
    hits = np.asarray(run.scalars["hits"], dtype=bool)  # (n, parts)
    hit = [bool(hits[:, k].any()) for k in range(hits.shape[1])]
    return "none" if not any(hit) else ", ".join(n for n, h in zip(names, hit) if h)


def nominal_report(model: GMMFTC) -> list[ReportRow]:
    """Claims C1-C7, the eq (36) bound and delta-v beside the paper's figures."""
    p = model.params
    clean, noisy = nominal_runs(model)
    sc = {k: np.asarray(v)[0] for k, v in clean.scalars.items()}
    names = target_geometry().names
    t_chk = f"t >= {p.t_check:g} s"
    bound, tight = (fixed_time_bound(np.asarray(p.lambda1), np.asarray(p.lambda2), p.zeta1,
                                     p.zeta2, tight=t) for t in (False, True))
    w = np.asarray(p.spin_rate)
    rf = np.asarray(p.r_f)
    rf_perp = np.linalg.norm(rf - np.dot(rf, w) * w / max(np.dot(w, w), 1e-300))
    u_eq = float(np.dot(w, w) * rf_perp)
    u_f = float(sc["u_final"])
    rows = [
        ReportRow("collision with any part (C5)", "-", _collisions(clean, names), "none",
                  "none", sc["collided"] == 0,
                  "swept segments, panels 0.02 m, antennas 0.05 m half-thickness (spec 4.2)"),
        ReportRow("min clearance to the target", "m", float(sc["min_clearance"]), None,
                  "> 0", bool(sc["min_clearance"] > 0),
                  "at the goal: 1.00 m to body and +x panel, 2.00 m to +y antenna (spec 11)"),
        ReportRow(f"time to converge, |e| < {p.converge_tol:g} m (C1)", "s",
                  float(sc["t_converge"]), 150.0, "<= 150 s",
                  bool(sc["converged"] == 1 and sc["t_converge"] <= p.t_check),
                  "spec 11 reference 113.3 s"),
        ReportRow(f"max |e| for {t_chk} (C1)", "m", float(sc["pos_error_final"]), 1e-4,
                  "< 1e-4 m", bool(sc["pos_error_final"] < p.converge_tol),
                  "spec 11 reference 4.6e-9 m noise-free"),
        ReportRow(f"max |v| for {t_chk} (C2)", "m/s", float(sc["speed_final"]), 1e-4,
                  "< 1e-4 m/s", bool(sc["speed_final"] < p.velocity_tol),
                  "spec 11 reference 5.6e-7 m/s"),
        ReportRow("max |v| during the approach (C3)", "m/s", float(sc["speed_max"]), 0.15,
                  "< 0.15 m/s", bool(sc["speed_max"] < 0.15),
                  "initial transient (spec 11: 0.2143 m/s at t = 2-5 s, per axis "
                  + "/".join(f"{a:.3f}" for a in sc["speed_max_axes"])
                  + f" m/s); below 0.15 m/s after {float(sc['t_speed_below']):.1f} s "
                  "(spec 22.1 s)"),
        ReportRow("max |u| (C4)", "m/s^2", float(sc["u_max"]), 0.06, "< 0.06 m/s^2",
                  bool(sc["u_max"] < 0.06),
                  f"at t = 0 (spec 11: 0.736 m/s^2); below 0.06 m/s^2 after "
                  f"{float(sc['t_u_below']):.1f} s (spec 1.4 s)"),
        ReportRow("max |u| after convergence (C4)", "m/s^2", float(sc["u_max_converged"]), 0.06,
                  "< 0.06 m/s^2", bool(sc["u_max_converged"] < 0.06)),
        ReportRow("|u| at t_final, station keeping (C6)", "m/s^2", u_f, u_eq, "10 %",
                  bool(abs(u_f - u_eq) <= 0.1 * u_eq),
                  "paper: constant set by u_eq; |w|^2 |r_f,perp| = "
                  f"{u_eq:.3g} m/s^2 (spec 11: 5.84e-3)"),
        ReportRow(f"spread of u for {t_chk} / |u(t_f)| (C6)", "-",
                  float(sc["u_spread_final"]) / u_f, None, "< 0.1",
                  bool(sc["u_spread_final"] < 0.1 * u_f)),
        ReportRow("time for |s2| < 1e-6 m/s (C7)", "s", float(sc["t_reach_s2"]), None,
                  f"<= eq 36 bound {bound:g} s", bool(sc["t_reach_s2"] <= bound),
                  "spec 11: 98.3 s"),
        ReportRow("fixed-time bound T_max, eq (36)", "s", bound, None, "informational", None,
                  f"2/(lambda1min (1-zeta1)) + 2/(lambda2min (zeta2-1)); the valid tighter "
                  f"bound (3-D power-mean factor) is {tight:.1f} s; s1 then decays only "
                  "exponentially"),
        ReportRow("delta-v", "m/s", float(sc["delta_v"]), None, "not published", None),
        ReportRow("range at t_final", "m", float(np.linalg.norm(clean.r[0, -1])),
                  float(np.linalg.norm(rf)), "1e-3 m",
                  bool(abs(np.linalg.norm(clean.r[0, -1]) - np.linalg.norm(rf)) < 1e-3)),
    ]
    if noisy is not None:
        ns = noisy.scalars
        tag = f"+-{100 * p.thrust_noise:g} % noise, {N_NOISE_SEEDS} seeds: "
        rows += [
            ReportRow(tag + "time to converge (C1)", "s",
                      f"{ns['t_converge'].min():.1f}-{ns['t_converge'].max():.1f}", 150.0,
                      "<= 150 s", bool(np.all(ns["converged"] == 1)
                                       and ns["t_converge"].max() <= p.t_check),
                      "spec 11: 112.3-114.4 s (other noise draws)"),
            ReportRow(tag + f"max |e| for {t_chk} (C1)", "m", float(ns["pos_error_final"].max()),
                      1e-4, "< 1e-4 m", bool(ns["pos_error_final"].max() < p.converge_tol),
                      "spec 11: 4.6e-5 - 8.5e-5 m"),
            ReportRow(tag + f"max |v| for {t_chk} (C2)", "m/s", float(ns["speed_final"].max()),
                      1e-4, "< 1e-4 m/s", bool(ns["speed_final"].max() < p.velocity_tol),
                      "spec 11: 5.6e-5 - 6.7e-5 m/s"),
            ReportRow(tag + "max |u| (C4)", "m/s^2",
                      f"{ns['u_max'].min():.3f}-{ns['u_max'].max():.3f}", 0.06, "< 0.06 m/s^2",
                      bool(ns["u_max"].max() < 0.06), "spec 11: 0.709-0.768 m/s^2"),
            ReportRow(tag + "collision (C5)", "-", _collisions(noisy, names), "none", "none",
                      bool(np.all(ns["collided"] == 0))),
        ]
    return rows
