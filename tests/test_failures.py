"""Per-sample failures: exact counts and reasons, statistics of the rest, the failure budget,
the PCE failure policy setting."""

from __future__ import annotations

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.results.result import read_hdf5
from uqguide.stats.moments import sample_statistics

from tests.failing_models import failing_region

N = 4000


def _config(function: str, **top) -> dict:
    return {
        "model": {"name": "callable", "function": function, "inputs": ["a", "b"],
                  "outputs": [{"name": "path", "kind": "series"}, "y",
                              {"name": "ab", "components": 2}]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "uniform", "low": -1.0, "high": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": N, "chunk_size": 1000,
                     "bootstrap": 0}],
        "batch_size": 250,
        "seed": 21,
        **top,
    }


def test_five_percent_failures_exact_counts_and_statistics_of_the_rest():
    cfg = validate_config(_config("tests.failing_models:flaky", max_failed_fraction=0.1))
    r = run(cfg).run("mc")
    a = r.x[:, 0]
    raised, nan = a > 1.96, a < -1.96  # P = 2.5% each
    np.testing.assert_array_equal(r.failed, raised | nan)
    assert r.n_failed == int((raised | nan).sum())
    assert 0.03 < r.n_failed / N < 0.07  # about 5%: binomial sd 0.35% at n = 4000
    assert set(r.reasons[raised]) == {"ValueError: a above 1.96"}
    assert set(r.reasons[nan]) == {"non-finite output value"}
    assert set(r.reasons[~r.failed]) == {""}
    assert f"ValueError: a above 1.96 ({raised.sum()})" in r.estimate.diagnostics[
        "failure_reasons"]

    # A clean run on the rest: the failure-free function on the surviving inputs, statistics by
    # the in-memory two-pass estimators. The streamed ones differ only by rounding: sums of
    # n = 3800 terms in another order (relative error <= n * eps ~ 1e-12) and 3 Pébay merges.
    keep = ~r.failed
    clean = validate_config(_config("tests.failing_models:clean")).model
    out = clean.evaluate(r.x[keep], ["a", "b"], ["path", "y", "ab"])
    for name in ("path", "y", "ab"):
        y = out.series[name] if name in out.series else out.scalars[name]
        ref = sample_statistics(y, bootstrap=0)
        got = r.estimate.stats[name]
        assert got.n_used == keep.sum()
        for k in ("mean", "std", "cov"):
            np.testing.assert_allclose(getattr(got, k), getattr(ref, k), rtol=1e-11,
                                       atol=1e-13, err_msg=f"{name} {k}")
        # skewness and kurtosis: the same relative error carried through mu3 / sigma^3
        # (near-zero skewness needs an absolute floor)
        np.testing.assert_allclose(got.skewness, ref.skewness, rtol=1e-9, atol=1e-11)
        np.testing.assert_allclose(got.kurtosis, ref.kurtosis, rtol=1e-9)
        if name in out.scalars:  # the per-sample scalars kept are the model's values
            np.testing.assert_array_equal(r.scalars[name][keep], out.scalars[name])
    np.testing.assert_allclose(r.estimate.scalar_cov,
                               np.cov(np.column_stack([out.scalars["y"], out.scalars["ab"]]).T,
                                      ddof=0), rtol=1e-11, atol=1e-13)


def test_failure_budget_exceeded_is_exit_1_with_the_result_written(write_config, tmp_path):
    path = write_config(_config("tests.failing_models:flaky"), "flaky.yaml")
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path)])
    assert res.exit_code == 1
    r = read_hdf5(tmp_path / "flaky.h5").run("mc")  # written, for inspection
    raised = int((r.x[:, 0] > 1.96).sum())
    nan = int((r.x[:, 0] < -1.96).sum())
    assert res.stderr.strip().splitlines()[-1] == (
        f"error: mc: {raised + nan} of {N} runs failed ({100 * (raised + nan) / N:.3g}%: "
        f"ValueError: a above 1.96 ({raised}); non-finite output value ({nan})); above "
        f"max_failed_fraction = 0.01")
    assert "Traceback" not in res.output
    ok = CliRunner().invoke(main, ["run", str(write_config(
        _config("tests.failing_models:flaky", max_failed_fraction=0.1), "ok.yaml")),
        "--out", str(tmp_path)])
    assert ok.exit_code == 0, ok.output


def test_a_model_breaking_its_contract_is_not_a_sample_failure(write_config, tmp_path):
    cfg = _config("tests.failing_models:clean_sum")  # an array, where series need a dict
    res = CliRunner().invoke(main, ["run", str(write_config(cfg)), "--out", str(tmp_path)])
    assert res.exit_code == 1
    assert res.stderr.strip().splitlines()[-1] == (
        "error: a function with series outputs must return a dict")
    assert not (tmp_path / "config.h5").exists()


@pytest.mark.parametrize("policy", [None, "fail", "regression"])
def test_pce_failure_policy_reaches_every_method(policy):
    cfg = _config("tests.failing_models:clean")
    if policy:
        cfg["pce_failure_policy"] = policy
    c = validate_config(cfg)
    assert [m.context.failure_policy for m in c.methods] == [policy or "fail"]
    assert c.resolved()["pce_failure_policy"] == (policy or "fail")


def test_pce_failure_policy_is_checked(write_config):
    text = yaml.safe_dump(_config("tests.failing_models:clean", pce_failure_policy="refit"))
    res = CliRunner().invoke(main, ["validate", str(write_config(text))])
    assert res.exit_code == 2
    assert res.stderr.strip() == ("error: pce_failure_policy: unknown value 'refit'; allowed: "
                                  "fail, regression")


def test_pce_failure_policy_end_to_end(write_config, tmp_path):
    # 3 x 3 Gauss-Hermite nodes; the 3 with a = sqrt(3) raise. Default: the method fails
    # (exit 1) naming the failed runs. regression: a least-squares fit on the 6 others, exact
    # for this linear model (y = a + 2 b); its moments would be those over the whole space,
    # failure region included, so they are withheld (no runs sample the inputs: no +mc).
    cfg = {
        "model": {"name": "callable", "function": "tests.failing_models:linear_raises_above",
                  "inputs": ["a", "b"], "outputs": ["y"]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "pce_tensor", "label": "pt", "m": 3}],
        "max_failed_fraction": 0.5,
    }
    res = CliRunner().invoke(main, ["run", str(write_config(cfg, "f.yaml")), "--out",
                                    str(tmp_path)])
    assert res.exit_code == 1
    assert res.stderr.strip().splitlines()[-1].startswith(
        "error: pt: 3 of 9 quadrature runs failed (")
    assert "set pce_failure_policy: regression" in res.stderr
    cfg["pce_failure_policy"] = "regression"
    res = CliRunner().invoke(main, ["run", str(write_config(cfg, "r.yaml")), "--out",
                                    str(tmp_path)])
    assert res.exit_code == 0, res.output
    r = read_hdf5(tmp_path / "r.h5").run("pt")
    assert r.n_failed == 3
    s = r.estimate.stats["y"]
    assert np.isnan([s.mean[0], s.std[0]]).all() and not s.fallback
    assert r.estimate.diagnostics["runs_failed.y"] == "3 of 9 runs failed"
    x = np.array([[2.0, -1.0], [0.5, 0.25]])
    np.testing.assert_allclose(read_hdf5(tmp_path / "r.h5").surrogate("pt")(x)["y"].ravel(),
                               x[:, 0] + 2 * x[:, 1], atol=1e-10)


def test_one_failing_method_is_recorded_while_the_others_complete(write_config, tmp_path):
    # The tensor PCE needs every quadrature node and 3 of its 9 raise: it cannot produce
    # statistics. The Monte Carlo beside it must still complete, be written and be reported;
    # the run ends with exit 1 naming the method that failed.
    cfg = {
        "model": {"name": "callable", "function": "tests.failing_models:linear_raises_above",
                  "inputs": ["a", "b"], "outputs": ["y"]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "pce_tensor", "label": "pt", "m": 3},
                    {"name": "monte_carlo", "label": "mc", "n_samples": 2000, "bootstrap": 0}],
        "max_failed_fraction": 0.5,
        "seed": 3,
    }
    res = CliRunner().invoke(main, ["run", str(write_config(cfg, "two.yaml")), "--out",
                                    str(tmp_path)])
    assert res.exit_code == 1
    assert "Traceback" not in res.output
    assert res.stderr.strip().splitlines()[-1].startswith(
        "error: pt: 3 of 9 quadrature runs failed (")
    assert "Methods without statistics (the others completed):" in res.stdout
    result = read_hdf5(tmp_path / "two.h5")
    pt, mc = result.run("pt"), result.run("mc")
    assert not pt.success and pt.message.startswith("pt: 3 of 9 quadrature runs failed")
    assert pt.estimate.stats == {} and pt.n_failed == 3 and pt.n_runs == 9
    assert mc.success and mc.message == ""
    # y = a + 2 b over the runs that survive (a <= 1.5): a is a normal truncated above 1.5,
    # mean -phi(1.5) / Phi(1.5); the MC mean lies within 4 of its standard errors of it.
    from scipy.stats import norm

    s = mc.estimate.stats["y"]
    exact = -norm.pdf(1.5) / norm.cdf(1.5)
    assert abs(s.mean[0] - exact) < 4 * s.sem[0]
    from uqguide.report.tables import cost_table

    table = cost_table(result).set_index("label")
    assert table.loc["pt", "status"] == "FAILED: no statistics"
    assert table.loc["mc", "status"] == "ok"


def _region_config(**top) -> dict:
    """The issue's model that fails on 2% of its input space (a + b > 2.9), through a small
    adaptive PCE and a Monte Carlo."""
    return {
        "model": {"name": "callable", "function": "tests.failing_models:failing_region",
                  "inputs": ["a", "b", "c"], "outputs": ["y"]},
        "inputs": [{"name": n, "dist": "normal", "std": 1.0} for n in "abc"],
        "methods": [{"name": "pce_adaptive", "label": "pa", "n_samples": 60,
                     "validation": {"n_samples": 100}},
                    {"name": "monte_carlo", "label": "mc", "n_samples": 2000}],
        "max_failed_fraction": 0.5, "seed": 4, **top,
    }


def test_every_methods_failed_runs_are_said_once_with_their_interval(caplog):
    # The API warned only about Monte Carlo's failed runs: a PCE's are said too, one line per
    # method, with the share's Clopper-Pearson interval and what the statistics then are.
    import uqguide
    from uqguide.core.events import clopper_pearson

    with caplog.at_level("WARNING"):
        result = uqguide.run(_region_config())
    said = [rec.getMessage() for rec in caplog.records if "runs failed (" in rec.getMessage()]
    assert [s.split(":")[0] for s in said] == ["pa", "mc"]
    mc = result.run("mc")
    lo, hi = clopper_pearson(mc.n_failed, mc.n_runs)
    assert said[1] == (f"mc: {mc.n_failed:,} of {mc.n_runs:,} runs failed "
                       f"({100 * mc.n_failed / mc.n_runs:.3g}%, 95% interval "
                       f"{100 * lo:.3g}-{100 * hi:.3g}%); its statistics are conditional on "
                       f"success (the runs that failed are left out); reasons: non-finite "
                       f"output value ({mc.n_failed})")
    # the PCE's validation runs lean to the tails, where the runs fail: its share is that of
    # its runs weighted to the input distribution, whose interval holds the 2.0% the raw
    # count of its runs overstates
    pa = result.run("pa")
    d = pa.estimate.diagnostics
    assert said[0] == (f"pa: {pa.n_failed:,} of {pa.n_runs:,} runs failed "
                       f"({100 * d['failed_share']:.3g}% weighted to the input distribution, "
                       f"95% interval {100 * d['failed_share_low']:.3g}-"  # (above 0.001%)
                       f"{100 * d['failed_share_high']:.3g}%); its statistics are conditional "
                       f"on success (the runs that failed are left out); reasons: "
                       f"non-finite output value ({pa.n_failed})")
    assert d["failed_share_low"] <= 0.020 <= d["failed_share_high"] < pa.n_failed / pa.n_runs


def test_the_cli_summary_says_each_methods_failed_runs(write_config, tmp_path):
    res = CliRunner().invoke(main, ["run", str(write_config(_region_config(), "fr.yaml")),
                                    "--out", str(tmp_path)])
    assert res.exit_code == 0, res.output
    after = res.stdout.split("Failed runs (excluded from the statistics)")[1]
    # one line per method, wrapped at the console's 160 characters
    said = after.split("\nlabel ")[0].replace("\n ", " ").split("\n")
    said = [s for s in (x.strip() for x in said) if s]
    assert [s.split(":")[0] for s in said] == ["pa", "mc"]
    assert all("runs failed (" in s and "conditional on success" in s for s in said)
    # conditional on success inside the learnt success region: values with their intervals
    own = [line for line in res.stdout.splitlines()
           if line.split()[:1] == ["pa"] and line.count("[") == 4]  # the statistics' row
    assert len(own) == 1 and "withheld" not in own[0]


def test_a_pce_whose_runs_failed_gives_its_statistics_inside_the_success_region():
    # Fitted on the runs that succeeded, the polynomial integrated over the whole space gives
    # the 2.5 against the conditional 2.439: its draws inside the success region
    # learnt from the runs give the conditional statistics, with their intervals.
    import uqguide

    result = uqguide.run(_region_config())
    r = result.run("pa")
    assert r.n_failed > 0
    df = result.to_dataframe("y").set_index(["label", "statistic"])
    assert ("pa+mc", "mean") not in df.index
    d = r.estimate.diagnostics
    assert "runs_failed.y" not in d and d["success_region.y"] == d["success_region"]
    # the conditional moments by 1e6 inputs (their own standard errors 0.0012 for the mean,
    # negligible beside the intervals)
    x = np.random.default_rng(0).standard_normal((1_000_000, 3))
    y = failing_region(x)["y"]
    y = y[np.isfinite(y)]
    truth = {"mean": y.mean(), "std": y.std()}
    for stat, exact in truth.items():
        for label in ("pa", "pa+cv"):
            row = df.loc[(label, stat)]
            assert row.ci_low <= exact <= row.ci_high, (label, stat, row, exact)
    # not the polynomial's mean over the whole space, failure region included (2.5)
    assert abs(df.loc[("pa", "mean"), "value"] - truth["mean"]) < 0.5 * (2.5 - truth["mean"])


def test_a_pce_whose_failures_no_region_explains_gives_the_mc_estimate_of_its_runs():
    # Failures scattered with no region: the classifier checked on the validation runs does no
    # better than "every run succeeds", so the own and +cv values are withheld, with the
    # reason, and the +mc estimate of its successful runs stands instead.
    import uqguide

    cfg = {
        "model": {"name": "callable", "function": "tests.failing_models:sum_fails_at_random",
                  "inputs": ["a", "b"], "outputs": ["y"]},
        "inputs": [{"name": n, "dist": "normal", "std": 1.0} for n in "ab"],
        "methods": [{"name": "pce_adaptive", "label": "pa", "n_samples": 30,
                     "validation": {"n_samples": 40}}],
        "max_failed_fraction": 0.5, "seed": 2,
    }
    result = uqguide.run(cfg)
    r = result.run("pa")
    d = r.estimate.diagnostics
    assert r.n_failed > 0
    assert d["runs_failed.y"] == f"{r.n_failed} of {r.n_runs} runs failed"
    assert "success_region.y" not in d and "no better than" not in d["success_region"]
    df = result.to_dataframe("y").set_index(["label", "statistic"])
    assert np.isnan(df.loc[("pa", "mean"), "value"])
    assert ("pa+cv", "mean") not in df.index
    row = df.loc[("pa+mc", "mean")]
    # failures independent of the inputs: the mean of a + b conditional on success is ~0
    assert row.ci_low <= 0.0 <= row.ci_high


# seed 1 in the default suite, the others with -m slow (the suite's CPU budget)
@pytest.mark.parametrize("seed", [1, pytest.param(2, marks=pytest.mark.slow),
                                  pytest.param(3, marks=pytest.mark.slow)])
def test_the_conditional_mean_of_a_half_space_failure_is_held(seed):
    # y = a + b failing where a > 1.5: conditional on success a is a normal truncated above
    # 1.5, mean -phi(1.5) / Phi(1.5) (b's is 0). The PCE's interval holds it at each seed;
    # the polynomial's mean over the whole space (0) lies outside it.
    import uqguide
    from scipy.stats import norm

    exact = -norm.pdf(1.5) / norm.cdf(1.5)
    cfg = {
        "model": {"name": "callable", "function": "tests.failing_models:sum_nan_above",
                  "inputs": ["a", "b"], "outputs": ["y"]},
        "inputs": [{"name": n, "dist": "normal", "std": 1.0} for n in "ab"],
        "methods": [{"name": "pce_adaptive", "label": "pa", "n_samples": 30,
                     "surrogate_draws": 20_000, "validation": {"n_samples": 30}}],
        "max_failed_fraction": 0.5, "seed": seed,
    }
    result = uqguide.run(cfg)
    assert result.run("pa").n_failed > 0
    row = result.to_dataframe("y").set_index(["label", "statistic"]).loc[("pa", "mean")]
    assert row.ci_low <= exact <= row.ci_high, row


def test_a_stratified_design_conditional_on_success_shrinks_the_failing_stratum():
    # 10 runs in a stratum of share 0.9, 10 in one of share 0.1 of which 5 failed: conditional
    # on success the second holds 0.05 / 0.95 of the mass (successful() keeps its 0.1).
    from uqguide.pce.validation_design import ValidationDesign

    stratum = np.repeat([0, 1], 10)
    share = np.array([0.9, 0.1])
    design = ValidationDesign(u=np.full((20, 1), 0.5), weight=share[stratum] / 10,
                              stratum=stratum, share=share)
    ok = np.ones(20, dtype=bool)
    ok[15:] = False
    np.testing.assert_allclose(design.conditional(ok).share, [0.9 / 0.95, 0.05 / 0.95])
    np.testing.assert_allclose(design.conditional(ok).weight.sum(), 1.0)
    np.testing.assert_allclose(design.successful(ok).share, share)
