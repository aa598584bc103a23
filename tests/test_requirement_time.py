"""A requirement on a series output at a time (``time:``): judged on the value at the nearest
step, by a closed-form series model ``y(t) = a t``, ``a ~ N(1, 1)``."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.errors import ConfigError

GRID = np.linspace(0.0, 10.0, 11)


def ramp(x):
    """``y(t) = a t`` on 0..10 s in steps of 1 s, the two components ``(a t, -a t)`` as
    ``pair``, and ``a`` itself as the scalar ``gain``."""
    a = x[:, 0]
    y = a[:, None] * GRID[None, :]
    return {"time": GRID, "y": y, "pair": np.stack([y, -y], axis=2), "gain": a}


def _config(requirements, n=2000, methods=None, **method):
    m = {"name": "monte_carlo", "label": "mc", "n_samples": n, "chunk_size": 250,
         "bootstrap": 0, "sensitivity": "off", **method}
    return validate_config({
        "model": {"name": "callable", "function": "tests.test_requirement_time:ramp",
                  "isolate": False,  # (no guard process: a cheap default-suite test)
                  "inputs": ["a"], "outputs": [{"name": "y", "kind": "series"},
                                               {"name": "pair", "kind": "series",
                                                "components": 2}, "gain"]},
        "inputs": [{"name": "a", "dist": "normal", "mean": 1.0, "std": 1.0}],
        "methods": methods or [m], "requirements": requirements, "seed": 5})


def _req(name, probability, time=4.0, below=10.0, **extra):
    return {"name": name, "output": "y", "time": time, "below": below,
            "probability": probability, "confidence": 0.9, **extra}


def test_the_verdict_at_a_time_is_as_the_exact_probability_dictates():
    """P(y(4) < 10) = P(a < 2.5) = Phi(1.5) = 0.9332; 2,000 runs put the estimate's standard
    error at 0.0056: 0.9 passes and 0.97 fails by 6 of them, 0.9332 (the truth) stays
    undecided (the one-sided 90% bounds are 1.3 standard errors from the estimate, and it
    lies 1.3 of them from the truth with probability 0.2: the seed is fixed, checked here).
    Time 4.3 reads the step at 4 s, 4.6 the step at 5 s (P(a < 2) = Phi(1) = 0.841)."""
    p = float(stats.norm.cdf(1.5))
    reqs = [_req("ok", 0.9), _req("bad", 0.97), _req("edge", p),
            _req("near4", 0.9, time=4.3), _req("at5", 0.9, time=4.6)]
    r = run(_config(reqs)).runs[0]
    v = r.verdicts
    assert {k: v[k].verdict for k in v} == {"ok": "pass", "bad": "fail", "edge": "undecided",
                                           "near4": "pass", "at5": "fail"}
    a = r.scalars["gain"][:, 0]
    assert v["ok"].estimate == np.count_nonzero(a * 4.0 < 10.0) / a.size
    assert v["near4"].estimate == v["ok"].estimate and v["ok"].runs == a.size == 2000
    assert v["at5"].estimate == np.count_nonzero(a * 5.0 < 10.0) / a.size
    assert abs(v["ok"].estimate - p) < 4 * np.sqrt(p * (1 - p) / a.size)
    assert r.estimate.events["ok"].definition == "y@4 < 10"


def test_the_result_file_the_table_and_the_gate_carry_it(tmp_path):
    import pandas as pd

    from uqguide.gate.requirements import blocking_verdicts
    from uqguide.report.tables import write_tables
    from uqguide.results.result import read_hdf5, write_hdf5

    res = run(_config([_req("ok", 0.9), _req("bad", 0.97)], n=500))
    back = read_hdf5(write_hdf5(res, tmp_path / "r.h5"))
    assert back.runs[0].verdicts == res.runs[0].verdicts
    write_tables(back, tmp_path, "r")
    df = pd.read_csv(tmp_path / "r_requirements.csv")
    assert list(zip(df["requirement"], df["verdict"])) == [("ok", "pass"), ("bad", "fail")]
    assert [v.requirement for v in blocking_verdicts(back)] == ["bad"]


def test_a_component_of_a_series_at_a_time():
    """pair[1](4) = -4 a > -10 is a < 2.5 again: the same count as y(4) < 10."""
    reqs = [_req("y4", 0.9), {**_req("down4", 0.9, below=None), "output": "pair",
                              "component": 1, "above": -10.0}]
    r = run(_config(reqs)).runs[0]
    assert r.verdicts["down4"].verdict == "pass"
    assert r.verdicts["down4"].estimate == r.verdicts["y4"].estimate


def test_stop_when_decided_at_a_time():
    """A clear fail (Phi(1) = 0.841 against 0.97) stops before the cap of 20,000, on the
    series' values; its estimate is the fraction of the runs it kept."""
    r = run(_config([_req("at5", 0.97, time=5.0)], n=20_000, stop_when="decided")).runs[0]
    assert r.verdicts["at5"].verdict == "fail" and r.n_runs < 20_000
    a = r.scalars["gain"][:, 0]
    assert r.verdicts["at5"].estimate == np.count_nonzero(a * 5.0 < 10.0) / r.n_runs


@pytest.mark.parametrize("change, message", [
    ({"time": 12.0}, "requirements[0].time: 12 s is outside the time grid of 'y' [0, 10] s; "
                     "give a time within it"),
    ({"time": -0.6}, "requirements[0].time: -0.6 s is outside the time grid of 'y' [0, 10] s; "
                     "give a time within it"),
    ({"output": "gain"}, "requirements[0].time: 4 s on 'gain', a scalar output; time: is "
                         "allowed on a time series output only, remove it"),
    ({"time": None}, "requirements[0].output: 'y' is a time series; give a requirement on it "
                     "a time: (its value at the nearest step)"),
    ({"output": "pair", "component": 2},
     "requirements[0].component: component 2 is out of range 0..1"),
])
def test_bad_times_name_the_field_the_value_and_what_is_allowed(change, message):
    with pytest.raises(ConfigError) as err:
        _config([{**_req("r", 0.9), **change}])
    assert str(err.value) == message


def test_a_stopped_run_resumes_from_its_folder_to_the_same_verdict(tmp_path):
    """The kept values travel in the chunks' summaries: a run folder restores them, and the
    resumed run stops at the same chunk with the same verdict."""
    from uqguide.driver.run_folder import RunStore, run_identity

    cfg = _config([_req("at5", 0.9, time=5.0)], n=20_000, stop_when="decided")

    def store(resume):
        return RunStore.open(tmp_path / "r.run", run_identity(cfg.resolved(), cfg.model),
                             resume=resume)

    first = run(cfg, store=store(False)).runs[0]
    again = run(cfg, store=store(True)).runs[0]
    assert first.verdicts["at5"].verdict == "fail" and first.n_runs > 250
    assert again.n_runs == first.n_runs and again.verdicts == first.verdicts


def test_other_methods_state_it_undecided():
    r = run(_config([_req("ok", 0.9)], methods=[{"name": "pce_tensor", "label": "pt",
                                                  "surrogate_draws": 1000}])).runs[0]
    assert (r.verdicts["ok"].verdict, r.verdicts["ok"].basis) == ("undecided",
                                                                "no estimate of this event")
