"""Checkpoint and resume: a run killed (SIGKILL) or interrupted (Ctrl-C) mid-way and resumed
gives the statistics of an uninterrupted run, runs only what is missing, and refuses a config
or model code that changed."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.results.result import read_hdf5

from .failing_models import mc_config, sigint_as_on_a_terminal

ROOT = Path(__file__).resolve().parents[1]


def _config(function: str, n: int = 2000, chunk: int = 100) -> dict:
    return mc_config(function, n, chunk, bootstrap=40)


def _stats(h5: Path) -> dict[str, np.ndarray]:
    r = read_hdf5(h5).run("mc")
    s = r.estimate.stats["y"]
    return {"mean": s.mean, "std": s.std, "skewness": s.skewness, "kurtosis": s.kurtosis,
            "cov": s.cov, **{f"ci_{k}": v for k, v in s.ci.items()}, "x": r.x,
            "y": r.scalars["y"], "n_runs": np.array(r.n_runs)}


def _assert_same(a: dict, b: dict) -> None:
    for k in a:
        np.testing.assert_array_equal(a[k], b[k], err_msg=k)


def _chunk_lines(manifest: Path) -> int:
    if not manifest.is_file():
        return 0
    return sum(1 for line in manifest.read_text().splitlines() if '"kind": "chunk"' in line)


@pytest.mark.slow  # a signal to a subprocess: the marker's 'crashes and signals'
def test_sigkill_mid_run_then_resume_equals_an_uninterrupted_run(tmp_path):
    cfg = tmp_path / "slow.yaml"
    cfg.write_text(yaml.safe_dump(_config("tests.failing_models:slow_sum")))
    calls = tmp_path / "calls.log"
    env = {**os.environ, "PYTHONPATH": str(ROOT), "UQGUIDE_TEST_CALL_LOG": str(calls)}
    out = tmp_path / "killed"
    manifest = out / "slow.run" / "manifest.jsonl"
    proc = subprocess.Popen([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                             str(out)], cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE)
    deadline = time.monotonic() + 60
    while _chunk_lines(manifest) < 5 and time.monotonic() < deadline:
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.05)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=10)
    proc.stderr.close()
    done = _chunk_lines(manifest)
    assert 5 <= done < 20, done  # killed mid-way: 20 chunks of 100 samples in all
    assert not (out / "slow.h5").exists()

    calls.write_text("")
    os.environ["UQGUIDE_TEST_CALL_LOG"] = str(calls)
    try:
        res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    finally:
        del os.environ["UQGUIDE_TEST_CALL_LOG"]
    assert res.exit_code == 0, res.output
    # only the missing chunks ran (a chunk the kill caught between its file and its manifest
    # line runs again: at most one more)
    n_calls = len(calls.read_text().split())
    assert 20 - done <= n_calls <= 20 - done + 1, (done, n_calls)
    assert not (out / "slow.run").exists()  # the result holds everything: the folder is gone

    # the uninterrupted reference: the same function without the pause (the samples depend on
    # the seed and the method label only)
    fast = tmp_path / "slow_ref.yaml"
    fast.write_text(yaml.safe_dump(_config("tests.failing_models:clean_sum")))
    ref = CliRunner().invoke(main, ["run", str(fast), "--out", str(tmp_path / "ref")])
    assert ref.exit_code == 0, ref.output
    _assert_same(_stats(tmp_path / "ref" / "slow_ref.h5"), _stats(out / "slow.h5"))


def run_to_ctrl_c(raw: dict, tmp_path, monkeypatch):
    """``uqguide run`` of ``raw`` (a ``ctrl_c_on_third_call`` model) into ``tmp_path/out``,
    stopped by the Ctrl-C the model stands for on its third call: (config, out, result)."""
    cfg = tmp_path / "cc.yaml"
    # the model's KeyboardInterrupt stands for a Ctrl-C of the driver: it must run there, not
    # in the guard process a callable runs in by default (whose death would be a crash)
    raw["model"]["isolate"] = False
    cfg.write_text(yaml.safe_dump(raw))
    monkeypatch.setenv("UQGUIDE_TEST_ARM_CTRL_C", "1")
    from tests import failing_models

    monkeypatch.setitem(failing_models._calls, "n", 0)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    monkeypatch.setenv("UQGUIDE_TEST_ARM_CTRL_C", "0")
    return cfg, out, res


@pytest.fixture
def interrupted(tmp_path, monkeypatch):
    """A run stopped by Ctrl-C on its third model call (2 of 10 chunks done)."""
    return run_to_ctrl_c(_config("tests.failing_models:ctrl_c_on_third_call", 1000), tmp_path,
                         monkeypatch)


def test_ctrl_c_leaves_a_resumable_run_with_a_clear_message(interrupted, tmp_path):
    cfg, out, res = interrupted
    assert res.exit_code == 130
    assert res.stderr.strip().splitlines()[-1] == (
        f"interrupted: 2 of 10 chunks done; resume with `uqguide run {cfg} --resume "
        f"--out {out}`")
    assert "Traceback" not in res.output
    assert _chunk_lines(out / "cc.run" / "manifest.jsonl") == 2
    # without --resume, the chunks done are not thrown away silently
    again = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert again.exit_code == 2
    assert again.stderr.strip().splitlines()[-1] == (
        f"error: {out / 'cc.run'} holds an unfinished run (2 chunks done); continue it with "
        f"`uqguide run {cfg} --resume --out {out}`, or delete the folder to start over")
    # a torn last manifest line (a kill while appending) is ignored
    with open(out / "cc.run" / "manifest.jsonl", "a") as f:
        f.write('{"kind": "chunk", "label": "mc", "sta')
    resumed = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    ref = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "ref")])
    assert ref.exit_code == 0
    _assert_same(_stats(tmp_path / "ref" / "cc.h5"), _stats(out / "cc.h5"))


def test_a_config_edited_between_run_and_resume_is_refused(interrupted):
    cfg, out, _ = interrupted
    edited = yaml.safe_load(cfg.read_text())
    edited["methods"][0]["n_samples"] = 1200
    cfg.write_text(yaml.safe_dump(edited))
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines()[-1] == (
        f"error: cannot resume {out / 'cc.run'}: the config changed since the run started "
        f"(methods[0].n_samples: 1000 -> 1200); start over with another --out, or delete the "
        f"folder")
    # the seed is part of the config
    edited["methods"][0]["n_samples"] = 1000
    cfg.write_text(yaml.safe_dump(edited))
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume",
                                    "--seed", "12"])
    assert res.exit_code == 2 and "(seed: 11 -> 12)" in res.stderr


def test_a_model_whose_code_changed_is_refused(tmp_path, monkeypatch):
    pkg = tmp_path / "usermod"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "f.py").write_text("def f(x):\n    return x[:, 0] + x[:, 1]\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    from uqguide.driver.run_folder import RunStore, run_identity
    from uqguide.config.run_config import validate_config

    c = validate_config(_config("usermod.f:f", 200))
    folder = tmp_path / "out" / "x.run"
    store = RunStore.open(folder, run_identity(c.resolved(), c.model), resume=False)
    from uqguide.driver.propagate import run

    run(c, store=store)
    (pkg / "f.py").write_text("def f(x):\n    return x[:, 0] - x[:, 1]\n")
    with pytest.raises(Exception) as err:
        RunStore.open(folder, run_identity(c.resolved(), c.model), resume=True)
    assert str(err.value) == (f"cannot resume {folder}: the code of model 'callable' changed "
                              f"since the run started; start over with another --out, or "
                              f"delete the folder")


def test_manifest_lines_and_chunk_files(tmp_path):
    from uqguide.driver.run_folder import RunStore, run_identity
    from uqguide.config.run_config import validate_config
    from uqguide.driver.propagate import run

    c = validate_config(_config("tests.failing_models:clean_sum", 300))
    store = RunStore.open(tmp_path / "r.run", run_identity(c.resolved(), c.model), resume=False)
    run(c, store=store)
    lines = [json.loads(x) for x in (tmp_path / "r.run" / "manifest.jsonl").read_text()
             .splitlines()]
    assert lines[0]["kind"] == "header" and lines[0]["config"] == c.resolved()
    assert [(e["index"], e["start"], e["stop"]) for e in lines[1:]] == [
        (0, 0, 100), (1, 100, 200), (2, 200, 300)]
    assert sorted(p.name for p in (tmp_path / "r.run").iterdir()) == [
        "manifest.jsonl", "mc.s0.c000000.npz", "mc.s0.c000001.npz", "mc.s0.c000002.npz"]


def test_a_checkpoint_write_that_fails_stops_the_run_and_lists_only_what_is_on_disk(
        tmp_path, monkeypatch):
    """Chunks are written by a background thread; its error (here a full disk at the second
    chunk) reaches the run, which fails with it, and the manifest lists exactly the chunk
    files written before it, so a resume re-runs the rest."""
    from uqguide.driver import run_folder as checkpoint
    from uqguide.driver.run_folder import RunStore, run_identity
    from uqguide.config.run_config import validate_config
    from uqguide.driver.propagate import run

    real = checkpoint.write_chunk
    written = []

    def full_disk(path, r, *args):
        if r.task.index == 1:
            raise OSError(28, "No space left on device")
        real(path, r, *args)
        written.append(path.name)

    monkeypatch.setattr(checkpoint, "write_chunk", full_disk)
    c = validate_config(_config("tests.failing_models:clean_sum", 500))
    store = RunStore.open(tmp_path / "r.run", run_identity(c.resolved(), c.model), resume=False)
    with pytest.raises(OSError, match="No space left"):
        try:
            run(c, store=store)
        finally:
            store.close()
    lines = [json.loads(x) for x in (tmp_path / "r.run" / "manifest.jsonl").read_text()
             .splitlines()][1:]
    assert [e["file"] for e in lines] == written == ["mc.s0.c000000.npz"]


@pytest.mark.slow
def test_ctrl_c_with_worker_processes_exits_130_without_traceback(tmp_path):
    # A real SIGINT to the whole process group, as a terminal's Ctrl-C: the workers ignore it
    # (from birth), the driver stops them, reports and leaves a resumable run.
    cfg = tmp_path / "slow.yaml"
    cfg.write_text(yaml.safe_dump(_config("tests.failing_models:slow_sum")))
    out = tmp_path / "out"
    manifest = out / "slow.run" / "manifest.jsonl"
    proc = subprocess.Popen([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                             str(out), "--workers", "2"], cwd=ROOT,
                            env={**os.environ, "PYTHONPATH": str(ROOT)},
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            start_new_session=True, preexec_fn=sigint_as_on_a_terminal)
    deadline = time.monotonic() + 60
    while _chunk_lines(manifest) < 3 and time.monotonic() < deadline:
        assert proc.poll() is None, proc.stderr.read().decode()
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=30)
    err = err.decode()
    done = _chunk_lines(manifest)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert err.strip().splitlines()[-1] == (
        f"interrupted: {done} of 20 chunks done; resume with `uqguide run {cfg} --resume "
        f"--out {out}`")
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert res.exit_code == 0, res.output
    fast = tmp_path / "ref.yaml"
    fast.write_text(yaml.safe_dump(_config("tests.failing_models:clean_sum")))
    assert CliRunner().invoke(main, ["run", str(fast), "--out", str(tmp_path)]).exit_code == 0
    _assert_same(_stats(tmp_path / "ref.h5"), _stats(out / "slow.h5"))


def test_resume_and_cleanup_leave_the_users_files_alone(interrupted, tmp_path):
    """A resumed run deleted a notes.txt left in its run folder, and a sub-folder there gave an
    IsADirectoryError traceback after the result was written, leaving a half-deleted folder that
    every later --resume crashed on. Only the files the run wrote are deleted now."""
    cfg, out, _ = interrupted
    folder = out / "cc.run"
    (folder / "notes.txt").write_text("why this run matters\n")
    (folder / "mine").mkdir()
    (folder / "mine" / "plot.png").write_bytes(b"\x89PNG")
    resumed = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert resumed.exit_code == 0, resumed.output
    assert "Traceback" not in resumed.output
    assert (out / "cc.h5").is_file()
    assert sorted(p.name for p in folder.iterdir()) == ["mine", "notes.txt"]
    assert (folder / "notes.txt").read_text() == "why this run matters\n"
    assert (folder / "mine" / "plot.png").read_bytes() == b"\x89PNG"
    # the folder is no longer the run's: a new run is refused, naming what is in the way
    again = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert again.exit_code == 2
    assert "is not a uqguide run folder" in again.output
    assert "'mine'" in again.output or "'notes.txt'" in again.output


def test_a_run_stopped_while_writing_its_result_is_recognised_as_finished(tmp_path,
                                                                          monkeypatch):
    """Every chunk done, then Ctrl-C while the tables were written: a plain rerun used to refuse
    with 'holds an unfinished run'; it now sees a finished run of the same config and runs it
    again (same numbers)."""
    from uqguide.commands import run_and_write as raw

    cfg = tmp_path / "w.yaml"
    cfg.write_text(yaml.safe_dump(_config("tests.failing_models:clean_sum", 400)))
    out = tmp_path / "out"

    def ctrl_c(*args, **kwargs):
        raise KeyboardInterrupt

    with monkeypatch.context() as m:
        m.setattr(raw, "write_tables", ctrl_c)
        stopped = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert stopped.exit_code == 130, stopped.output
    assert (out / "w.run" / "manifest.jsonl").is_file()
    again = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert again.exit_code == 0, again.output
    assert not (out / "w.run").exists()
    ref = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "ref")])
    assert ref.exit_code == 0
    _assert_same(_stats(tmp_path / "ref" / "w.h5"), _stats(out / "w.h5"))
