"""Requirements: config entries, verdicts per method (exact, approximate, validated PCE), the
plan, the table and the file."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from uqguide.config.run_config import validate_config
from uqguide.core.events import EventEstimate, EventSpec
from uqguide.core.requirements import RequirementSpec
from uqguide.driver.propagate import run
from uqguide.errors import ConfigError
from uqguide.report.tables import REQUIREMENT_COLUMNS, render_text, write_tables
from uqguide.results.result import read_hdf5, write_hdf5
from uqguide.stats.verdicts import (count_verdict, method_verdicts, one_sided_bounds,
                                    runs_to_decide, runs_to_pass, wilks_rank)

LINEAR = {"model": {"name": "linear_gaussian", "coefficients": [[1.0, 2.0, -0.5]]},
          "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0.0, "std": 1.0}
                     for i in (1, 2, 3)]}
SIGMA = float(np.sqrt(1 + 4 + 0.25))
REQ = {"name": "r", "output": "y", "below": 3.0, "probability": 0.99, "confidence": 0.9}


def _config(requirements, methods=None, **extra):
    methods = methods or [{"name": "monte_carlo", "label": "mc", "n_samples": 2000,
                           "bootstrap": 0, "sensitivity": "off"}]
    return validate_config({**LINEAR, "methods": methods, "requirements": requirements,
                            **extra})


@pytest.mark.parametrize("entry, message", [
    ({**REQ, "probabilty": 0.99},
     "requirements[0].probabilty: unknown key (did you mean 'probability'?)"),
    ({**REQ, "probability": 1.5},
     "requirements[0].probability: Input should be less than 1 (got 1.5)"),
    ({**REQ, "confidence": 0.3},
     "requirements[0].confidence: Input should be greater than or equal to 0.5 (got 0.3)"),
    ({k: v for k, v in REQ.items() if k != "confidence"},
     "requirements[0].confidence: required field is missing"),
    ({**REQ, "quantile": 0.9},
     "requirements[0]: requirement 'r': give exactly one of probability, quantile "
     "(got probability=0.99, quantile=0.9)"),
    ({**REQ, "above": 1.0},
     "requirements[0]: requirement 'r': give exactly one of below, above"),
    ({**REQ, "output": "z"},
     "requirements[0].output: 'z' is not among the config's outputs; allowed: y"),
])
def test_a_bad_requirement_names_its_field_value_and_what_is_allowed(entry, message):
    with pytest.raises(ConfigError) as exc:
        _config([entry])
    assert str(exc.value).startswith(message)


def test_a_requirement_named_as_an_event_or_twice_is_refused():
    with pytest.raises(ConfigError, match=r"requirements\[0\]\.name: 'r' is also an event's"):
        _config([REQ], events=[{"name": "r", "output": "y", "above": 1.0}])
    with pytest.raises(ConfigError, match=r"requirements\[1\]\.name: 'r' is used twice"):
        _config([REQ, REQ])


def test_the_quantile_form_targets_the_success_probability():
    below = RequirementSpec(name="a", output="y", quantile=0.999, below=2.0, confidence=0.9)
    above = RequirementSpec(name="b", output="y", quantile=0.01, above=2.0, confidence=0.9)
    assert below.target == 0.999
    assert above.target == pytest.approx(0.99)  # x_0.01 > a when P(y > a) > 0.99
    assert below.describe() == "q0.999(y) < 2 at 90%"
    assert RequirementSpec(**REQ).describe() == "P(y < 3) >= 0.99 at 90%"


def test_one_sided_bounds_are_the_exact_beta_quantiles():
    k, n, c = 987, 1000, 0.9
    lo, hi = one_sided_bounds(k, n, c)
    assert lo == pytest.approx(stats.beta.ppf(1 - c, k, n - k + 1), rel=1e-12)
    assert hi == pytest.approx(stats.beta.ppf(c, k + 1, n - k), rel=1e-12)


def test_verdicts_pass_fail_and_undecided_at_counts():
    assert count_verdict("r", "mc", 852, 852, 0.9973, 0.9).verdict == "pass"
    assert count_verdict("r", "mc", 851, 851, 0.9973, 0.9).verdict == "undecided"
    assert count_verdict("r", "mc", 800, 852, 0.9973, 0.9).verdict == "fail"


def test_runs_to_decide_decides_there_and_not_one_run_before():
    """An undecided count, run on at its estimate: decided after the further runs given, not
    one run earlier."""
    for k, n, target, c in [(850, 852, 0.9973, 0.9), (2998, 3000, 0.999, 0.95),
                            (96, 100, 0.95, 0.9)]:
        v = count_verdict("r", "mc", k, n, target, c)
        assert v.verdict == "undecided"
        m = n + int(v.runs_to_decide)
        p = k / n
        assert count_verdict("r", "mc", p * m, m, target, c).verdict != "undecided"
        assert count_verdict("r", "mc", p * (m - 1), m - 1, target, c).verdict == "undecided"
    assert runs_to_decide(0.95, 0.95, 0.9, 100) == math.inf


@pytest.mark.parametrize("target, confidence", [(0.9973, 0.9), (0.95, 0.95), (0.99, 0.99),
                                                (0.999, 0.5)])
def test_the_plan_equals_the_closed_forms(target, confidence):
    """Zero failures: n = ceil(ln(1 - c) / ln p); one and two: the least n whose binomial
    probability of at most f failures, written out, is at most 1 - c."""
    n0 = runs_to_pass(target, confidence, 0)
    assert n0 == math.ceil(math.log(1 - confidence) / math.log(target))
    q = 1 - target

    def at_most(f, n):
        return sum(math.comb(n, j) * q**j * target ** (n - j) for j in range(f + 1))

    for f in (1, 2):
        n = runs_to_pass(target, confidence, f)
        assert at_most(f, n) <= 1 - confidence < at_most(f, n - 1)
        # and the exact lower bound of n - f successes of n reaches the target just there
        assert count_verdict("r", "mc", n - f, n, target, confidence).verdict == "pass"
        assert count_verdict("r", "mc", n - 1 - f, n - 1, target, confidence).verdict != "pass"
    assert runs_to_pass(0.9973, 0.9) == 852 and runs_to_pass(0.95, 0.95) == 59


def test_the_quantile_form_is_wilks_order_statistic():
    """``y_(r) < b`` (r the Wilks rank) exactly when the count verdict passes, for every count."""
    for n, q, c in [(59, 0.95, 0.95), (500, 0.99, 0.9), (1000, 0.5, 0.99)]:
        r = wilks_rank(n, q, c)
        assert r is not None
        for k in range(n + 1):
            assert (k >= r) == (count_verdict("r", "mc", k, n, q, c).verdict == "pass")
    assert wilks_rank(58, 0.95, 0.95) is None  # fewer than the zero-failure plan's 59


def _event(name, p, ci, n_in, n, estimator, cov=float("nan")):
    return EventEstimate(name, "", p, ci, n_in, n, estimator, cov)


def test_subset_simulation_gives_an_approximate_verdict_on_the_complement():
    req = RequirementSpec(**{**REQ, "below": 5.0, "probability": 0.9999})
    fail = EventSpec(name="far", output="y", above=5.0)
    p, s = 1e-6, 0.3
    ev = _event("far", p, (p * math.exp(-1.96 * s), p * math.exp(1.96 * s)), 90, 1000,
                "subset", 0.3)
    v = method_verdicts("ss", [req], {"far": ev}, [fail, req.event()])["r"]
    z = stats.norm.ppf(0.9)
    assert v.verdict == "pass" and v.basis.startswith("approximate")
    assert v.lower == pytest.approx(1 - p * math.exp(z * s), rel=1e-12)
    # another threshold is not the complement: no verdict
    other = EventSpec(name="far", output="y", above=4.0)
    assert method_verdicts("ss", [req], {"far": ev}, [other, req.event()])["r"].verdict \
        == "undecided"


def test_a_pce_decides_only_with_validation_bounds_at_the_confidence_asked():
    cv = _event("r", 0.999, (0.995, 1.0), 400, 400, "surrogate+cv")
    req90 = RequirementSpec(**REQ)
    req99 = RequirementSpec(**{**REQ, "confidence": 0.99})
    v = method_verdicts("pce", [req90, ], {"r": cv}, [req90.event()])["r"]
    assert (v.verdict, v.lower) == ("pass", 0.995)
    v = method_verdicts("pce", [req99], {"r": cv}, [req99.event()])["r"]
    assert v.verdict == "undecided" and "97.5%" in v.basis and math.isnan(v.lower)
    draws = _event("r", 0.999, (0.998, 1.0), 999_000, 1_000_000, "surrogate")
    v = method_verdicts("pce", [req90], {"r": draws}, [req90.event()])["r"]
    assert v.verdict == "undecided" and "validation_runs bound it" in v.basis


def test_a_monte_carlo_run_gives_verdicts_stored_printed_and_written(tmp_path):
    """P(y < 3 sigma) = 0.99865: 2000 runs (about 3 beyond) pass 0.99 and fail 0.9999; the
    median at its true value 0 is undecided (this seed; either way with 2% chance)."""
    cfg = _config([{**REQ, "below": 3 * SIGMA},
                   {**REQ, "name": "tight", "below": 3 * SIGMA, "probability": 0.9999},
                   {"name": "q", "output": "y", "quantile": 0.5, "below": 0.0,
                    "confidence": 0.99}])
    res = run(cfg)
    got = {name: v.verdict for name, v in res.runs[0].verdicts.items()}
    assert got["r"] == "pass" and got["tight"] == "fail"
    assert got["q"] == "undecided"  # the median is 0: no count decides it
    assert res.runs[0].verdicts["q"].runs_to_decide > 0
    path = write_hdf5(res, tmp_path / "r.h5")
    back = read_hdf5(path)
    assert back.runs[0].verdicts == res.runs[0].verdicts
    write_tables(back, tmp_path, "r")
    df = pd.read_csv(tmp_path / "r_requirements.csv")
    assert list(df.columns) == REQUIREMENT_COLUMNS
    assert list(df["requirement"]) == ["r", "tight", "q"]  # the config's order
    text = render_text(back)
    assert "Requirements (one-sided bounds" in text
    assert max(len(line) for line in text.splitlines()) <= 160
    from uqguide.report.document import render_report
    from uqguide.report.tables import render_markdown

    for md in (render_markdown(back), render_report(back, [], tmp_path)):
        assert "## Requirements" in md and "| tight |" in md


def _cli_config(write_config, requirements, n=2000):
    return write_config({**LINEAR, "name": "req", "seed": 0, "requirements": requirements,
                         "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n,
                                      "bootstrap": 0, "sensitivity": "off"}]})


def test_validate_prints_the_plan(write_config):
    from click.testing import CliRunner

    from uqguide.cli import main

    path = _cli_config(write_config, [
        {**REQ, "name": "three_sigma", "probability": 0.9973},
        {"name": "q95", "output": "y", "quantile": 0.95, "below": 3.0, "confidence": 0.95}])
    res = CliRunner().invoke(main, ["validate", str(path)])
    assert res.exit_code == 0, res.output
    assert "  three_sigma: P(y < 3) >= 0.9973 at 90%: 852 / 1,440 / 1,970\n" in res.output
    assert "  q95: q0.95(y) < 3 at 95%: 59 / 93 / 124\n" in res.output


def test_the_requirements_gate_exits_by_the_verdicts(write_config, tmp_path):
    """A passing, a failing and an undecided requirement (3 sigma = 6.87 with P 0.99865):
    check --requirements exits 1 on the fail, or on the undecided one unless --undecided
    pass; run --check-requirements does the same at the end of the run."""
    from click.testing import CliRunner

    from uqguide.cli import main

    runner = CliRunner()
    ok = {**REQ, "name": "ok", "below": 3 * SIGMA}
    bad = {**REQ, "name": "bad", "below": 3 * SIGMA, "probability": 0.9999}
    open_ = {"name": "open", "output": "y", "quantile": 0.5, "below": 0.0, "confidence": 0.99}
    path = _cli_config(write_config, [ok, open_])
    out = tmp_path / "out"
    res = runner.invoke(main, ["run", str(path), "--out", str(out), "-q",
                               "--check-requirements"])
    assert res.exit_code == 1, res.output
    assert "mc: open UNDECIDED" in res.output
    assert "requirements: 1 of 2 verdicts pass the gate" in res.output
    h5 = str(out / "req.h5")
    res = runner.invoke(main, ["check", h5, "--requirements", "--undecided", "pass"])
    assert res.exit_code == 0 and "2 of 2 verdicts pass the gate - OK" in res.output
    assert runner.invoke(main, ["check", h5, "--requirements"]).exit_code == 1
    path = _cli_config(write_config, [ok, bad])
    res = runner.invoke(main, ["run", str(path), "--out", str(out), "-q", "--force",
                               "--check-requirements", "--undecided", "pass"])
    assert res.exit_code == 1 and "mc: bad FAIL" in res.output
    path = _cli_config(write_config, [ok])
    res = runner.invoke(main, ["run", str(path), "--out", str(out), "-q", "--force",
                               "--check-requirements"])
    assert res.exit_code == 0 and "1 of 1 verdicts pass the gate - OK" in res.output
    res = runner.invoke(main, ["check", h5, "--baseline", "b.json", "--undecided", "fail"])
    assert res.exit_code == 2 and "give it with --requirements" in res.output


def _sequential(below_sigmas, probability, cap=20_000, chunk=128, stop="decided", **method):
    m = {"name": "monte_carlo", "label": "mc", "n_samples": cap, "chunk_size": chunk,
         "bootstrap": 0, "sensitivity": "off", **method}
    if stop:
        m["stop_when"] = stop
    return _config([{**REQ, "below": below_sigmas * SIGMA, "probability": probability}], [m])


def test_stop_when_decided_needs_requirements():
    with pytest.raises(ConfigError, match=r"^methods\[0\]\.stop_when: 'decided' stops when "
                                          r"every requirement is decided"):
        validate_config({**LINEAR, "methods": [{"name": "monte_carlo", "n_samples": 100,
                                                "stop_when": "decided"}]})


def test_a_clearly_failing_requirement_stops_before_its_cap():
    """P(y < 2 sigma) = 0.977 against 0.9973: the sequence rules it out long before 20,000."""
    r = run(_sequential(2.0, 0.9973)).runs[0]
    assert r.verdicts["r"].verdict == "fail" and r.n_runs < 20_000
    assert r.verdicts["r"].basis.startswith("confidence sequence")
    assert r.n_runs % 128 == 0 and r.estimate.diagnostics["n_samples_cap"] == 20_000


def test_a_clearly_passing_requirement_stops_at_the_sequence_zero_failure_point():
    """P(y < 10 sigma) = 1 - 7.6e-24: no run fails, so the run stops at the first chunk after
    the least n with M_n(p) = a / (a + n) / p^n >= 1 / (1 - c) (prior Beta(a, 1), a = p / (1 -
    p)): n ln(1/p) >= ln(1/(1-c)) + ln(1 + n/a), i.e. n / n_plan <= 1 + ln(1 + n/a) / ln(1/(1-c))
    over the fixed plan's 852 (1.69 here)."""
    p, c = 0.9973, 0.9
    a = p / (1 - p)
    n_seq = next(n for n in range(1, 10**5)
                 if n * math.log(1 / p) >= math.log(1 / (1 - c)) + math.log(1 + n / a))
    plan = runs_to_pass(p, c)
    assert n_seq / plan <= 1 + math.log(1 + n_seq / a) / math.log(1 / (1 - c)) + 1 / plan
    assert n_seq / plan < 1.7
    r = run(_sequential(10.0, p)).runs[0]
    assert r.verdicts["r"].verdict == "pass"
    assert r.n_runs == 128 * math.ceil(n_seq / 128)  # 1536


def test_a_stopped_run_has_the_numbers_of_a_fixed_run_of_its_size(tmp_path):
    """The same rows and folds: every statistic and count of the run stopped at m equals the
    fixed run's with n_samples = m; resumed from its run folder it stops at the same chunk."""
    from uqguide.driver.run_folder import RunStore, run_identity

    cfg = _sequential(2.0, 0.9973)
    store = RunStore.open(tmp_path / "r.run", run_identity(cfg.resolved(), cfg.model),
                          resume=False)
    stopped = run(cfg, store=store).runs[0]
    m = stopped.n_runs
    fixed = run(_sequential(2.0, 0.9973, cap=m, stop=None)).runs[0]
    for name in ("mean", "std", "skewness", "kurtosis"):
        assert np.array_equal(getattr(stopped.estimate.stats["y"], name),
                              getattr(fixed.estimate.stats["y"], name))
    assert stopped.estimate.events == fixed.estimate.events
    assert np.array_equal(np.asarray(stopped.x), np.asarray(fixed.x))
    store = RunStore.open(tmp_path / "r.run", run_identity(cfg.resolved(), cfg.model),
                          resume=True)
    again = run(cfg, store=store).runs[0]
    assert again.n_runs == m and again.verdicts == stopped.verdicts


@pytest.mark.slow
def test_a_pool_stops_at_the_same_chunk_with_the_same_numbers():
    """Chunks in flight after the deciding one are dropped: two worker processes give the
    serial run's stopping point and statistics."""
    import uqguide

    cfg = _sequential(2.0, 0.9973)
    serial = run(cfg).runs[0]
    pooled = uqguide.run(cfg, workers=2).runs[0]
    assert pooled.n_runs == serial.n_runs < 20_000
    assert np.array_equal(pooled.estimate.stats["y"].mean, serial.estimate.stats["y"].mean)
    assert pooled.verdicts == serial.verdicts


def test_the_gate_refuses_a_config_or_result_without_requirements(write_config, tmp_path):
    from click.testing import CliRunner

    from uqguide.cli import main

    runner = CliRunner()
    res = runner.invoke(main, ["run", str(_cli_config(write_config, [], n=100)), "--out",
                               str(tmp_path), "--check-requirements"])
    assert res.exit_code == 2 and "lists no requirements" in res.output
    assert not (tmp_path / "req.h5").exists()  # refused before running
    h5 = write_hdf5(run(_config([], [{"name": "monte_carlo", "n_samples": 100}])),
                    tmp_path / "plain.h5")
    res = runner.invoke(main, ["check", str(h5), "--requirements"])
    assert res.exit_code == 2
    assert "error: the result holds no requirement verdicts" in res.output


@pytest.mark.parametrize("stop", [None, "decided"])
def test_a_requirement_on_one_component_of_a_multi_component_output(stop):
    """y = (x, 2 x), x ~ N(0, 1): on component 1, P(y[1] < 3) = Phi(1.5) = 0.9332, clear of
    0.9 (pass) and 0.97 (fail) by 6 of its standard errors at 2,000 runs (0.0056); the other
    component's P(y[0] < 3) = 0.9987 would pass both. The estimate is the runs' own fraction."""
    model = {"model": {"name": "linear_gaussian", "coefficients": [[1.0], [2.0]]},
             "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}]}
    reqs = [{"name": n, "output": "y", "component": 1, "below": 3.0, "probability": p,
             "confidence": 0.9} for n, p in (("ok", 0.9), ("bad", 0.97))]
    method = {"name": "monte_carlo", "label": "mc", "n_samples": 2000, "chunk_size": 250,
              "bootstrap": 0, "sensitivity": "off"}
    if stop:
        method["stop_when"] = stop
    r = run(validate_config({**model, "methods": [method], "requirements": reqs})).runs[0]
    assert stats.norm.cdf(1.5) == pytest.approx(0.9332, abs=1e-4)
    assert (r.verdicts["ok"].verdict, r.verdicts["bad"].verdict) == ("pass", "fail")
    y = r.scalars["y"][~r.failed]
    for name in ("ok", "bad"):
        assert r.verdicts[name].estimate == np.count_nonzero(y[:, 1] < 3.0) / len(y)
        assert r.verdicts[name].runs == len(y)
