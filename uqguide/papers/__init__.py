"""Paper scenarios, above ``report``.

Each paper's nominal checks, report rows and figures, on top of the models: a model simulates
and does not know which paper it reproduces. Per simulator with a paper behind it, a subpackage
with ``report.nominal_report`` (``uqguide simulate``), ``figures.nominal_figures`` and optionally
``figures.sample_figures`` (``uqguide replay``). :data:`SCENARIOS` maps a registered model name
to its subpackage, imported on first use; a new paper scenario is one subpackage and one line
there.

The contract of a subpackage: docs/architecture.md#the-model-contract; what each paper's
reproduction shows: docs/papers.md.
"""

from __future__ import annotations

import importlib
from collections.abc import Mapping
from pathlib import Path
from types import ModuleType
from typing import cast

from ..models.base import Model
from ..core.types import ModelOutput
from .rows import ReportRow, format_report

__all__ = ["SCENARIOS", "NoPaperScenario", "ReportRow", "format_report", "has_scenario",
           "nominal_figures", "nominal_report", "sample_figures"]

SCENARIOS: dict[str, str] = {
    "ftcapn": "uqguide.papers.ftcapn",
    "gmm_proximity": "uqguide.papers.gmm_proximity",
    "gmm_ftc": "uqguide.papers.gmm_ftc",
    "ft_as": "uqguide.papers.ft_as",
}
"""Registered model name -> the package of its paper scenario."""


class NoPaperScenario(LookupError):
    """The model has no paper scenario (no nominal report, no paper figures)."""


def has_scenario(model: Model) -> bool:
    """Whether ``model`` has a paper scenario in :data:`SCENARIOS`."""
    return model.name in SCENARIOS


def _scenario(model: Model, part: str) -> ModuleType:
    try:
        package = SCENARIOS[model.name]
    except KeyError:
        raise NoPaperScenario(f"model '{model.name}' has no nominal scenario to report") from None
    return importlib.import_module(f"{package}.{part}")


def nominal_report(model: Model) -> list[ReportRow]:
    """Run the model's nominal scenario and report its headline figures beside the paper's,
    in the order the report prints them; :class:`NoPaperScenario` without a scenario."""
    return cast(list[ReportRow], _scenario(model, "report").nominal_report(model))


def nominal_figures(model: Model, out_dir: str | Path) -> list[Path]:
    """Write the paper's figures of the nominal scenario (PNG) into ``out_dir`` (made if
    missing); return the files written. :class:`NoPaperScenario` without a scenario."""
    return cast(list[Path], _scenario(model, "figures").nominal_figures(model, Path(out_dir)))


def sample_figures(model: Model, out: ModelOutput, values: Mapping[str, float],
                   out_dir: str | Path, stem: str) -> list[Path]:
    """Figures of one replayed sample beyond the generic time histories (its trajectory, with
    the scene's geometry where the paper has one); return the files written, none for a model
    without a scenario or a sample figure.

    ``out`` holds every output of the one sample (batch of 1), ``values`` every input (nominal
    where not uncertain) in SI units; file names start with ``stem``.
    """
    if not has_scenario(model):
        return []
    figures = _scenario(model, "figures")
    if not hasattr(figures, "sample_figures"):
        return []
    return cast(list[Path], figures.sample_figures(model, out, values, Path(out_dir), stem))
