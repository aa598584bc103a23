"""Issue 27 items 2 and 3: a PCE's skewness and kurtosis are printed only where its own runs
support them; where a moment is withheld the Monte Carlo estimate of those runs (+mc) stands in;
``--strict`` / ``strict: true`` makes a withheld statistic exit 1."""

from __future__ import annotations

import logging

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.commands.strict import check_withheld
from uqguide.errors import UqguideError
from uqguide.core.types import STAT_NAMES, OutputStats
from uqguide.pce.credibility import State, check_own_by_runs, fallback, record
from uqguide.pce.runs_estimate import runs_estimate, unresolved
from uqguide.pce.support import corrections_to_withhold, refuted, unsupported
from uqguide.pce.validation import Corrected, withdraw
from uqguide.pce.validation_design import random_validation
from uqguide.results.result import read_hdf5
from uqguide.stats.moments import central_moments, shape_moments
from tests.fixtures_models import decaying_cosine_at_7s


def _estimate(value: float, half: float) -> Corrected:
    v = {k: np.array([value]) for k in ("mean", "std", "skewness", "kurtosis")}
    ci = {k: np.array([[value - half], [value + half]]) for k in v}
    return Corrected(values=v, ci=ci, error=np.zeros(1), n=50,
                     correction_half={k: np.array([half]) for k in v})


# ---------------------------------------------------------------------------- the rule
def test_a_pce_value_inside_every_interval_is_kept_and_one_outside_is_withheld():
    own = {"std": np.array([1.0, 1.0, 1.0, 1.0]),
           "skewness": np.array([0.2, 0.9, np.nan, 0.2]),
           "kurtosis": np.array([3.0, 3.0, 3.0, 30.0])}
    cv = Corrected(values={k: np.array([0.0, 0.0, 0.0, 0.0]) for k in own}
                   | {"kurtosis": np.full(4, 3.1), "mean": np.zeros(4)},
                   ci={k: np.array([[-0.5] * 4, [0.5] * 4]) for k in own}
                   | {"kurtosis": np.array([[2.6] * 4, [3.6] * 4]),
                      "mean": np.zeros((2, 4))},
                   error=np.zeros(4), n=50,
                   correction_half={"skewness": np.full(4, 0.5), "kurtosis": np.full(4, 0.5)})
    bad = unsupported(own, cv, None)
    # skewness 0.9 is 1.8 half-widths of the correction (0.5) from its +cv value: kept (two,
    # as check_own); 1.2 is 2.4: withheld; NaN (zero variance) is no value
    assert bad["skewness"].tolist() == [False, False, False, False]
    assert bad["kurtosis"].tolist() == [False, False, False, True]
    own["skewness"][1] = 1.2
    assert unsupported(own, cv, None)["skewness"].tolist() == [False, True, False, False]
    # the +cv interval widened by the surrogate's part beyond the runs' range (far_tails) is
    # shared by the PCE's own value: the check stays on the correction's half-width alone
    cv.ci = {k: np.array([[-5.0] * 4, [5.0] * 4]) for k in own} | {
        "kurtosis": np.array([[-1.9] * 4, [8.1] * 4]), "mean": np.zeros((2, 4))}
    assert unsupported(own, cv, None)["skewness"].tolist() == [False, True, False, False]
    assert unsupported(own, cv, None)["kurtosis"].tolist() == [False, False, False, True]
    own["skewness"][1] = 0.9
    # against the runs' plain estimate the margin is two half-widths: 0.9 vs 0 +- 0.5 is kept
    runs = _estimate(0.0, 0.5)
    runs.values["kurtosis"] = np.array([3.0])
    bad = unsupported({k: v[1:2] for k, v in own.items()}, None, runs)
    assert not bad["skewness"].any()


def test_a_pce_shape_statistic_whose_cv_twin_the_runs_refuted_is_judged_at_one_half_width():
    """A user's damped pendulum (final angle; default pce_adaptive, 250 runs): the PCE's
    kurtosis 3.58, the model's 2.83 (2e4 Monte Carlo runs), its runs' 2.69 +- 0.56. Its +cv
    twin was refuted by those runs; the PCE's own value passed the two-half-width check.
    Where the runs give a floor only, they refute only a value below it: a heavy tail's exact
    skewness 5.93 sits above its runs' 3.90 [2.95, 4.84] at 7 of 10 seeds, within their
    tail-aware [-21.8, inf] (issue 46). Another pendulum's PCE 5.07 (model 4.19) beside such
    a floor is then printed with the runs' bound as its interval
    (``credibility.bound_own``)."""
    own = {"std": np.array([0.189, 0.189, 0.189]), "skewness": np.full(3, -0.95),
           "kurtosis": np.array([3.58, 3.0, 3.58])}
    runs = _estimate(-0.94, 0.23)
    runs.values["kurtosis"] = np.full(3, 2.69)
    runs.values["skewness"] = np.full(3, -0.94)
    runs.ci["kurtosis"] = np.array([[2.13] * 3, [3.25] * 3])
    runs.ci["skewness"] = np.array([[-1.17] * 3, [-0.71] * 3])
    runs.shown_ci = {k: v.copy() for k, v in runs.ci.items()}
    runs.shown_ci["kurtosis"][1, 2] = np.inf  # the third column: the runs give a floor only
    twin = {"kurtosis": np.array([True, True, True]), "skewness": np.zeros(3, dtype=bool)}
    assert not unsupported(own, None, runs)["kurtosis"].any()  # 3.58 < 2.69 + 2 x 0.56
    # the +cv twin (its value withheld: NaN) and its validation runs, which bound the own value
    twin_cv = _estimate(np.nan, 0.01)
    bad = unsupported(own, twin_cv, runs, twin_disagreed=twin)
    # 3.58 is 1.6 half-widths off: withheld; 3.0 is within one; above a floor: kept
    assert bad["kurtosis"].tolist() == [True, False, False]
    own["kurtosis"][2] = 2.0  # below the floor 2.13: refuted
    assert unsupported(own, twin_cv, runs, twin_disagreed=twin)["kurtosis"].tolist() == [
        True, False, True]
    # without validation runs, the delta-method test alone: a floor is no bound
    own["kurtosis"][2] = 3.58
    assert unsupported(own, None, runs, twin_disagreed=twin)["kurtosis"].tolist() == [
        True, False, True]
    assert not bad["skewness"].any()  # its twin stood


def test_a_pce_mean_or_std_its_runs_refute_is_withheld():
    """The zoo's kinked ramp (seed 8, t = 2 s): the PCE's std 0.201, its 298 runs' 0.163; the
    runs judge a mean and a std at two half-widths, as they do a skewness."""
    runs = Corrected(values={"mean": np.array([0.933, 0.933, 0.933]),
                             "std": np.array([0.163, 0.163, 0.163]),
                             "skewness": np.zeros(3), "kurtosis": np.full(3, 3.0)},
                     ci={"mean": np.array([[0.92] * 3, [0.946] * 3]),
                         "std": np.array([[0.153] * 3, [0.173] * 3]),
                         "skewness": np.array([[-1.0] * 3, [1.0] * 3]),
                         "kurtosis": np.array([[2.0] * 3, [4.0] * 3])},
                     error=np.zeros(3), n=298, correction_half={})
    own = {"mean": np.array([0.933, 0.95, 0.933]), "std": np.array([0.201, 0.18, 0.1635]),
           "skewness": np.zeros(3), "kurtosis": np.full(3, 3.0)}
    bad = unsupported(own, None, runs)
    # 0.201 is 3.8 half-widths (0.010) off; 0.18 is 1.7, within two; a mean 1.3 half-widths off
    assert bad["std"].tolist() == [True, False, False]
    assert bad["mean"].tolist() == [False, False, False]
    own["mean"] = np.array([0.933, 0.96, 0.933])  # 2.1 half-widths (0.013)
    assert unsupported(own, None, runs)["mean"].tolist() == [False, True, False]
    # a fit exact to its held-out runs is not judged by them (EXACT_LOO), nor without runs
    assert not unsupported(own, None, runs, loo=1e-12)["std"].any()
    assert not unsupported(own, None, None)["std"].any()


def test_a_fit_exact_to_its_held_out_runs_is_not_judged_by_their_sample_kurtosis():
    # The 40-run command model of tests/test_command_model.py: the PCE's kurtosis 4.959 is
    # exact, its runs' sample kurtosis 2.51 [1.69, 3.34] is biased low (a sample kurtosis of a
    # few dozen runs is); the fit predicts every left-out run to round-off.
    own = {"std": np.array([1.32]), "skewness": np.array([0.756]),
           "kurtosis": np.array([4.959])}
    runs = _estimate(0.7, 0.5)
    runs.values["kurtosis"] = np.array([2.51])
    runs.ci["kurtosis"] = np.array([[1.69], [3.34]])
    assert unsupported(own, None, runs)["kurtosis"].tolist() == [True]
    assert unsupported(own, None, runs, loo=1e-6)["kurtosis"].tolist() == [True]
    assert unsupported(own, None, runs, loo=1e-20)["kurtosis"].tolist() == [False]
    # the control-variate check is not waived: its validation runs are independent of the fit
    cv = _estimate(3.0, 0.2)
    assert unsupported(own, cv, runs, loo=1e-20)["kurtosis"].tolist() == [True]


def _beam_stats(kurtosis: float) -> OutputStats:
    return OutputStats(mean=np.array([0.488]), std=np.array([0.114]),
                       skewness=np.array([-0.043]), kurtosis=np.array([kurtosis]),
                       cov=np.array([[0.013]]), n_used=234, moments_method="exact")


def test_a_skewness_goes_with_the_kurtosis_whose_tails_the_runs_refute():
    """A user's contact-kink beam (3 inputs, 234 runs, seed 3): the PCE's kurtosis 1.0e3
    against its runs' 2.34 is withheld; its skewness -0.043 (the model's: -0.209) lies within
    two half-widths of the runs' wide -0.221 [-0.404, -0.038] and passed alone. It rests on the
    same tails, so it goes with the kurtosis, and the runs' estimate stands in for both."""
    runs = Corrected(values={"mean": np.array([0.49]), "std": np.array([0.112]),
                             "skewness": np.array([-0.221]), "kurtosis": np.array([2.338])},
                     ci={"mean": np.array([[0.475], [0.505]]),
                         "std": np.array([[0.102], [0.122]]),
                         "skewness": np.array([[-0.404], [-0.038]]),
                         "kurtosis": np.array([[2.097], [2.580]])},
                     error=np.zeros(1), n=234, correction_half={})
    usable = np.array([True])
    bad, verdicts = check_own_by_runs("y", _beam_stats(1036.3), None, runs, usable, None)
    assert bad["skewness"][0] and bad["kurtosis"][0]
    given, _, verdict = fallback(runs, {k: ~usable | m for k, m in bad.items()})
    assert given["skewness"][0] == -0.221 and given["kurtosis"][0] == 2.338
    assert verdict is not None and verdict.state is State.FALLBACK
    diag: dict = {}
    for v in verdicts:
        record(diag, "apce", "y", v)
    assert diag["skewness_with_kurtosis.y"] == 1 and diag["withheld.y"] == "kurtosis"
    # the same skewness beside a kurtosis the runs support is kept: the kurtosis decides
    bad, verdicts = check_own_by_runs("y", _beam_stats(2.4), None, runs, usable, None)
    assert not any(m.any() for m in bad.values()) and not verdicts
    assert fallback(runs, {k: ~usable | m for k, m in bad.items()}) == ({}, {}, None)


@pytest.mark.slow
def test_a_heavy_tails_exact_moments_are_not_refuted_by_its_runs_at_more_than_the_level():
    """Issue 46: exp(s Z), s^2 = 0.97 (kurtosis 103), judged by 100 random runs of it, 100
    times: the exact skewness and kurtosis, standing as a PCE's own values, were refuted by
    the runs' two delta-method half-widths in most replicates (their sample kurtosis sits far
    below 103). Refuted only outside the runs' tail-aware interval too, each statistic is
    refuted at most at the acceptance's 10% (the interval's level is 95%). (Without validation
    runs the delta-method test alone decides: nothing else would bound the value.)"""
    s2 = 0.97
    w = np.exp(s2)
    exact = {"mean": np.array([np.exp(s2 / 2)]), "std": np.array([np.sqrt((w - 1) * w)]),
             "skewness": np.array([(w + 2) * np.sqrt(w - 1)]),
             "kurtosis": np.array([w**4 + 2 * w**3 + 3 * w**2 - 3])}
    # a PCE with validation runs whose correction agrees with it (exact to its surrogate)
    cv = Corrected(values=dict(exact), ci={k: np.stack([v, v]) for k, v in exact.items()},
                   error=np.zeros(1), n=50, correction_half={k: np.zeros(1) for k in exact})
    rng = np.random.default_rng(46)
    count = dict.fromkeys(exact, 0)
    reps = 100
    for _ in range(reps):
        runs = runs_estimate(np.exp(np.sqrt(s2) * rng.standard_normal((100, 1))), None, None)
        assert runs is not None
        for k, m in unsupported(exact, cv, runs).items():
            count[k] += int(m[0])
    assert max(count.values()) <= 0.10 * reps, count


def test_a_correction_the_runs_bound_only_from_below_is_not_withheld_above_the_floor():
    """The heavy tail at seed 2: the +cv skewness 5.933 +- 0.016 (exact 5.936) against its 250
    runs' 3.896, delta-method [2.951, 4.841], tail-aware [-21.76, inf]: consistent."""
    cv, runs = _estimate(5.933, 0.016), _estimate(3.896, 0.945)
    runs.shown_ci = {k: np.array([[-21.76], [np.inf]]) for k in runs.ci}
    assert not corrections_to_withhold(cv, runs, np.array([1.0]))["skewness"].any()
    runs.shown_ci = None  # the delta-method interval alone refuted it
    assert corrections_to_withhold(cv, runs, np.array([1.0]))["skewness"].all()


def test_a_floor_that_says_nothing_is_not_resolved():
    runs = _estimate(3.0, 1.0)
    runs.shown_ci = {"mean": np.array([[1.35], [np.inf]]), "std": np.array([[0.0], [np.inf]]),
                     "skewness": np.array([[-21.8], [np.inf]]),
                     "kurtosis": np.array([[1.0], [np.inf]])}
    # a skewness has no least value: a floor of one says something
    assert [unresolved(runs, k)[0] for k in STAT_NAMES] == [False, True, False, True]
    runs.shown_ci["kurtosis"] = np.array([[2.2], [np.inf]])
    assert not unresolved(runs, "kurtosis")[0]
    runs.shown_ci["std"] = np.array([[0.0], [4.0]])  # two finite ends: an interval
    assert not unresolved(runs, "std")[0]


def test_a_floor_that_says_nothing_is_printed_as_not_resolved_by_its_runs(write_config,
                                                                          tmp_path):
    """Issue 46 item 3: a kurtosis whose runs bound it only by 1 (the least of any
    distribution) is printed as "not resolved by N runs" in the console and the Markdown
    tables, with N the runs behind it (a PCE's 40 fit and 20 validation runs for its +mc; a
    Monte Carlo's 30), and the legend says what that means; the result files keep the value
    and its interval. (A lognormal output, sigma 1.24: at this seed the PCE's kurtosis is
    withheld and the runs' is such a floor.)"""
    cfg = {"name": "nr", "model": {"name": "lognormal", "a": [1.2, 0.3]},
           "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                      for i in (1, 2)],
           "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 30},
                       {"name": "pce_adaptive", "label": "apce", "n_samples": 40,
                        "validation": {"n_samples": 20}}],
           "seed": 2}
    res = CliRunner().invoke(main, ["run", str(write_config(cfg)), "--out", str(tmp_path),
                                    "-q"])
    assert res.exit_code == 0, res.output
    rows = {line.split()[0]: line for line in res.output.splitlines()
            if line.strip().startswith(("mc ", "apce+mc "))}
    assert rows["apce+mc"].rstrip().endswith("not resolved by 60 runs"), rows
    assert rows["mc"].rstrip().endswith("not resolved by 30 runs"), rows
    assert "[>= 1;" not in res.output
    key = res.output.split("Key (all of it: docs/statistics.md):")[1].splitlines()
    assert any(line.split()[:4] == ["not", "resolved", "by", "N"] for line in key), key
    summary = (tmp_path / "nr_summary.md").read_text()
    assert "| apce+mc | nan | nan |" in summary and "| not resolved by 60 runs |" in summary
    stats = read_hdf5(tmp_path / "nr.h5").run("apce")
    assert stats.estimate.diagnostics["not_resolved.y"] == "kurtosis by 60 runs"
    s = stats.estimate.stats["y"]
    assert np.isfinite(s.fallback["kurtosis"][0])
    assert s.fallback_ci["kurtosis"][:, 0].tolist() == [1.0, np.inf]
    table = pd.read_csv(tmp_path / "nr_stats.csv").set_index(["label", "stat"])
    assert table.loc[("mc", "kurtosis"), "ci_low"] == 1.0
    assert np.isinf(table.loc[("apce+mc", "kurtosis"), "ci_high"])
    assert np.isfinite(table.loc[("apce+mc", "kurtosis"), "value"])


def test_a_control_variate_value_the_runs_refute_or_less_precise_than_them_is_withheld():
    runs = _estimate(3.0, 1.0)
    assert not corrections_to_withhold(_estimate(3.5, 0.5), runs, np.array([1.0]))["kurtosis"].any()
    # 4.8e5 [2.2e5, 7.4e5] against 3 +- 1 (issue 27's +cv kurtosis)
    assert corrections_to_withhold(_estimate(4.8e5, 2.6e5), runs, np.array([1.0]))["kurtosis"].all()
    # consistent, but a wider interval than the runs' own: worse than no control variate
    assert corrections_to_withhold(_estimate(3.5, 2.0), runs, np.array([1.0]))["kurtosis"].all()



def test_the_old_names_of_the_withholding_rules_still_work_and_say_they_are_deprecated():
    runs, cv = _estimate(3.0, 1.0), _estimate(4.8e5, 2.6e5)
    with pytest.warns(DeprecationWarning, match="corrections_to_withhold"):
        old = refuted(cv, runs, np.array([1.0]))
    assert old == corrections_to_withhold(cv, runs, np.array([1.0]))
    own = {k: np.array([30.0]) for k in ("mean", "std", "skewness", "kurtosis")}
    twin = {"kurtosis": np.array([True])}
    with pytest.warns(DeprecationWarning, match="twin_disagreed"):
        old = unsupported(own, None, runs, twin_refuted=twin)
    assert old == unsupported(own, None, runs, twin_disagreed=twin)
    with pytest.raises(TypeError, match="twin_refutd"):
        unsupported(own, None, runs, twin_refutd=twin)
    st = _beam_stats(3.0)
    with pytest.warns(DeprecationWarning, match="withhold_all"):
        withdraw(st, np.array([False]))
    assert np.isnan(st.mean[0]) and np.isnan(st.kurtosis[0])


def test_the_runs_estimate_is_the_pooled_sample_and_its_mean_interval_covers():
    """Fit runs plus random validation runs (weights 1/n each): the estimate is the pooled
    sample's moments exactly, and over 400 independent columns of normal data (n = 30 + 20)
    the mean's t interval holds the true mean 0 in 95% of them: the coverage of 400 columns
    has standard error sqrt(0.95 0.05 / 400) = 0.011; the test allows 4 of them."""
    rng = np.random.default_rng(7)
    fit, val = rng.normal(size=(30, 400)), rng.normal(size=(20, 400))
    design = random_validation(3, "v", 20, 2)
    est = runs_estimate(fit, val, design)
    assert est is not None
    mean, mu2, mu3, mu4 = central_moments(np.concatenate([fit, val]))
    std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
    for name, want in (("mean", mean), ("std", std), ("skewness", skew), ("kurtosis", kurt)):
        np.testing.assert_allclose(est.values[name], want, rtol=1e-10, atol=1e-12)
    lo, hi = est.ci["mean"]
    cover = np.mean((lo < 0.0) & (0.0 < hi))
    assert cover >= 0.95 - 4 * np.sqrt(0.95 * 0.05 / 400), cover
    assert runs_estimate(fit[:2], None, None) is None  # two runs: no spread to estimate
    # the printed interval never reaches below what any distribution can have
    assert est.shown_ci is not None
    assert np.nanmin(est.shown_ci["kurtosis"][0]) >= 1.0
    assert np.nanmin(est.shown_ci["std"][0]) >= 0.0
    heavy = np.exp(rng.normal(size=(50, 200)))       # lognormal, sigma 1: wide kurtosis
    low = runs_estimate(heavy[:30], heavy[30:], design).shown_ci["kurtosis"][0]
    assert np.nanmin(low) >= 1.0


def test_the_runs_estimate_of_a_stratified_design_weights_its_tail_bounds():
    """Validation runs alone, stratified by a lognormal output (sigma 0.5) from the arcsine
    pool, so that they over-sample both tails: the printed (tail-aware) intervals use the
    runs' weights and Kish's effective count, and over 100 seeds of 40 runs each holds the
    exact moment in at least 95% less 3.9 binomial standard errors of the seeds (measured
    99.5-100% over 200 seeds at 20, 40 and 100 runs; with unweighted tail bounds the mean
    and std held 95-98.5%)."""
    from scipy import stats

    from uqguide.pce.validation_design import stratified_validation

    s2 = 0.25
    w = np.exp(s2)
    exact = {"mean": np.exp(s2 / 2), "std": np.sqrt((w - 1) * w),
             "skewness": (w + 2) * np.sqrt(w - 1), "kurtosis": w**4 + 2 * w**3 + 3 * w**2 - 3}

    def y(u):
        return np.exp(0.5 * stats.norm.ppf(u[:, :1]))

    seeds = 100
    hits = dict.fromkeys(exact, 0)
    for seed in range(seeds):
        vd = stratified_validation(lambda u: {"y": y(u)}, seed, "t", 40, 1)
        est = runs_estimate(None, y(vd.u), vd)
        assert est is not None and est.shown_ci is not None
        for k, v in exact.items():
            lo, hi = est.shown_ci[k][:, 0]
            hits[k] += bool(lo <= v <= hi)
    floor = 0.95 * seeds - 3.9 * np.sqrt(seeds * 0.95 * 0.05)
    assert min(hits.values()) >= floor, hits


# ---------------------------------------------------------------------------- end to end
def _oscillator(seed: int, **extra) -> dict:
    return {"model": {"name": "callable",
                      "function": "tests.fixtures_models:decaying_cosine_at_7s",
                      "inputs": ["omega", "zeta"], "outputs": [{"name": "x"}]},
            "inputs": [{"name": "omega", "dist": "normal", "mean": 2.0, "std": 0.2},
                       {"name": "zeta", "dist": "uniform", "low": 0.05, "high": 0.15}],
            # 20 runs, no enrichment: issue 27's old default, whose tails the rule must catch
            "methods": [{"name": "pce_adaptive", "label": "apce", "n_samples": 20}],
            "seed": seed, **extra}


@pytest.fixture(scope="module")
def oscillator_reference() -> dict[str, float]:
    """Skewness and kurtosis of the oscillator at 7 s from 2e5 plain samples (their standard
    errors, ~0.003 and ~0.005, are far below the tolerances used)."""
    rng = np.random.default_rng(2027)
    x = np.column_stack([rng.normal(2.0, 0.2, 200_000), rng.uniform(0.05, 0.15, 200_000)])
    mean, mu2, mu3, mu4 = central_moments(decaying_cosine_at_7s(x))
    _, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
    return {"skewness": float(skew), "kurtosis": float(kurt)}


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_oscillator_at_20_runs_prints_no_absurd_kurtosis(seed, oscillator_reference,
                                                              caplog):
    """Issue 27's oscillator (here its value at 7 s): the 20-run PCE (the old default) had its
    own kurtosis at 21-61 against the model's 2.4. Now a printed kurtosis is within 20% of the
    reference, or withheld with the runs' estimate beside it, within two of its 95%
    half-widths of the reference (about four standard errors)."""
    with caplog.at_level(logging.WARNING):
        r = uqguide.run(_oscillator(seed))
    s = r.run("apce").estimate.stats["x"]
    for k in ("skewness", "kurtosis"):
        ref = oscillator_reference[k]
        if np.isfinite(s.stat(k)[0]):
            if k == "kurtosis":
                assert abs(s.stat(k)[0] - ref) <= 0.2 * ref, (k, s.stat(k)[0], ref)
            continue
        fb = s.fallback[k][0]
        lo, hi = s.fallback_ci[k][:, 0]
        assert abs(fb - ref) <= (hi - lo), (k, fb, lo, hi, ref)
        assert "withheld" in caplog.text
    if seed == 1:
        with pytest.raises(UqguideError, match=r"strict: \d+ statistic\(s\) withheld.*apce: x"):
            check_withheld(r)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_kurtosis_its_validation_runs_refute_is_withheld_with_the_reason(
        seed, oscillator_reference, caplog):
    """The oscillator at 7 s, 60 fit runs and 30 validation runs (q-norm 1 keeps it cheap):
    the surrogate's exact kurtosis is more than 20% off the model's, the validation runs'
    corrected (+cv) kurtosis is refuted by the runs too, so neither is printed; the
    diagnostics and the warning say why, and the runs' own estimate (+mc) stands in, within
    two of its 95% half-widths of the reference."""
    cfg = _oscillator(seed)
    # usable_error lifted: the rule under test is the support check, not the usability gate
    # (the validation pool's arcsine density sees these surrogates' tails, and their
    # validation error, 0.14-0.23 at these seeds, true 0.09-0.13, already fails the default 0.1)
    cfg["methods"][0].update(n_samples=60, q_norm=1.0, validation={"n_samples": 30},
                             usable_error=1.0)
    with caplog.at_level(logging.WARNING):
        est = uqguide.run(cfg).run("apce").estimate
    ref = oscillator_reference["kurtosis"]
    exact = float(est.surrogate.statistics("x").kurtosis[0])
    assert abs(exact - ref) > 0.2 * ref, exact  # what the rule had to catch
    s = est.stats["x"]
    assert np.isnan(s.kurtosis[0]) and np.isnan(s.corrected["kurtosis"][0])
    assert "kurtosis" in est.diagnostics["withheld.x"]
    assert "kurtosis" in est.diagnostics["withheld_cv.x"]
    # the runs' tail-aware interval, one-sided at 90 runs, cannot refute it; with its +cv
    # twin withheld nothing bounds its error (credibility.bound_own): withheld all the same
    assert "kurtosis are withheld at 1 point(s): nothing bounds their error" in caplog.text
    assert "hold" not in caplog.text.replace("withheld", "")
    lo, hi = s.fallback_ci["kurtosis"][:, 0]
    assert abs(s.fallback["kurtosis"][0] - ref) <= hi - lo


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_the_oscillator_at_7s_at_the_default_plan(seed, oscillator_reference):
    """No PCE setting at all (the default plan: growth up to 200 fit runs, 50 validation runs
    at most): a printed skewness or kurtosis is within 20% (kurtosis) of the reference, or it is
    withheld and the runs' estimate (+mc) stands within two of its half-widths of it."""
    cfg = _oscillator(seed)
    cfg["methods"][0].pop("n_samples")
    est = uqguide.run(cfg).run("apce").estimate
    d = est.diagnostics
    assert d["max_runs"] == 200 and d["n_validation"] >= 20
    s = est.stats["x"]
    for k in ("skewness", "kurtosis"):
        ref = oscillator_reference[k]
        for v in (s.stat(k)[0], s.corrected[k][0]):
            if np.isfinite(v) and k == "kurtosis":
                assert abs(v - ref) <= 0.2 * ref, (k, v, ref)
        if not np.isfinite(s.stat(k)[0]):
            lo, hi = s.fallback_ci[k][:, 0]
            assert abs(s.fallback[k][0] - ref) <= hi - lo, (k, s.fallback[k][0], lo, hi, ref)


def test_strict_is_a_config_switch_and_a_run_flag(write_config, tmp_path):
    assert validate_config(_oscillator(1, strict=True)).raw.strict is True
    path = write_config(_oscillator(1, name="osc"))
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o"), "-q",
                                    "--strict"])
    assert res.exit_code == 1, res.output
    assert "apce+mc" in res.output and "withheld" in res.output
    assert "strict:" in res.output and "Traceback" not in res.output
    # the result file keeps the +mc estimate (and reads it back)
    stats = read_hdf5(tmp_path / "o" / "osc.h5").run("apce").estimate.stats["x"]
    assert np.isfinite(stats.fallback["kurtosis"]).all()
    assert np.all(stats.fallback_ci["kurtosis"][0] < stats.fallback["kurtosis"])


@pytest.mark.slow
@pytest.mark.parametrize("validation", [0, 100])
def test_the_oscillator_series_at_defaults_against_monte_carlo(validation):
    """Issue 27's acceptance case: the 401-step oscillator at pce_adaptive defaults (and with 100
    validation runs) beside 2e4 Monte Carlo runs. Every printed kurtosis is within 20% of
    Monte Carlo's; every withheld one has the runs' estimate (+mc), except at t = 0 where the
    output does not vary (no kurtosis at all). Before issue 27 the validated PCE printed
    kurtosis up to 2.7e3 (Monte Carlo: 2.4) and +cv kurtosis up to 4.8e5."""
    pce: dict = {"name": "pce_adaptive", "label": "apce"}
    if validation:
        pce["validation"] = {"n_samples": validation}
    cfg = {"model": {"name": "callable", "function": "tests.fixtures_models:decaying_cosine",
                     "inputs": ["omega", "zeta"], "outputs": [{"name": "x", "kind": "series"}]},
           "inputs": [{"name": "omega", "dist": "normal", "mean": 2.0, "std": 0.2},
                      {"name": "zeta", "dist": "uniform", "low": 0.05, "high": 0.15}],
           "methods": [pce, {"name": "monte_carlo", "label": "mc", "n_samples": 20_000}],
           "seed": 1}
    r = uqguide.run(cfg)
    a, mc = r.run("apce").estimate.stats["x"], r.run("mc").estimate.stats["x"]
    kurt, ref = a.kurtosis[1:, 0], mc.kurtosis[1:, 0]
    printed = np.isfinite(kurt)
    assert np.all(np.abs(kurt[printed] - ref[printed]) <= 0.2 * ref[printed])
    assert np.isfinite(a.fallback["kurtosis"][1:, 0][~printed]).all()
    if a.corrected:
        cv = a.corrected["kurtosis"][1:, 0]
        shown = np.isfinite(cv)
        assert np.all(np.abs(cv[shown] - ref[shown]) <= 0.2 * ref[shown])
