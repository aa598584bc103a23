"""The paper-scenario layer: dispatch by model name, and models that know nothing of it."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from uqguide.models.base import Model
from uqguide.papers import (
    SCENARIOS, NoPaperScenario, nominal_figures, nominal_report, sample_figures,
)
from uqguide.config.registry import MODELS, model_class


def test_every_scenario_belongs_to_a_registered_model():
    assert set(SCENARIOS) <= set(MODELS)


@pytest.mark.parametrize("name", sorted(SCENARIOS))
def test_models_no_longer_carry_presentation(name):
    cls = model_class(name)
    for attr in ("nominal_report", "nominal_figures", "sample_figures"):
        assert not hasattr(cls, attr), f"{name}.{attr} belongs in uqguide.papers"


def test_a_model_without_a_paper_scenario(tmp_path):
    model = model_class("lognormal")()
    with pytest.raises(NoPaperScenario, match="model 'lognormal' has no nominal scenario"):
        nominal_report(model)
    with pytest.raises(NoPaperScenario):
        nominal_figures(model, tmp_path)
    out = model.evaluate(np.zeros((1, 0)), [])
    assert sample_figures(model, out, model.full_values(np.zeros(0), []), tmp_path, "s") == []
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_importing_the_models_pulls_in_neither_papers_nor_matplotlib():
    # the layering the import graph checks statically, checked at run time too
    code = ("import sys, uqguide.config.registry as r\n"
            "[r.model_class(n) for n in r.MODELS]\n"
            "bad = sorted(m for m in sys.modules\n"
            "             if m.startswith(('uqguide.papers', 'matplotlib')))\n"
            "print(bad)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_base_model_has_no_presentation_hooks():
    assert not {"nominal_report", "nominal_figures", "sample_figures"} & set(dir(Model))
