"""Events (``collision: min_clearance below 0``) and their probabilities with intervals.

``below: b`` is ``y < b``, ``above: a`` is ``y > a``, both strict. Monte Carlo reports ``k`` of
``n`` with the Clopper-Pearson 95% interval; what is reported and how: docs/statistics.md#events.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field, model_validator

from .strict import StrictModel

LEVEL = 0.95


class EventSpec(StrictModel):
    """One event of the config's ``events`` list (``below: true`` is refused, not 1.0)."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")
    output: str
    component: int | str | None = None
    below: float | None = None
    above: float | None = None

    @model_validator(mode="after")
    def _one_threshold(self) -> EventSpec:
        if (self.below is None) == (self.above is None):
            raise ValueError(f"event {self.name!r}: give exactly one of below, above "
                             f"(got below={self.below}, above={self.above})")
        return self

    def describe(self) -> str:
        """The event as text, e.g. ``"miss[1] > 5"``."""
        comp = f"[{self.component}]" if self.component is not None else ""
        op, thr = ("<", self.below) if self.below is not None else (">", self.above)
        return f"{self.output}{comp} {op} {thr:g}"

    def threshold(self) -> float:
        """The event's threshold: ``b`` (``below``) or ``a`` (``above``), in the output's unit."""
        value = self.below if self.below is not None else self.above
        assert value is not None, "validated: exactly one of below, above"
        return float(value)

    def severity(self, values: np.ndarray) -> np.ndarray:
        """``g`` with the event ``g > 0`` (for level sets): ``y - a`` or ``b - y``, ``(n,)`` in the
        output's unit."""
        return values - self.threshold() if self.above is not None else self.threshold() - values

    def indicator(self, values: np.ndarray) -> np.ndarray:
        """Whether each sample's value ``(n,)`` is in the event."""
        return self.severity(values) > 0


def component_index(spec: EventSpec, components: tuple[str, ...]) -> int:
    """Column of the event's component among the output's ``components`` (0 for a one-component
    output); ValueError naming the allowed components when it is not one of them."""
    c = spec.component
    if c is None:
        if len(components) > 1:
            raise ValueError(f"output {spec.output!r} has components {', '.join(components)}: "
                             f"name one with component")
        return 0
    if isinstance(c, int):
        if not 0 <= c < len(components):
            raise ValueError(f"component {c} is out of range 0..{len(components) - 1}")
        return c
    if c not in components:
        raise ValueError(f"output {spec.output!r} has no component {c!r}; allowed: "
                         f"{', '.join(components)}")
    return components.index(c)


def clopper_pearson(k: float, n: float, level: float = LEVEL) -> tuple[float, float]:
    """Exact (Clopper-Pearson) two-sided interval of a binomial proportion ``k / n`` (counts
    may be effective, non-integer ones).

    Coverage is at least ``level`` for every true probability (conservative); ``[0, upper]``
    for ``k = 0`` and ``[lower, 1]`` for ``k = n``; NaN for ``n = 0``.
    """
    if n <= 0:
        return float("nan"), float("nan")
    a = (1.0 - level) / 2.0
    # The beta quantiles by scipy.special (what scipy.stats.beta.ppf computes, the same bits):
    # the gate's baseline and check seal an event's interval with this function, and
    # importing scipy.stats would cost those quick commands most of their start-up.
    from scipy.special import betaincinv

    lo = 0.0 if k == 0 else float(betaincinv(k, n - k + 1, a))
    hi = 1.0 if k == n else float(betaincinv(k + 1, n - k, 1.0 - a))
    return lo, hi


@dataclass
class EventEstimate:
    """The probability of one event by one method.

    ``ci``: 95% interval; ``n_in``, ``n_used``: runs (or draws) in the event and behind the
    estimate; ``estimator``: ``"count"`` (model runs, Clopper-Pearson), ``"surrogate"`` (PCE
    draws, Clopper-Pearson of the draws only) or ``"subset"`` (subset simulation; lognormal
    interval from its CoV); ``cov``: coefficient of variation (NaN where not estimated).
    """

    name: str
    definition: str
    probability: float
    ci: tuple[float, float]
    n_in: int
    n_used: int
    estimator: str
    cov: float = float("nan")

    def as_dict(self) -> dict[str, object]:
        """The fields but the name, flat (for storage); inverse of :meth:`from_dict`."""
        return {"definition": self.definition, "probability": self.probability,
                "ci_low": self.ci[0], "ci_high": self.ci[1], "n_in": self.n_in,
                "n_used": self.n_used, "estimator": self.estimator, "cov": self.cov}

    @classmethod
    def from_dict(cls, name: str, d: dict) -> EventEstimate:
        """The estimate stored by :meth:`as_dict` (``cov`` may be missing in older files)."""
        return cls(name, str(d["definition"]), float(d["probability"]),
                   (float(d["ci_low"]), float(d["ci_high"])), int(d["n_in"]),
                   int(d["n_used"]), str(d["estimator"]), float(d.get("cov", float("nan"))))


def count_events(specs: list[EventSpec], scalars: dict[str, np.ndarray], ok: np.ndarray,
                 components: dict[str, tuple[str, ...]], estimator: str = "count"
                 ) -> dict[str, EventEstimate]:
    """Events counted over the runs (or draws) ``ok (n,)`` of per-sample scalars ``(n, k)``: by
    event name, ``k / n`` with its Clopper-Pearson interval; ``estimator`` (``"count"`` or
    ``"surrogate"``) is recorded."""
    out = {}
    for s in specs:
        y = scalars[s.output][ok, component_index(s, components[s.output])]
        k, n = int(np.count_nonzero(s.indicator(y))), int(y.shape[0])
        p = k / n if n else float("nan")
        cov = float(np.sqrt((1 - p) / (n * p))) if 0 < p else float("nan")
        out[s.name] = EventEstimate(s.name, s.describe(), p, clopper_pearson(k, n), k, n,
                                    estimator, cov)
    return out
