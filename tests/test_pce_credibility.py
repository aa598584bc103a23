"""The credibility pipeline's steps, each alone (:mod:`uqguide.pce.credibility`)."""

from __future__ import annotations

import importlib
import pkgutil
import re

import numpy as np

import uqguide.pce
from uqguide.core.types import STAT_NAMES, OutputStats
from uqguide.pce.credibility import (
    STEPS, State, check_correction, check_own, no_usable_surrogate, record, usable,
)
from uqguide.pce.validation import Corrected


def _stats(mean: list[float], std: list[float], kurtosis: float = 3.0) -> OutputStats:
    n = len(mean)
    return OutputStats(mean=np.array(mean), std=np.array(std), skewness=np.zeros(n),
                       kurtosis=np.full(n, kurtosis), cov=np.diag(np.square(std)), n_used=30,
                       moments_method="exact")


def _estimate(values: dict[str, float], half: float, n: int = 1) -> Corrected:
    v = {k: np.full(n, values.get(k, 0.0)) for k in STAT_NAMES}
    return Corrected(values=v, ci={k: np.stack([x - half, x + half]) for k, x in v.items()},
                     error=np.zeros(n), n=50,
                     correction_half={k: np.full(n, half) for k in STAT_NAMES})


def test_the_four_states_are_named_once_and_every_verdict_names_its_step():
    assert [s.value for s in State] == ["own", "corrected", "fallback", "withheld"]
    st = _stats([1.0], [1.0])
    ok, constant = usable("y", st, None, 0.5, 0.1)
    verdict = no_usable_surrogate("y", st, ok, constant, None, 0.5, 0.1, None)
    assert verdict is not None and verdict.step in STEPS


def test_no_public_name_of_the_pce_package_uses_a_synonym_of_withheld_but_a_deprecated_one():
    """refuted, withdrawn, unusable: the old words for a withheld value leave the API; the
    names that remain are the deprecated aliases, which say so."""
    synonym = re.compile(r"refut|withdr|unusable", re.IGNORECASE)
    found = []
    for info in pkgutil.iter_modules(uqguide.pce.__path__, "uqguide.pce."):
        module = importlib.import_module(info.name)
        for name in dir(module):
            obj = getattr(module, name)
            if (synonym.search(name) and not name.startswith("_")
                    and getattr(obj, "__module__", None) == module.__name__
                    and "Deprecated" not in (obj.__doc__ or "")):
                found.append(f"{info.name}.{name}")
    assert not found, found


def test_a_scalar_pce_value_two_half_widths_from_its_correction_is_withheld():
    st = _stats([1.0, 1.0], [1.0, 1.0])
    cv = _estimate({"mean": 1.0, "std": 1.0, "kurtosis": 3.0}, 0.1, n=2)
    cv.values["mean"] = np.array([1.15, 1.25])  # 1.5 and 2.5 half-widths off
    masks, verdict = check_own("y", st, cv, None, np.array([True, True]))
    assert masks["mean"].tolist() == [False, True] and not masks["std"].any()
    assert verdict is not None and verdict.state is State.WITHHELD and verdict.of == "own"
    diag: dict = {}
    record(diag, "apce", "y", verdict)
    assert diag == {"disagrees.y": "mean"}
    # where it is not usable it says "no usable surrogate" instead: not judged here
    masks, verdict = check_own("y", st, cv, None, np.array([True, False]))
    assert verdict is None and masks == {}


def test_a_correction_the_runs_disagree_with_is_withheld_and_says_which():
    cv, runs = _estimate({"std": 1.0, "kurtosis": 30.0}, 0.5), _estimate({"std": 1.0,
                                                                           "kurtosis": 3.0}, 1.0)
    disagreed, verdict = check_correction("y", cv, runs)
    assert disagreed["kurtosis"].all() and not disagreed["mean"].any()
    assert np.isnan(cv.values["kurtosis"][0]) and np.isnan(cv.ci["kurtosis"]).all()
    assert verdict is not None and verdict.of == "+cv" and verdict.state is State.WITHHELD
    assert dict(verdict.record) == {"withheld_cv.y": "kurtosis"}
    assert check_correction("y", _estimate({}, 0.5), None) == (None, None)


def test_an_unusable_output_is_withheld_with_its_reason_and_a_constant_says_why():
    st = _stats([1.0], [1.0])
    ok, constant = usable("y", st, np.array([0.05]), 0.5, 0.1)
    assert not ok.any() and not constant  # a scalar is judged by both errors: LOO 0.5 > 0.1
    ok, constant = usable("y", st, None, 0.5, 0.1)
    verdict = no_usable_surrogate("y", st, ok, constant, None, 0.5, 0.1, None)
    assert verdict is not None
    assert dict(verdict.record) == {"no_usable_surrogate.y": "LOO error 0.5 > 0.1"}
    flat = _stats([1.0], [0.0])
    ok, constant = usable("y", flat, None, 0.0, 0.1)
    verdict = no_usable_surrogate("y", flat, ok, constant, None, 0.0, 0.1, None)
    assert constant and verdict is not None and "constant on all 30" in verdict.reason
    assert no_usable_surrogate("y", st, np.array([True]), False, None, 0.0, 0.1, None) is None
