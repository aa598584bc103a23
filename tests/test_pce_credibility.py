"""The credibility pipeline's steps, each alone (:mod:`uqguide.pce.credibility`)."""

from __future__ import annotations

import importlib
import pkgutil
import re

import numpy as np

import uqguide.pce
from uqguide.core.types import STAT_NAMES, OutputStats
from uqguide.pce.credibility import (
    STEPS, State, bound_own, check_correction, check_own, fallback, no_usable_surrogate,
    not_resolved, record, refused_correction, usable,
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


def test_an_own_value_carries_the_correction_s_interval_or_the_runs_bound_or_is_withheld():
    """Issue 46 item 4: a PCE value shown carries the smallest interval holding it and its
    printed +cv interval; where the +cv value is withheld, the runs' interval; where that says
    nothing (a kurtosis >= 1) or is narrower than the correction, the value is withheld."""
    st = _stats([1.0] * 4, [1.0] * 4, kurtosis=5.0)
    cv = _estimate({"mean": 1.02, "std": 1.0, "kurtosis": 5.1}, 0.1, n=4)
    for k in ("kurtosis",):  # withheld by check_correction at points 1..3
        cv.values[k][1:] = np.nan
    cv.correction_half["kurtosis"][3] = 3.0  # less precise than the runs' 1.0
    runs = _estimate({"mean": 1.0, "std": 1.0, "kurtosis": 4.0}, 1.0, n=4)
    runs.shown_ci = {k: v.copy() for k, v in runs.ci.items()}
    runs.shown_ci["kurtosis"] = np.array([[3.0, 2.0, 1.0, 2.0], [5.0, np.inf, np.inf, np.inf]])
    ok = np.ones(4, dtype=bool)
    out, verdict = bound_own("y", st, cv, runs, ok)
    assert np.allclose(st.ci["mean"][:, 0], [0.92, 1.12])  # holds 1.0 and 1.02 +- 0.1
    lo, hi = st.ci["kurtosis"]
    assert lo[0] == 5.0 and np.isclose(hi[0], 5.2)  # the value itself at the low end
    assert (lo[1], hi[1]) == (2.0, np.inf)  # the runs' floor
    assert out["kurtosis"].tolist() == [False, False, True, True]
    assert np.isnan(lo[2:]).all()
    assert verdict is not None and verdict.state is State.WITHHELD
    assert dict(verdict.record) == {"withheld.y": "kurtosis (unbounded)"}
    # no validation set: the runs bound a value near their estimate; one far from it is
    # judged by check_own_by_runs alone (issue 27's 20-run kurtosis 21.5 against 2.4)
    st = _stats([1.0, 1.0], [1.0, 1.0], kurtosis=4.5)
    st.kurtosis[1] = 21.5
    runs = _estimate({"mean": 1.0, "std": 1.0, "kurtosis": 4.0}, 1.0, n=2)
    out, verdict = bound_own("y", st, None, runs, np.ones(2, dtype=bool))
    assert st.ci["kurtosis"][:, 0].tolist() == [3.0, 5.0]
    assert np.isnan(st.ci["kurtosis"][:, 1]).all()
    assert not out["kurtosis"].any() and verdict is None
    # neither validation nor runs (quadrature nodes): the own values stay as they were
    st = _stats([1.0], [1.0])
    assert bound_own("y", st, None, None, np.ones(1, dtype=bool)) == ({}, None)
    assert st.ci == {}


def test_a_runs_answer_that_says_nothing_is_not_resolved_by_its_runs():
    runs = _estimate({"kurtosis": 30.3, "skewness": 4.2}, 12.0)
    runs.shown_ci = {k: v.copy() for k, v in runs.ci.items()}
    runs.shown_ci["kurtosis"] = np.array([[1.0], [np.inf]])
    runs.shown_ci["skewness"] = np.array([[-21.8], [np.inf]])
    values, _, _ = fallback(runs, {k: np.ones(1, dtype=bool) for k in STAT_NAMES})
    verdict = not_resolved("y", runs, values)
    assert verdict is not None and dict(verdict.record) == {"not_resolved.y": "kurtosis by 50 runs"}
    assert "not resolved by 50 runs" in verdict.reason
    runs.shown_ci["kurtosis"] = np.array([[2.2], [np.inf]])  # a floor that says something
    assert not_resolved("y", runs, values) is None


def test_where_the_surrogate_is_refused_its_cv_values_go_but_a_constant_one_s_stay():
    """Issue 46 item 5: where the validation error is above usable_error the +cv values are
    not reported (the refused polynomial's residuals understate the correction's error: on the
    50-period oscillator the +cv means printed there, for an interval narrower than the
    runs', held at 89% of the steps, docs/pce.md#where-the-surrogate-is-refused); a constant
    surrogate does not swing, so its +cv moments (the validation runs' own) stay."""
    st = _stats([1.0, 1.0, 1.0], [1.0, 1.0, 0.0])
    cv = _estimate({"mean": 1.0, "std": 1.0, "skewness": 0.2, "kurtosis": 3.0}, 0.1, n=3)
    cv.error = np.array([0.05, 2.3, 2.3])
    verdict = refused_correction("x", st, cv, 0.1)
    assert verdict is not None and verdict.step in STEPS and verdict.state is State.WITHHELD
    for k in STAT_NAMES:
        assert np.isfinite(cv.values[k]).tolist() == [True, False, True]
        assert np.isfinite(cv.ci[k]).all(axis=0).tolist() == [True, False, True]
    assert verdict.record == {"refused_correction.x": 1}
    assert refused_correction("x", st, cv, 0.1) is None  # nothing left to withhold
