"""What a baseline can be trusted for (issue 44, item 10): error bars that fit its own numbers,
run counts comparable with the result's, and the keyed seal (``UQGUIDE_BASELINE_KEY``).

Linear-Gaussian outputs: ``y1 = s (x1 + 2 x2 - 0.5 x3) + b1`` with ``x ~ N(1, 1)``, so a scale
``s`` of 1.1 with ``b1 = -0.25`` moves the std by exactly 10% (the same seed's runs scaled) and
keeps the mean; with 4000 runs the std's delta-method standard error is ``sqrt(2 / 16000)`` =
1.1% of it, the combined one 1.6%, a 10% move 6.3 combined errors (fails at 4), and a
``std_se`` x2.9 would have made it 3.1 (passed).
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import pytest
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.errors import ResultError
from uqguide.gate.baseline import (KEY_ENV, delta_std_se, make_baseline, parse_baseline,
                                   read_baseline, sealed, to_jsonable, write_baseline)
from uqguide.gate.check import RUNS_RATIO, check_result
from uqguide.results.result import write_hdf5

GOLDEN = Path(__file__).parent / "golden"


def config(scale: float = 1.0, offset: float = 1.0, n: int = 4000, seed: int = 1) -> dict:
    return {
        "model": {"name": "linear_gaussian", "n_times": 3,
                  "coefficients": [[scale, 2.0 * scale, -0.5 * scale], [0.5, 0.0, 1.5]],
                  "offset": [offset, 0.0]},
        "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 1.0, "std": 1.0}
                   for i in (1, 2, 3)],
        "outputs": ["y"],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n}],
        "seed": seed,
    }


@pytest.fixture(autouse=True)
def _no_key(monkeypatch):
    monkeypatch.delenv(KEY_ENV, raising=False)


@pytest.fixture(scope="module")
def base_result():
    return run(validate_config(config()))


@pytest.fixture(scope="module")
def wider_result():
    """The same runs with y1's spread 10% wider and its mean kept (2.5 s + b1 = 2.5)."""
    return run(validate_config(config(scale=1.1, offset=1.0 - 0.25)))


def _y1(data: dict) -> dict:
    return data["methods"]["mc"]["outputs"]["y"]["points"][0]


def _std_row(rep):
    return next(r for r in rep.rows if r.stat == "std" and r.component == "y1")


# ---------------------------------------------------------------------------- error bars
def test_mean_se_must_fit_std_and_runs_to_the_round_off(base_result):
    data = to_jsonable(make_baseline(base_result))
    parse_baseline(copy.deepcopy(data))
    p = _y1(data)
    assert p["mean_se"] == p["std"] / math.sqrt(4000)  # the result's own sem, bit for bit
    p["mean_se"] *= 1 + 1e-9  # passed the old 1e-6 rule
    with pytest.raises(ResultError, match=r"points\[0\]\.mean_se must be std / sqrt\(n_used\)"):
        parse_baseline(data)


def test_std_se_loosened_within_the_old_factor_3_loosens_nothing(base_result, wider_result):
    """The baseline's std error is recomputed from its own std, kurtosis and n_used: a stored
    std_se x2.9 (inside the x3 plausibility rule) gives the same tolerance, and a 10% std
    regression fails against it."""
    data = to_jsonable(make_baseline(base_result))
    edited = copy.deepcopy(data)
    p = _y1(edited)
    p["std_se"] = 2.9 * delta_std_se(p["std"], p["kurtosis"], 4000)
    honest, loosened = parse_baseline(data), parse_baseline(edited)
    assert _std_row(check_result(base_result, loosened)).tolerance == \
        _std_row(check_result(base_result, honest)).tolerance
    for b in (honest, loosened):
        rep = check_result(wider_result, b)
        row = _std_row(rep)
        assert row.value == pytest.approx(1.1 * row.baseline, rel=1e-12)
        assert not row.passed and abs(row.difference) > 1.5 * row.tolerance, row
        mean = next(r for r in rep.rows if r.stat == "mean" and r.component == "y1")
        assert mean.passed  # the mean kept: only the spread regressed


def test_a_baseline_of_far_fewer_runs_is_refused_and_far_more_is_said(tmp_path):
    """Consistent in itself (as written by uqguide) but of 20x fewer runs than the result: its
    standard errors, 4.5x the result's, would set the tolerance."""
    few = run(validate_config(config(n=150, seed=3)))
    many = run(validate_config(config(n=int(RUNS_RATIO * 150) + 50, seed=4)))
    h5 = write_hdf5(many, tmp_path / "many.h5")
    b = write_baseline(few, tmp_path / "few.json")
    res = CliRunner().invoke(main, ["check", str(h5), "--baseline", str(b)])
    assert res.exit_code == 2, res.output
    assert res.stderr.startswith(f"error: {b}: methods.mc.outputs.y.n_used: the baseline has "
                                 f"150 runs, the result 1550, more than 10x as many")
    assert len(res.stderr.strip().splitlines()) == 1
    # the other way round the check is only as tight as the result's runs: said, not refused
    rep = check_result(few, read_baseline(write_baseline(many, tmp_path / "many.json")))
    assert any("has 150 runs against the baseline's 1550" in n for n in rep.notes)
    # within 10x: nothing said
    rep = check_result(run(validate_config(config(n=1000, seed=5))), read_baseline(b))
    assert not any("runs against" in n for n in rep.notes)


# ---------------------------------------------------------------------------- keyed seal
def test_baseline_with_the_key_set_carries_a_seal_the_check_verifies(base_result, tmp_path,
                                                                     monkeypatch):
    h5 = write_hdf5(base_result, tmp_path / "r.h5")
    runner = CliRunner()
    monkeypatch.setenv(KEY_ENV, "k" * 32)
    b = tmp_path / "b.json"
    res = runner.invoke(main, ["baseline", str(h5), "-o", str(b)])
    assert res.exit_code == 0 and f"(sealed with the key in {KEY_ENV})" in res.output
    data = json.loads(b.read_text())
    assert data["seal"].startswith("hmac-sha256:") and list(data)[2:4] == ["digest", "seal"]
    res = runner.invoke(main, ["check", str(h5), "--baseline", str(b), "--require-key"])
    assert res.exit_code == 0, res.output
    assert "seal" not in res.output  # verified: nothing to say

    def check(path, *flags, key="k" * 32):
        if key is None:
            monkeypatch.delenv(KEY_ENV, raising=False)
        else:
            monkeypatch.setenv(KEY_ENV, key)
        return runner.invoke(main, ["check", str(h5), "--baseline", str(path), *flags])

    # an edit whose digest was redone (anyone can): the seal no longer fits, with or
    # without --require-key, as does a seal made with another key
    edited = copy.deepcopy(data)
    _y1(edited)["mean"] += 8 * _y1(edited)["mean_se"]
    forged = tmp_path / "forged.json"
    forged.write_text(json.dumps(_redigest(edited)))  # the old seal kept
    for path, key in ((forged, "k" * 32), (b, "another key")):
        for flags in ((), ("--require-key",)):
            res = check(path, *flags, key=key)
            assert res.exit_code == 2, res.output
            assert "keyed seal does not match its content" in res.stderr
    # the seal stripped and the digest redone: only --require-key refuses it
    stripped = tmp_path / "stripped.json"
    stripped.write_text(json.dumps(sealed({k: v for k, v in data.items() if k != "seal"})))
    res = check(stripped, "--require-key")
    assert res.exit_code == 2 and "the baseline has no keyed seal" in res.stderr
    res = check(stripped)
    assert res.exit_code == 0 and "the baseline has no keyed seal" in res.output
    # --require-key without a key (unset or empty) verifies nothing: refused
    for key in (None, ""):
        res = check(b, "--require-key", key=key)
        assert res.exit_code == 2 and f"{KEY_ENV} is not set" in res.stderr
    # a sealed baseline read without the key passes, saying its seal was not verified
    res = check(b, key=None)
    assert res.exit_code == 0 and "keyed seal is not verified" in res.output


def _redigest(d: dict) -> dict:
    from uqguide.gate.baseline import baseline_digest

    return d | {"digest": baseline_digest(d)}


def test_run_check_require_key(tmp_path, monkeypatch):
    """`run --check B --check-require-key` refuses an unsealed baseline before any run."""
    import yaml

    cfg = tmp_path / "c.yaml"
    cfg.write_text(yaml.safe_dump(config(n=50)))
    runner = CliRunner()
    res = runner.invoke(main, ["run", str(cfg), "--check-require-key", "-q"])
    assert res.exit_code == 2 and "--check-require-key compares with a baseline" in res.output
    b = write_baseline(run(validate_config(config(n=50))), tmp_path / "b.json")
    monkeypatch.setenv(KEY_ENV, "some key")
    res = runner.invoke(main, ["run", str(cfg), "--out", str(tmp_path / "out"), "-q",
                               "--check", str(b), "--check-require-key"])
    assert res.exit_code == 2 and "the baseline has no keyed seal" in res.stderr
    assert not (tmp_path / "out").exists()  # refused before anything ran


def test_golden_baselines_read_as_before_and_require_key_refuses_them(monkeypatch):
    """Old baselines (no seal) stay readable with or without a key set; --require-key refuses
    them: they were written without one."""
    path = GOLDEN / "benchmark_linear_gaussian.baseline.json"
    read_baseline(path)
    monkeypatch.setenv(KEY_ENV, "some key")
    read_baseline(path)
    with pytest.raises(ResultError, match="no keyed seal"):
        read_baseline(path, require_key=True)
