"""The [W] paper's claims as checkable statements (claims W1-W10).

Each claim is evaluated on the nominal outcomes of the three controllers of one configuration
and reported with the measured value, whether it holds or not: in the literal reading of the
paper's scenario most of them do not, and the report says so instead of hiding it
(docs/papers.md#gmm-controllers-what-reproduces-and-what-does-not).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

APF, GTS, GNT = "APF-TSMC", "GMM-TSMC", "GMM-NTSMC"
"""Display names of the three controllers of [W]."""

CONTROLLER_LABEL: dict[str, str] = {"apf_tsmc": APF, "gmm_tsmc": GTS, "gmm_ntsmc": GNT}
"""The model's ``controller`` parameter -> display name."""

WANG2022_DV_RATIO = {GTS: 0.44, GNT: 0.4553}
"""Delta-v of each GMM controller over APF-TSMC's ([W] 4.2, "reduce by 56 % / 54.47 %", A15)."""

DV_RATIO_TOLERANCE = 0.05
"""Absolute tolerance on those ratios (claims W5, W6)."""


@dataclass(frozen=True)
class Outcome:
    """A nominal run of one controller: the parts whose collision box the path crossed, the
    least clearance [m] to each part's skeleton, the deepest ``penetration`` of the body [m],
    ``delta_v = sum ||u_k|| dt`` [m/s] and ``final_error = ||r(t_f) - r_f||`` [m]."""

    hit_parts: tuple[str, ...]
    clearance: dict[str, float]
    penetration: float
    delta_v: float
    final_error: float

    @property
    def collided(self) -> bool:
        return bool(self.hit_parts)

    def clearance_of(self, kind: str) -> float:
        """Minimum clearance [m] to the parts whose name starts with ``kind``."""
        return min(v for k, v in self.clearance.items() if k.startswith(kind))


@dataclass(frozen=True)
class Claim:
    """One checked statement (``id`` ``"W1"`` ... ``"W10"``) and the measured figures behind
    its verdict."""

    id: str
    statement: str
    holds: bool
    measured: str


def evaluate_wang2022_claims(out: dict[str, Outcome], reach_tolerance: float = 0.05) -> list[Claim]:
    """Claims W1-W10 for the outcomes ``out`` keyed by :data:`APF`, :data:`GTS`, :data:`GNT`.
    ``reach_tolerance``: final position error [m] below which the goal counts as reached (W10;
    0.05 m allows the ~1 cm offset of the GMM controllers' spurious minimum next to the goal)."""
    a, t, n = out[APF], out[GTS], out[GNT]

    def no_collision(o: Outcome) -> bool:
        return not o.collided

    def hits(o: Outcome) -> str:
        return ", ".join(o.hit_parts) or "none"

    r_t = t.delta_v / a.delta_v
    r_n = n.delta_v / a.delta_v
    claims = [
        Claim("W1", "APF-TSMC collides with an antenna",
              any(p.startswith("antenna") for p in a.hit_parts), f"APF-TSMC hits: {hits(a)}"),
        Claim("W2", "GMM-TSMC has no collision", no_collision(t), f"GMM-TSMC hits: {hits(t)}"),
        Claim("W3", "GMM-NTSMC has no collision", no_collision(n), f"GMM-NTSMC hits: {hits(n)}"),
        Claim("W4", "no controller collides with a solar panel",
              not any(p.startswith("panel") for o in (a, t, n) for p in o.hit_parts),
              "; ".join(f"{k}: {hits(o)}" for k, o in out.items())),
        Claim("W5", "GMM-TSMC needs 44 % of APF-TSMC's delta-v",
              abs(r_t - WANG2022_DV_RATIO[GTS]) <= DV_RATIO_TOLERANCE, f"ratio {r_t:.3f}"),
        Claim("W6", "GMM-NTSMC needs 45.53 % of APF-TSMC's delta-v",
              abs(r_n - WANG2022_DV_RATIO[GNT]) <= DV_RATIO_TOLERANCE, f"ratio {r_n:.3f}"),
        Claim("W7", "GMM-NTSMC needs slightly more delta-v than GMM-TSMC (paper ratio 1.035)",
              n.delta_v > t.delta_v, f"ratio {n.delta_v / t.delta_v:.3f}"),
        Claim("W8", "APF-TSMC has the largest delta-v", a.delta_v >= max(t.delta_v, n.delta_v),
              f"{a.delta_v:.4f} / {t.delta_v:.4f} / {n.delta_v:.4f} m/s (APF / GTS / GNT)"),
        Claim("W9", "GMM-NTSMC passes antenna and panel farther than GMM-TSMC",
              n.clearance_of("antenna") > t.clearance_of("antenna")
              and n.clearance_of("panel") > t.clearance_of("panel"),
              f"antenna {n.clearance_of('antenna'):.4f} vs {t.clearance_of('antenna'):.4f} m, "
              f"panel {n.clearance_of('panel'):.4f} vs {t.clearance_of('panel'):.4f} m"),
        Claim("W10", f"all controllers reach the goal (final error < {reach_tolerance} m)",
              bool(np.all([o.final_error < reach_tolerance for o in (a, t, n)])),
              " / ".join(f"{o.final_error:.3g}" for o in (a, t, n)) + " m (APF / GTS / GNT)"),
    ]
    return claims
