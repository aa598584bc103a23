"""The one description of a run's statistics (uqguide.results.statistics) and its readers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uqguide.core.types import STAT_NAMES, Estimate, OutputStats
from uqguide.gate.baseline import make_baseline
from uqguide.models.base import OutputInfo
from uqguide.report.tables import statistics_table
from uqguide.results.result import MethodRun, Result
from uqguide.results.statistics import Z95, OutputStatistics, points

SERIES = OutputInfo("r", "series", "m", "a range", ("x", "y"))
SCALAR = OutputInfo("miss", "scalar", "m", "a miss distance", ("",))
TIME = np.linspace(0.0, 10.0, 11)


def _stats(shape: tuple[int, ...], n: int = 100, **kw) -> OutputStats:
    rng = np.random.default_rng(len(shape))
    m = rng.normal(size=shape)
    sd = 1.0 + rng.random(shape)
    k = shape[-1]
    return OutputStats(mean=m, std=sd, skewness=0.1 * m, kurtosis=3.0 + 0.0 * m,
                       cov=np.ones((*shape, k)), n_used=n, **kw)


def test_points_are_the_report_steps_then_the_last_step_per_component():
    got = points(SERIES, TIME, [2.0, 5.0])
    assert [(p.at, p.time, p.step, p.name) for p in got] == [
        ("report", 2.0, 2, "x"), ("report", 2.0, 2, "y"), ("report", 5.0, 5, "x"),
        ("report", 5.0, 5, "y"), ("end", 10.0, 10, "x"), ("end", 10.0, 10, "y")]
    assert got[3].where == (5, 1)
    scalar = points(SCALAR, TIME, [2.0])
    assert [(p.at, p.time, p.where) for p in scalar] == [("scalar", None, (0,))]


def test_statistics_are_own_moments_then_control_variate_then_quantiles():
    s = _stats((2,), corrected={n: np.full(2, 1.0) for n in STAT_NAMES},
               corrected_ci={n: np.zeros((2, 2)) for n in STAT_NAMES},
               quantile_levels=(0.5, 0.9), quantiles=np.zeros((2, 2)),
               ci_quantiles=np.zeros((2, 2, 2)))
    v = OutputStatistics.of("pce", SCALAR, s)
    assert [(st.label, st.name, st.kind) for st in v.statistics] == [
        *(("pce", n, "moment") for n in STAT_NAMES),
        *(("pce+cv", n, "corrected") for n in STAT_NAMES),
        ("pce", "q0.5", "quantile"), ("pce", "q0.9", "quantile")]
    assert v.own("q0.9") is v.quantiles[1] and v.own("mean") is v.moments[0]
    assert v.own("nope") is None


def test_standard_errors_fall_back_from_sem_to_interval_to_normal_theory():
    n = 400
    ci_std = np.array([[0.9], [1.3]])
    s = _stats((1,), n=n, sem=np.array([0.05]),
               ci={"std": ci_std, "skewness": np.array([[np.nan], [np.nan]])})
    v = OutputStatistics.of("mc", SCALAR, s)
    assert v.standard_error("mean", (0,)) == 0.05
    assert v.standard_error("std", (0,)) == (1.3 - 0.9) / (2.0 * Z95)
    # an interval with a NaN end says nothing: normal theory
    assert v.standard_error("skewness", (0,)) == math.sqrt(6.0 / n)
    assert v.standard_error("kurtosis", (0,)) == math.sqrt(24.0 / n)
    # the mean's interval is mean -+ 1.96 sem where the method gives none
    lo, hi = v.moment("mean").interval((0,))
    assert (lo, hi) == (float(s.mean[0] - 1.96 * 0.05), float(s.mean[0] + 1.96 * 0.05))


def _result() -> Result:
    T = TIME.size
    usable = np.ones((T, 2), dtype=bool)
    usable[10, 1] = False  # the PCE withdraws its moments of y at the last step
    pce = _stats((T, 2), usable=usable, moments_method="exact",
                 corrected={n: np.full((T, 2), 2.0) for n in STAT_NAMES},
                 corrected_ci={n: np.stack([np.full((T, 2), 1.0), np.full((T, 2), 3.0)])
                               for n in STAT_NAMES})
    mc = _stats((T, 2), sem=np.full((T, 2), 0.1))

    def run(label: str, method: str, s: OutputStats) -> MethodRun:
        return MethodRun(Estimate(method=method, label=label, stats={"r": s}),
                         np.zeros((3, 1)), {}, np.zeros(3, bool), np.full(3, "", object),
                         TIME, 3, 0.0, 0.0, 0.0)

    return Result("t", "m", ["a"], [SERIES], TIME,
                  [run("mc", "monte_carlo", mc), run("pce", "pce_tensor", pce)],
                  reference="mc", report_times=[5.0])


def test_the_table_and_the_baseline_read_the_same_points_and_rows():
    result = _result()
    table = statistics_table(result)
    places = points(SERIES, TIME, result.report_times)
    for label in ("mc", "pce", "pce+cv"):
        rows = table[table.label == label]
        assert len(rows) == len(places) * len(STAT_NAMES), label
        assert sorted(set(zip(rows.time, rows.component))) == sorted(
            {(p.time, p.name) for p in places})
    cv = table[table.label == "pce+cv"]
    assert (cv.value == 2.0).all() and (cv.ci_low == 1.0).all() and cv.usable.all()
    withdrawn = table[(table.label == "pce") & (table.time == 10.0) & (table.component == "y")]
    assert not withdrawn.usable.any()
    base = make_baseline(result)["methods"]
    assert len(base["mc"]["outputs"]["r"]["points"]) == len(places)
    # the baseline pins no moment the PCE withdrew
    pce_points = base["pce"]["outputs"]["r"]["points"]
    assert len(pce_points) == len(places) - 1
    assert ("end", "y") not in {(p["at"], p["component"]) for p in pce_points}
    assert {"mean_se", "std_se"} <= set(base["mc"]["outputs"]["r"]["points"][0])
    assert "mean_se" not in pce_points[0]


@pytest.mark.parametrize("name", ["mean", "kurtosis"])
def test_a_control_variate_row_is_compared_with_the_reference_s_own_moment(name):
    result = _result()
    table = statistics_table(result)
    row = table[(table.label == "pce+cv") & (table.stat == name)].iloc[0]
    ref = result.run("mc").estimate.stats["r"].stat(name)[int(row.time), 0]
    assert row.ref_value == ref and row.abs_diff == 2.0 - ref


def test_the_description_reads_a_method_s_xarray_dataset_as_its_statistics():
    """The one data model: the description read from ``Result.to_xarray(label)`` is the one
    read from the method's statistics, value for value, with the sources' labels."""
    result = _result()
    for r in result.runs:
        a = OutputStatistics.of(r.label, SERIES, r.estimate.stats["r"])
        b = OutputStatistics.read(r.label, SERIES, result.to_xarray(r.label))
        assert [(st.label, st.name, st.kind) for st in a.statistics] == \
            [(st.label, st.name, st.kind) for st in b.statistics]
        for x, y in zip(a.statistics, b.statistics):
            np.testing.assert_array_equal(x.value, y.value)
            assert (x.ci is None) == (y.ci is None)
            if x.ci is not None:
                np.testing.assert_array_equal(x.ci, y.ci)
        np.testing.assert_array_equal(a.cov, b.cov)
        assert (a.usable is None) == (b.usable is None) and a.n_used == b.n_used
    assert [st.label for st in b.corrected] == ["pce+cv"] * len(STAT_NAMES)
