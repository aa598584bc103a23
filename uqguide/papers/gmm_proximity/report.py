"""The [W] nominal scenario beside the paper (``uqguide simulate``; claims W1-W10).

The three controllers run from the configured initial state; per controller the report gives
collision, clearances, delta-v (and its ratio to APF-TSMC's), final error, beside the paper's
statements, then claims W1-W10 with verdicts (:mod:`.claims`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..rows import ReportRow
from .claims import (
    APF, CONTROLLER_LABEL, DV_RATIO_TOLERANCE, GNT, GTS, WANG2022_DV_RATIO, Outcome,
    evaluate_wang2022_claims,
)

if TYPE_CHECKING:
    from ...models.gmm.model import GMMProximity
    from ...models.gmm.loop import SampledRun

__all__ = ["CONTROLLER_LABEL", "nominal_outcomes", "nominal_report", "nominal_runs"]


def nominal_runs(model: GMMProximity, record_every: int = 1) -> dict[str, SampledRun]:
    """The nominal run of each of the three controllers, keyed by display name, recording the
    state every ``record_every`` control periods."""
    vals = model.nominal_values()
    return {CONTROLLER_LABEL[c]: model.run(vals, 1, c, record_every=record_every)
            for c in ("apf_tsmc", "gmm_tsmc", "gmm_ntsmc")}


def nominal_outcomes(model: GMMProximity,
                     runs: dict[str, SampledRun] | None = None) -> dict[str, Outcome]:
    """The :class:`~.claims.Outcome` of each controller's nominal run (display name -> outcome),
    from ``runs`` of :func:`nominal_runs` when given."""
    runs = nominal_runs(model) if runs is None else runs
    names = model.geometry().names
    r_f = np.asarray(model.params.r_f)
    return {
        label: Outcome(
            hit_parts=tuple(nm for nm, h in zip(names, run.hits[0]) if h),
            clearance={nm: float(c) for nm, c in zip(names, run.clearance[0])},
            penetration=float(run.penetration[0]),
            delta_v=float(run.delta_v[0]),
            final_error=float(np.linalg.norm(run.r[0, -1] - r_f)),
        )
        for label, run in runs.items()
    }


def nominal_report(model: GMMProximity) -> list[ReportRow]:
    """Per controller: collision, clearances, delta-v (and its ratio to APF-TSMC's), final
    error, beside the paper's statements; then claims W1-W10 with verdicts."""
    out = nominal_outcomes(model)
    p = model.params
    rows: list[ReportRow] = []
    paper_collides = {APF: "yes (antenna)", GTS: "no", GNT: "no"}
    for label, o in out.items():
        hit = "yes: " + ", ".join(o.hit_parts) if o.collided else "no"
        as_paper = (any(h.startswith("antenna") for h in o.hit_parts) if label == APF
                    else not o.collided)
        rows.append(ReportRow(f"{label}: collision", "", hit, paper_collides[label],
                              "same verdict", as_paper,
                              "swept test; panel half-thickness "
                              f"{p.panel_half_thickness} m, antenna half-width "
                              f"{p.antenna_half_width} m"))
        rows.append(ReportRow(
            f"{label}: minimum clearance", "m",
            min(o.clearance_of("panel"), o.clearance_of("antenna")),
            note=f"to panels and antennas (zero thickness): antenna "
            f"{o.clearance_of('antenna'):.4f} m, panel {o.clearance_of('panel'):.4f} m; "
            f"body penetration {o.penetration:.3f} m"))
        rows.append(ReportRow(f"{label}: total delta-v", "m/s", o.delta_v,
                              note="Fig. 5 gives no number; eq (24)"))
        if label != APF:
            ratio = o.delta_v / out[APF].delta_v
            target = WANG2022_DV_RATIO[label]
            rows.append(ReportRow(f"{label}: delta-v / APF-TSMC delta-v", "", ratio, target,
                                  f"+-{DV_RATIO_TOLERANCE}",
                                  abs(ratio - target) <= DV_RATIO_TOLERANCE,
                                  '"reduce by" reading (A15)'))
        rows.append(ReportRow(f"{label}: final position error", "m", o.final_error,
                              "goal reached", f"< {p.reach_tolerance} m",
                              o.final_error < p.reach_tolerance))
    for c in evaluate_wang2022_claims(out, p.reach_tolerance):
        rows.append(ReportRow(f"claim {c.id}: {c.statement}", "",
                              "holds" if c.holds else "fails", "holds", "", c.holds,
                              c.measured))
    return rows
