"""Outputs near 1e300 (issue 44, item 8): the moments whose power sums overflow double
precision are said once per output and shown as ``overflow``, never as ``std inf`` beside a
page of numpy warnings; every other statistic keeps its bits.

``tests.failing_models:huge``: ``y = a + b^2`` beside ``big = 1e300 y`` (squares overflow),
``mid = 1e100 y`` (3rd and 4th powers overflow) and a series ``path = 1e300 a t``.
"""

from __future__ import annotations

import logging
import math
import warnings

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.gate.baseline import make_baseline, parse_baseline
from uqguide.gate.check import check_result
from uqguide.report.plots import _kde, _stats_text
from uqguide.report.tables import render_text, statistics_table
from uqguide.stats.moments import overflowed


def config(outputs: list) -> dict:
    return {
        "model": {"name": "callable", "function": "tests.failing_models:huge",
                  "inputs": ["a", "b"], "outputs": outputs},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "uniform", "low": 0.0, "high": 2.0}],
        # chunks of 100: the merges of chunk sums overflow too, not only one chunk's sums
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 400, "chunk_size": 100}],
        "report_times": [1.0],
        "seed": 3,
    }


ALL = ["y", "big", "mid", {"name": "path", "kind": "series"}]


class _Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


@pytest.fixture(scope="module")
def huge_run():
    """The run, its numpy warnings and the driver's warning lines."""
    handler, logger = _Lines(), logging.getLogger("uqguide.driver.propagate")
    logger.addHandler(handler)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            result = run(validate_config(config(ALL)))
    finally:
        logger.removeHandler(handler)
    return result, [w for w in caught if issubclass(w.category, RuntimeWarning)], handler.lines


@pytest.fixture(scope="module")
def huge_result(huge_run):
    return huge_run[0]


def test_overflowed_marks_only_what_finite_values_cannot_give():
    nan, inf = math.nan, math.inf
    ordinary = overflowed(np.array([1.0, 0.0]), np.array([2.0, 0.0]), np.array([0.1, nan]),
                          np.array([3.0, nan]))
    assert not any(m.any() for m in ordinary.values())  # (zero variance: NaN shape, silently)
    assert {k: bool(v) for k, v in overflowed(1e300, inf, 0.0, nan).items()} == \
        {"mean": False, "std": True, "skewness": True, "kurtosis": True}
    assert {k: bool(v) for k, v in overflowed(1e100, 1e100, -0.1, nan).items()} == \
        {"mean": False, "std": False, "skewness": False, "kurtosis": True}
    assert bool(overflowed(inf, nan, nan, nan)["mean"])
    # a PCE withholds a skewness and kurtosis as NaN, a multi-fidelity estimate gives NaN for
    # a negative variance: only their infinite moments are overflows
    assert not any(bool(v) for v in overflowed(52.1, 24.2, nan, nan, False).values())
    assert not any(bool(v) for v in overflowed(52.1, nan, nan, nan, False).values())
    assert bool(overflowed(1e300, inf, nan, nan, False)["kurtosis"])


def test_one_line_per_output_and_no_numpy_warning(huge_run):
    _, numpy_warnings, lines = huge_run
    assert not numpy_warnings, [str(w.message) for w in numpy_warnings]
    assert [ln.split(": ")[1] for ln in lines] == ["big", "mid", "path"]
    assert all(ln.startswith("mc: ") and "overflow" in ln and "larger unit" in ln
               for ln in lines)


def test_overflowed_moments_show_as_overflow(huge_result):
    text = render_text(huge_result)
    big = text[text.index("big [1]"):text.index("mid [1]")]
    row = next(ln for ln in big.splitlines() if ln.strip().startswith("mc "))
    assert row.count("overflow") == 4 and "inf" not in row  # mean's interval, std, skew, kurt
    # mid: only the 4th powers overflow; its std and skewness are finite and shown
    table = statistics_table(huge_result)
    mid = table[(table["output"] == "mid") & (table["label"] == "mc")].set_index("stat")
    assert mid.loc["kurtosis", "overflow"] == "value"
    assert np.isfinite(mid.loc[["mean", "std", "skewness"], "value"]).all()
    assert (mid.loc[["mean", "std", "skewness"], "overflow"] != "value").all()
    assert _stats_text(1e300, math.inf, 0.0, math.nan) == \
        "mean 1e+300, std overflow, skew overflow, kurt overflow"


def test_other_outputs_keep_every_bit(huge_result):
    alone = run(validate_config(config(["y"])))
    a, b = alone.run("mc").estimate.stats["y"], huge_result.run("mc").estimate.stats["y"]
    for name in ("mean", "std", "skewness", "kurtosis", "sem"):
        assert np.array_equal(getattr(a, name), getattr(b, name)), name
    for name, ci in a.ci.items():
        assert np.array_equal(ci, b.ci[name]), name


def test_the_gate_passes_a_rerun_of_an_overflowing_output(huge_result):
    rep = check_result(huge_result, parse_baseline(make_baseline(huge_result)))
    assert rep.passed, rep.render()
    notes = {r.note for r in rep.rows if r.output == "big"}
    assert "not finite in both" in notes


def test_density_of_draws_near_1e300_is_the_scaled_one():
    """The KDE of draws whose variance overflows is the density of the draws scaled by a
    power of two, scaled back: the same numbers as the density of the small draws."""
    z = np.random.default_rng(1).standard_normal(500)
    xs = np.linspace(-3, 3, 7)
    k = 2.0 ** 1000
    got = _kde(z * k, xs * k) * k
    np.testing.assert_allclose(got, _kde(z, xs), rtol=1e-12)
