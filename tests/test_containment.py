"""A crashing or leaking sample costs that sample, even serially (issue 26).

A ``callable`` runs its model calls in a guard process by default when there are no workers
(the built-in simulators keep the in-process path); a segfault is bisected down to the samples
that cause it; the run folder lists them as they are found and a resume fails them without
running them again; ``max_memory`` caps every child process, so a leak fails its samples.
The whole acceptance (4 segfaults in 1000 samples, SIGKILL and ``--resume`` at many moments)
is ``benchmarks/contain_crashes.py``; its short form is the slow test at the end.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.driver.run_folder import RunStore, run_identity
from uqguide.driver.progress import Progress
from uqguide.driver.propagate import containment_of, propagate
from uqguide.results.result import read_hdf5

from .failing_models import mc_config

ROOT = Path(__file__).resolve().parents[1]


def _above(cfg: dict, k: int) -> float:
    """The threshold on ``a`` above which exactly ``k`` samples of ``cfg``'s design lie."""
    c = uqguide.load_config(cfg)
    x = c.methods[0].design(c.space, c.seed).x
    return float(np.sort(x[:, 0])[-k - 1])


def test_a_segfaulting_sample_costs_only_itself_in_a_serial_run(tmp_path, monkeypatch):
    cfg = {**mc_config("tests.failing_models:segfault_above", 32, 16),
           "max_failed_fraction": 0.5, "name": "seg"}
    thr = _above(cfg, 1)
    monkeypatch.setenv("UQGUIDE_TEST_SEGFAULT_ABOVE", repr(thr))
    path = tmp_path / "seg.yaml"
    path.write_text(yaml.safe_dump(cfg))
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 0, res.output
    r = read_hdf5(tmp_path / "o" / "seg.h5").run("mc")
    assert r.n_failed == 1
    np.testing.assert_array_equal(r.failed, r.x[:, 0] > thr)
    assert set(map(str, r.reasons[r.failed])) == {"model process crashed (exit code -11)"}
    ok = ~r.failed
    np.testing.assert_array_equal(r.scalars["y"][ok, 0], r.x[ok, 0] + r.x[ok, 1])


@pytest.mark.parametrize("model, isolate, expected", [
    ({"name": "callable", "function": "tests.failing_models:clean_sum", "inputs": ["a", "b"]},
     None, True),
    ({"name": "callable", "function": "tests.failing_models:clean_sum", "inputs": ["a", "b"]},
     False, False),
    ({"name": "lognormal", "a": [0.3, 0.2]}, None, False),
    ({"name": "lognormal", "a": [0.3, 0.2]}, True, True),
], ids=["callable", "callable-isolate-false", "built-in", "built-in-isolate-true"])
def test_a_callable_is_isolated_by_default_and_a_simulator_is_not(model, isolate, expected):
    names = model.get("inputs", ["x1", "x2"])
    cfg = {"model": {**model, **({} if isolate is None else {"isolate": isolate})},
           "inputs": [{"name": n, "dist": "normal", "std": 1.0} for n in names],
           "methods": [{"name": "monte_carlo", "n_samples": 10}], "max_memory": "3 GB"}
    c = containment_of(uqguide.load_config(cfg))
    assert (c.isolate, c.asked, c.memory_limit) == (expected, isolate is True, 3 * 10**9)


def test_isolate_must_be_a_boolean(write_config):
    cfg = mc_config("tests.failing_models:clean_sum", 10, 10)
    cfg["model"]["isolate"] = "yes"
    res = CliRunner().invoke(main, ["validate", str(write_config(cfg))])
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines() == [
        "error: model.isolate: must be true or false (got 'yes')"]


def test_a_resume_fails_known_crashers_without_running_them(tmp_path, monkeypatch):
    """The run folder lists two crashers (as a run killed while bisecting leaves it): the
    resumed stage fails them with the recorded reason, and the model is never called on
    them (it logs every single-sample call that would crash)."""
    cfg = uqguide.load_config({**mc_config("tests.failing_models:segfault_above", 32, 16),
                               "name": "known", "max_failed_fraction": 0.5})
    thr = _above(mc_config("tests.failing_models:segfault_above", 32, 16), 2)
    calls = tmp_path / "calls.log"
    monkeypatch.setenv("UQGUIDE_TEST_SEGFAULT_ABOVE", repr(thr))
    monkeypatch.setenv("UQGUIDE_TEST_CALL_LOG", str(calls))
    method = cfg.methods[0]
    design = method.design(cfg.space, cfg.seed)
    crashers = [int(i) for i in np.flatnonzero(design.x[:, 0] > thr)]
    store = RunStore.open(tmp_path / "known.run", run_identity(cfg.resolved(), cfg.model),
                          resume=False)
    for row in crashers:
        store.record_isolated("mc", 0, row, f"recorded crash of row {row}")
    store.close()
    store = RunStore.open(tmp_path / "known.run", run_identity(cfg.resolved(), cfg.model),
                          resume=True)
    try:
        r = propagate(method, cfg.model, cfg.space, cfg.outputs, cfg.seed, store=store,
                      progress=Progress(), design=design, containment=containment_of(cfg))
    finally:
        store.close()
    assert [int(i) for i in np.flatnonzero(r.failed)] == crashers
    assert [str(v) for v in r.reasons[r.failed]] == [f"recorded crash of row {i}"
                                                     for i in crashers]
    assert not calls.exists(), calls.read_text()


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_AS is Linux's")
def test_a_leaking_sample_fails_alone_under_max_memory(tmp_path, monkeypatch):
    """A call that keeps 4 GB (a leak) under ``max_memory: 1500 MB``: its guard process ends
    at the limit, the bisection finds the sample, the others keep their values."""
    cfg = {**mc_config("tests.failing_models:leak_above", 16, 16), "max_memory": "1500 MB",
           "max_failed_fraction": 0.5}
    thr = _above(cfg, 1)
    monkeypatch.setenv("UQGUIDE_TEST_LEAK_ABOVE", repr(thr))
    r = uqguide.run(cfg).run("mc")
    np.testing.assert_array_equal(r.failed, r.x[:, 0] > thr)
    assert str(r.reasons[r.failed][0]) == ("model process went over its memory limit "
                                           "(max_memory = 1431 MiB per process)")


@pytest.mark.slow
def test_acceptance_4_segfaults_in_1000_and_kill_resume_bit_identical():
    """benchmarks/contain_crashes.py, three kill points (about 40 s)."""
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import contain_crashes
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    one = contain_crashes.segfaults()
    assert (one["exit"], one["failed"]) == (0, 4), one
    for row in contain_crashes.kill_and_resume([2, 5, 8]):
        assert row["bit-identical"] and row["crashers run again"] == 0, row


def test_a_signal_swallowed_before_the_result_is_written_is_exit_130(tmp_path, monkeypatch):
    """A SIGTERM that lands in code that catches it (a user's bare ``except:``) used to let
    the run finish and exit 0, though the signal came before the result was written: the
    command now exits 130 (the result is whole, a resume or rerun gives the same numbers)."""
    from tests import failing_models

    monkeypatch.setattr(failing_models, "_swallowed", [])
    cfg = mc_config("tests.failing_models:swallows_a_sigterm", 40, 20)
    cfg["model"]["isolate"] = False  # the user's code runs in the driver, where signals land
    path = tmp_path / "sw.yaml"
    path.write_text(yaml.safe_dump(cfg))
    res = CliRunner().invoke(main, ["run", str(path), "--out", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 130, res.output
    assert res.stderr.strip().splitlines()[-1] == \
        "terminated (SIGTERM); nothing was left half-written"


def test_a_hard_link_at_the_lock_is_refused_before_anything_is_written(tmp_path):
    """Found by benchmarks/fuzz_containment.py: O_NOFOLLOW stops a symbolic link, not a
    second name of a file outside --out, which the lock truncated and wrote."""
    from uqguide.driver.run_folder import RunLock
    from uqguide.errors import ConfigError

    victim = tmp_path / "outside.txt"
    victim.write_text("the user's\n")
    (tmp_path / "out").mkdir()
    os.link(victim, tmp_path / "out" / "st.run.lock")
    with pytest.raises(ConfigError, match="is a hard link"):
        RunLock(tmp_path / "out" / "st.run").acquire()
    assert victim.read_text() == "the user's\n"


def test_a_folder_where_a_table_goes_is_refused_before_the_run(tmp_path, write_config):
    """Also found by the fuzzer: a user's folder named like a table stopped the run with a
    traceback after all its work, at the rename."""
    cfg = write_config({**mc_config("tests.failing_models:clean_sum", 20, 10), "name": "t"})
    (tmp_path / "o" / "t_stats.csv").mkdir(parents=True)
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "o"), "-q"])
    assert res.exit_code == 2, res.output
    assert res.stderr.strip().splitlines()[-1].startswith(
        f"error: --out: {tmp_path / 'o' / 't_stats.csv'} is a folder;")
    assert not (tmp_path / "o" / "t.h5").exists()
