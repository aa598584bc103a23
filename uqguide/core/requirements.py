"""Requirements (``miss below 20 with probability 0.9973 at 90% confidence``) of a config.

A requirement holds when its success event (``below: b`` is ``y < b``, as an event's) has a
probability of at least ``probability``; the quantile form ``quantile: q, below: b`` says the
same of the ``q``-quantile (``x_q < b`` exactly when ``P(y < b) >= q`` for a continuous output).
Each is counted as the event of the same name; the verdicts: :mod:`uqguide.stats.verdicts`,
docs/requirements.md.
"""

from __future__ import annotations

from pydantic import Field, model_validator

from .events import EventSpec
from .strict import StrictModel


class RequirementSpec(StrictModel):
    """One entry of the config's ``requirements`` list."""

    name: str = Field(min_length=1, pattern=r"^[A-Za-z0-9_.\-]+$")
    output: str
    component: int | str | None = None
    below: float | None = None
    above: float | None = None
    probability: float | None = Field(default=None, gt=0.0, lt=1.0)
    quantile: float | None = Field(default=None, gt=0.0, lt=1.0)
    #: at least one half: a lower confidence bound below the estimate
    confidence: float = Field(ge=0.5, lt=1.0)
    #: [s] a series output: judged on its value at the step nearest this time
    time: float | None = None

    @model_validator(mode="after")
    def _one_each(self) -> RequirementSpec:
        if (self.below is None) == (self.above is None):
            raise ValueError(f"requirement {self.name!r}: give exactly one of below, above "
                             f"(got below={self.below}, above={self.above})")
        if (self.probability is None) == (self.quantile is None):
            raise ValueError(f"requirement {self.name!r}: give exactly one of probability, "
                             f"quantile (got probability={self.probability}, "
                             f"quantile={self.quantile})")
        return self

    @property
    def target(self) -> float:
        """The least probability of the success event that passes: ``probability``; in the
        quantile form ``quantile`` below ``b``, ``1 - quantile`` above ``a`` (``x_q > a`` when
        ``P(y > a) > 1 - q``)."""
        if self.probability is not None:
            return float(self.probability)
        assert self.quantile is not None, "validated: exactly one of probability, quantile"
        return float(self.quantile) if self.below is not None else 1.0 - float(self.quantile)

    @property
    def at(self) -> str:
        """The output the event is counted on: ``output``, or ``output@time`` (the series'
        value at the step nearest ``time``, one value per run)."""
        return self.output if self.time is None else f"{self.output}@{self.time:g}"

    def event(self) -> EventSpec:
        """The success event, named as the requirement."""
        return EventSpec(name=self.name, output=self.at, component=self.component,
                         below=self.below, above=self.above)

    def describe(self) -> str:
        """The requirement as text, e.g. ``"P(miss < 20) >= 0.9973 at 90%"``."""
        if self.quantile is not None:
            comp = f"[{self.component}]" if self.component is not None else ""
            op, thr = ("<", self.below) if self.below is not None else (">", self.above)
            return (f"q{self.quantile:g}({self.at}{comp}) {op} {thr:g} "
                    f"at {100 * self.confidence:g}%")
        return f"P({self.event().describe()}) >= {self.target:g} at {100 * self.confidence:g}%"
