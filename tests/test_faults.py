"""Fault reproducers (issue 15): runs that must not corrupt each other, escape --out, hang, sink
on one bad sample, exhaust memory, ignore Ctrl-C, leave half-written files, or pass a gate that
checks nothing. Each test is a reproducer of one failure mode, kept small and quick; none
asserts a timing."""

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
from uqguide.core import atomic
from uqguide.results.result import read_hdf5

from .failing_models import mc_config, sigint_as_on_a_terminal

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def _config(function: str = "tests.failing_models:clean_sum", n: int = 400, chunk: int = 50,
            seed: int = 11, **top) -> dict:
    return mc_config(function, n, chunk, seed, **top)


def _write(path: Path, cfg: dict) -> Path:
    path.write_text(yaml.safe_dump(cfg))
    return path


def _invoke(*args: str):
    return CliRunner().invoke(main, [str(a) for a in args])


def _chunk_lines(manifest: Path) -> list[dict]:
    if not manifest.is_file():
        return []
    out = []
    for line in manifest.read_text().splitlines():
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            continue
        if obj.get("kind") == "chunk":
            out.append(obj)
    return out


def _start_slow_run(cfg: Path, out: Path, extra_env: dict | None = None, *args: str):
    env = {**ENV, **(extra_env or {})}
    return subprocess.Popen([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                             str(out), *args], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE)


def _wait_for_chunks(proc, manifest: Path, n: int, timeout: float = 60) -> None:
    deadline = time.monotonic() + timeout
    while len(_chunk_lines(manifest)) < n:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline, "the run made no progress"
        time.sleep(0.05)


def _stop(proc, sig=signal.SIGKILL) -> None:
    if proc.poll() is None:
        proc.send_signal(sig)
    proc.communicate(timeout=30)


# ---------------------------------------------------------------------------- 1. run folder
@pytest.mark.slow
def test_a_second_run_into_the_same_folder_is_refused_naming_the_owner(tmp_path):
    cfg = _write(tmp_path / "slow.yaml", _config("tests.failing_models:slow_sum", n=2000,
                                                 chunk=100))
    out = tmp_path / "out"
    first = _start_slow_run(cfg, out)
    try:
        _wait_for_chunks(first, out / "slow.run" / "manifest.jsonl", 1)
        second = _invoke("run", cfg, "--out", out)
        assert second.exit_code == 2, second.output
        assert f"pid {first.pid}" in second.output and "in use" in second.output
        assert second.exception is None or isinstance(second.exception, SystemExit)
        resumed = _invoke("run", cfg, "--out", out, "--resume")
        assert resumed.exit_code == 2, resumed.output
        # the first run's folder is intact and still growing
        assert (out / "slow.run" / "manifest.jsonl").is_file()
    finally:
        _stop(first)


def test_a_lock_left_by_a_killed_run_is_taken_over_with_a_message(tmp_path, caplog):
    cfg = _write(tmp_path / "c.yaml", _config())
    out = tmp_path / "out"
    out.mkdir()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True).stdout.strip()
    (out / "c.run.lock").write_text(f"pid {dead} on host elsewhere\n")
    res = _invoke("run", cfg, "--out", out)
    assert res.exit_code == 0, res.output
    assert f"taking over the lock of a run that is gone (pid {dead}" in caplog.text
    assert not (out / "c.run.lock").exists() and not (out / "c.run").exists()


def _interrupted_run(tmp_path: Path, seed: int, sub: str) -> tuple[Path, Path]:
    """A run of 8 chunks stopped by SIGKILL after at least 3 chunks (its folder is left)."""
    cfg = _write(tmp_path / f"mix{sub}.yaml",
                 {**_config("tests.failing_models:slow_sum", n=800, chunk=100, seed=seed),
                  "name": "mix"})
    out = tmp_path / sub
    p = _start_slow_run(cfg, out)
    _wait_for_chunks(p, out / "mix.run" / "manifest.jsonl", 3)
    _stop(p)
    return cfg, out / "mix.run"


@pytest.mark.slow
def test_chunks_of_another_seed_are_refused_on_resume(tmp_path):
    """Issue 15 item 1: seed-11 chunks folded into a seed-12 resume exited 0 with wrong
    statistics. Both ways of mixing them in (manifest lines of the other run; chunk files of
    the other run under this run's manifest lines) must end in a clean refusal."""
    _, run11 = _interrupted_run(tmp_path, 11, "a")
    cfg12, run12 = _interrupted_run(tmp_path, 12, "b")
    own = _chunk_lines(run12 / "manifest.jsonl")
    foreign = _chunk_lines(run11 / "manifest.jsonl")
    header = (run12 / "manifest.jsonl").read_text().splitlines()[0]

    # (a) the other run's chunk lines and files, appended as a concurrent run would have
    for e in foreign:
        (run12 / e["file"]).write_bytes((run11 / e["file"]).read_bytes())
    (run12 / "manifest.jsonl").write_text(
        "\n".join([header] + [json.dumps(e) for e in foreign]) + "\n")
    res = _invoke("run", cfg12, "--out", run12.parent, "--resume")
    assert res.exit_code == 2, res.output
    assert "belongs to another run" in res.output
    assert not (run12.parent / "mix.h5").exists()

    # (b) this run's manifest lines, the other run's chunk files under their names
    fake = [{**e, "run": own[0]["run"]} for e in foreign]
    (run12 / "manifest.jsonl").write_text(
        "\n".join([header] + [json.dumps(e) for e in fake]) + "\n")
    res = _invoke("run", cfg12, "--out", run12.parent, "--resume")
    assert res.exit_code == 2, res.output
    assert "belongs to another run" in res.output
    assert not (run12.parent / "mix.h5").exists()


@pytest.mark.slow
def test_resume_after_a_kill_still_completes(tmp_path):
    cfg, run = _interrupted_run(tmp_path, 5, "k")
    res = _invoke("run", cfg, "--out", run.parent, "--resume")
    assert res.exit_code == 0, res.output
    assert read_hdf5(run.parent / "mix.h5").run("mc").n_runs == 800
    assert not run.exists()


# ---------------------------------------------------------------------------- 2. names
@pytest.mark.parametrize("name", ["/elsewhere/victim", "../../evil", "a/b", "..", ".",
                                  "evil\x00name", "spaced name", ""])
def test_a_name_that_is_not_a_plain_file_name_is_exit_2(tmp_path, name):
    victim = tmp_path / "elsewhere"
    (victim / "victim.run").mkdir(parents=True)
    (victim / "victim.run" / "keep.txt").write_text("mine")
    cfg = _config()
    cfg["name"] = name.replace("/elsewhere", str(victim))
    path = tmp_path / "c.yaml"
    path.write_text(json.dumps(cfg))  # JSON is YAML, and keeps the NUL byte escaped
    out = tmp_path / "sub" / "out"
    res = _invoke("run", path, "--out", out)
    assert res.exit_code == 2, res.output
    assert res.output.startswith("error: ") and "name" in res.output, res.output
    assert "Traceback" not in res.output
    assert (victim / "victim.run" / "keep.txt").read_text() == "mine"
    written = [p for p in tmp_path.rglob("*") if p.suffix in (".h5", ".csv", ".md")]
    assert written == []


def test_a_config_file_name_is_made_a_plain_name(tmp_path):
    path = _write(tmp_path / "my run (v2).yaml", _config(n=100))
    out = tmp_path / "out"
    res = _invoke("run", path, "--out", out)
    assert res.exit_code == 0, res.output
    assert (out / "my_run__v2_.h5").is_file()


def test_a_folder_at_the_run_path_that_is_not_a_run_folder_is_not_deleted(tmp_path):
    cfg = _write(tmp_path / "c.yaml", _config(n=100))
    out = tmp_path / "out"
    (out / "c.run").mkdir(parents=True)
    (out / "c.run" / "thesis.tex").write_text("years of work")
    res = _invoke("run", cfg, "--out", out)
    assert res.exit_code == 2, res.output
    assert "not a uqguide run folder" in res.output
    assert (out / "c.run" / "thesis.tex").read_text() == "years of work"


# ---------------------------------------------------------------------------- 3. all-failed
def test_a_chunk_in_which_every_sample_fails_is_counted():
    """Chunks of 1 sample of a model failing for |a| > 1.96 (raises above, NaN below): every
    failure is a chunk failing whole. Every failure is counted with its reason, the statistics
    are those of the rest."""
    from uqguide.config.run_config import validate_config
    from uqguide.driver.propagate import run

    cfg = _config("tests.failing_models:flaky", n=600, chunk=1, seed=3)
    cfg["model"]["outputs"] = ["y", {"name": "path", "kind": "series"}]
    r = run(validate_config(cfg)).runs[0]
    a = r.x[:, 0]
    bad = np.abs(a) > 1.96
    assert (a > 1.96).any() and (a < -1.96).any(), "the seed must give both failures"
    np.testing.assert_array_equal(r.failed, bad)
    assert r.estimate.diagnostics["n_failed"] == bad.sum()
    assert set(r.reasons[a > 1.96]) == {"ValueError: a above 1.96"}
    ok = ~bad
    y = a[ok] + r.x[ok, 1] ** 2
    np.testing.assert_allclose(r.estimate.stats["y"].mean, [y.mean()], rtol=1e-12)


def test_every_chunk_failing_is_a_clean_exit_1(tmp_path):
    cfg = _config("tests.failing_models:linear_raises_above", n=20, chunk=4)
    cfg["inputs"][0] = {"name": "a", "dist": "uniform", "low": 2.0, "high": 3.0}
    res = _invoke("run", _write(tmp_path / "c.yaml", cfg), "--out", tmp_path / "o")
    assert res.exit_code == 1, res.output
    assert "every one of the 20 runs failed" in res.output
    assert "Traceback" not in res.output


# ---------------------------------------------------------------------------- 7. the gate
@pytest.fixture(scope="module")
def gate_cases(tmp_path_factory):
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import fuzz_gate
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return fuzz_gate.build_cases(tmp_path_factory.mktemp("gate"))


# "sealed": the edit as if uqguide had written it (the structural checks and the comparison);
# "edited": by hand, refused by the digest whatever it did
GATE_SAMPLE = ["baseline, sealed: untouched", "baseline, sealed: methods empty",
               "baseline, sealed: mc outputs empty", "baseline, sealed: points empty",
               "baseline, sealed: unknown component", "baseline, sealed: series time null",
               "baseline, sealed: mean_se negative", "baseline, sealed: mean_se huge",
               "baseline, sealed: mean_se loosened 10x", "baseline, sealed: pce_rtol negative",
               "baseline, sealed: mean shifted 8 se", "baseline, edited: mean shifted 0.5 se",
               "baseline, edited: untouched",
               "baseline file: deep nesting", "check --sigmas inf", "check --sigmas nan",
               "check --pce-rtol nan", "result: config_yaml not yaml (check)",
               "result: config_yaml alias bomb (check)", "result: stats wrong shape (check)",
               "result: config_yaml not yaml (plot)", "result: config_yaml not yaml (report)",
               "result truncated (check)"]


@pytest.mark.parametrize("name", GATE_SAMPLE)
def test_the_gate_cannot_be_fooled_or_crashed(gate_cases, name):
    """A sample of benchmarks/fuzz_gate.py (run whole: 121 cases): an unusable input is exit
    2 with one error line, a real regression exit 1, never a traceback or 'PASS: 0'."""
    case = next(c for c in gate_cases if c.name == name)
    res = CliRunner().invoke(main, case.args)
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    assert res.exit_code == case.expect, res.output
    assert "PASS: 0 statistics" not in res.output
    if case.expect == 2:
        assert res.stderr.strip().splitlines()[-1].startswith(("error:", "Error:")), res.stderr


# ---------------------------------------------------------------------------- 8. loading
BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [{', '.join(['*' + p] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi"))


@pytest.mark.parametrize("text, message", [
    (BOMB, "anchor &a is not allowed"),
    ("model: &m {name: lognormal}\nother: *m\n", "anchor &m is not allowed"),
    ("model: {name: lognormal}\nmodel: {name: ishigami}\nmethods: []\n",
     "duplicate key 'model' (first at line 1)"),
    ("model: " + "[" * 100_000 + "]" * 100_000 + "\n", "nested deeper than 32 levels"),
    ("model: {name: lognormal}\nname: a\x00b\n", "NUL"),
    ("a: [*a]\n", "alias *a is not allowed"),
])
def test_yaml_that_would_explode_is_a_one_line_exit_2(tmp_path, text, message):
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    res = _invoke("validate", p)
    assert res.exit_code == 2, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"error: {p}: invalid YAML"), lines
    assert message in lines[0]


def test_a_config_file_over_1_mb_is_refused_before_parsing(tmp_path):
    p = tmp_path / "big.yaml"
    p.write_text("description: '" + "x" * 1_100_000 + "'\n")
    res = _invoke("validate", p)
    assert res.exit_code == 2 and "allowed at most 1000000" in res.output, res.output


@pytest.mark.parametrize("edit, field", [
    (lambda c: c.__setitem__("correlations", [{"inputs": ["a", "b"],
                                               "matrix": [[1, 0.5], [0.5]]}]),
     "correlations[0].matrix: must be 2x2"),
    (lambda c: c.__setitem__("description", "x\x00y"), "description: must not contain a NUL"),
])
def test_ragged_or_nul_values_are_exit_2(tmp_path, edit, field):
    cfg = _config()
    cfg["inputs"][1] = {"name": "b", "dist": "normal", "std": 1.0}
    edit(cfg)
    p = tmp_path / "c.yaml"
    p.write_text(json.dumps(cfg))
    res = _invoke("validate", p)
    assert res.exit_code == 2, res.output
    assert res.stderr.strip().startswith(f"error: {field}"), res.stderr


# ---------------------------------------------------------------------------- 5. budgets
def _ftcapn(n: int, **model) -> dict:
    raw = yaml.safe_load((ROOT / "configs" / "ftcapn_table3.yaml").read_text())
    raw.pop("reference", None)
    raw["model"].update(model)
    raw["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": n}]
    return raw


def test_validate_prints_runs_and_memory_of_a_1e8_sample_run(tmp_path):
    raw = _ftcapn(12345)
    with_quantiles = yaml.safe_dump(raw).replace("n_samples: 12345", "n_samples: 1e8")
    raw.pop("quantiles")
    text = yaml.safe_dump(raw).replace("n_samples: 12345", "n_samples: 1e8")
    (tmp_path / "big.yaml").write_text(text)  # 1e8 as written: a YAML 1.2 float
    res = _invoke("validate", tmp_path / "big.yaml")
    assert res.exit_code == 0, res.output
    assert "mc: 100,000,000 model runs x 800 steps" in res.output
    assert "estimated peak memory" in res.output
    # exact quantiles would keep 32 GB of series values: refused before anything runs
    (tmp_path / "bigq.yaml").write_text(with_quantiles)
    res = _invoke("validate", tmp_path / "bigq.yaml")
    assert res.exit_code == 2 and "quantiles kept 32 GB" in res.output, res.output


def test_the_estimate_counts_the_values_exact_quantiles_keep():
    # Table 3 asks for quantiles: a 1e7-run Monte Carlo keeps omega_s and R at the 9 report
    # times and the last step, 2 x 1e7 x 10 x 2 x 8 B = 3.2 GB (measured peak 3.6 GB in all);
    # without quantiles the same run peaks at 0.81 GB
    from uqguide.config.budget import estimate
    from uqguide.config.run_config import validate_config

    raw = _ftcapn(10_000_000)
    with_q = estimate(validate_config(raw)).methods[0]
    assert with_q.parts["quantiles kept"] == pytest.approx(2 * 1e7 * 10 * 2 * 8.0)
    raw.pop("quantiles")
    assert "quantiles kept" not in estimate(validate_config(raw)).methods[0].parts


def test_a_run_over_max_memory_exits_2_before_allocating(tmp_path):
    cfg = {**_ftcapn(100_000_000), "max_memory": "2 GB"}
    res = _invoke("run", _write(tmp_path / "big.yaml", cfg), "--out", tmp_path / "o")
    assert res.exit_code == 2, res.output
    assert res.stderr.strip().splitlines()[-1].startswith(
        "error: max_memory: this run needs an estimated")
    assert not (tmp_path / "o").exists()  # refused before any folder, lock or design


@pytest.mark.parametrize("model, message", [
    ({"dt": 1e-9}, "model.dt: 1e-09 gives 4e+11 steps per run (t_max / dt); allowed at most "
                   "max_steps = 1e+07"),
])
def test_a_step_that_would_run_for_ever_is_refused(tmp_path, model, message):
    res = _invoke("validate", _write(tmp_path / "c.yaml", _ftcapn(100, **model)))
    assert res.exit_code == 2, res.output
    assert res.stderr.strip() == f"error: {message} (raise max_steps to run it anyway)"


def test_a_tensor_grid_too_large_to_build_is_refused_by_validate(tmp_path):
    raw = _ftcapn(100)
    raw["methods"] = [{"name": "pce_tensor", "m": 3}]  # 7 inputs: 3^7 = 2187 runs
    assert _invoke("validate", _write(tmp_path / "ok.yaml", raw)).exit_code == 0
    raw["methods"] = [{"name": "pce_tensor", "m": 6}]  # 6^7 runs: its 6^7 x 6^7 basis
    res = _invoke("validate", _write(tmp_path / "mem.yaml", raw))
    assert res.exit_code == 2 and "error: max_memory: " in res.output, res.output
    raw["methods"] = [{"name": "pce_tensor", "m": 20}]
    res = _invoke("validate", _write(tmp_path / "c.yaml", raw))
    assert res.exit_code == 2
    assert res.stderr.strip().startswith("error: methods[0].m: pce_tensor with m = 20 on 7 "
                                         "inputs is 1.28e+09 runs; allowed at most 2000000")


def test_the_design_is_made_per_chunk_and_identical_to_the_whole_one():
    from uqguide.config.run_config import validate_config
    from uqguide.core.types import GeneratedRows
    from uqguide.methods.monte_carlo import method_seed, unit_samples

    cfg = validate_config({**_config(n=1000, chunk=128), "correlations": []})
    m = cfg.methods[0]
    d = m.design(cfg.space, cfg.seed)
    assert isinstance(d.x, GeneratedRows)
    whole = cfg.space.from_unit(unit_samples(2, 1000, "random", 128, method_seed(cfg.seed, "mc")))
    np.testing.assert_array_equal(np.asarray(d.x), whole)
    np.testing.assert_array_equal(d.x[300:700], whole[300:700])


# ---------------------------------------------------------------------------- 9. interrupts
def _stats(h5: Path) -> dict[str, np.ndarray]:
    r = read_hdf5(h5).run("mc")
    s = r.estimate.stats["y"]
    return {"mean": s.mean, "std": s.std, "skewness": s.skewness, "kurtosis": s.kurtosis,
            "x": r.x, "y": r.scalars["y"], "failed": r.failed}


# slow: 21 CLI processes (~55 CPU-s), and its moments scale with one timed run, so a loaded
# machine lets most runs finish first. The default suite keeps the property in
# test_resume.py (Ctrl-C mid-run with workers: exit 130, no traceback, resume gives the
# uninterrupted numbers) and test_resume_after_a_kill_still_completes below.
@pytest.mark.slow
def test_sigint_or_sigterm_at_20_random_moments_is_exit_130_and_resumes_identically(tmp_path):
    """Signals land in the start-up, the chunks, the checkpoint writes, the result files and
    the clean-up. Every one ends in exit 130 without a traceback, leaves no temporary file, and
    ``--resume`` gives the uninterrupted run's numbers."""
    raw = _config("tests.failing_models:slow_sum", n=200, chunk=50)
    raw["methods"][0]["bootstrap"] = 20
    cfg = _write(tmp_path / "sig.yaml", raw)
    ref = _invoke("run", cfg, "--out", tmp_path / "ref")
    assert ref.exit_code == 0, ref.output
    expected = _stats(tmp_path / "ref" / "sig.h5")

    # The run's length is the shorter of two lone runs: the first one in a fresh clone also
    # writes the byte-code and kernel caches, and timing it alone once set the moments past the
    # end of the warm runs (6 of 20 signals came after a clean exit 0).
    spans = []
    for k in range(2):
        t0 = time.monotonic()
        whole = subprocess.run([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                                str(tmp_path / f"timed{k}")], cwd=ROOT, env=ENV,
                               capture_output=True)
        assert whole.returncode == 0, whole.stderr.decode()
        spans.append(time.monotonic() - t0)
    span = min(spans)
    # From 0.5 s: before that the interpreter is still starting (Python's own Ctrl-C applies
    # until uqguide's first line runs). To 0.8 of a lone run: four runs at a time on two cores
    # take longer than one alone, so every moment should fall inside its run.
    moments = np.random.default_rng(2026).uniform(0.5, max(0.6, 0.8 * span), 20)
    signals = [signal.SIGTERM if i % 5 == 4 else signal.SIGINT for i in range(20)]
    codes = []
    finished = []
    for wave in range(0, 20, 4):  # four runs at a time (each one's signal at its own moment)
        procs = []
        for i in range(wave, wave + 4):
            procs.append((i, subprocess.Popen(
                [sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                 str(tmp_path / f"o{i}")], cwd=ROOT, env=ENV, stdout=subprocess.PIPE,
                stderr=subprocess.PIPE, preexec_fn=sigint_as_on_a_terminal), time.monotonic()))
        for i, p, started in sorted(procs, key=lambda t: moments[t[0]]):
            time.sleep(max(0.0, started + moments[i] - time.monotonic()))
            p.send_signal(signals[i])
        for i, p, _ in procs:
            finished.append((i, p, *p.communicate(timeout=60)))
    for i, p, stdout, stderr in finished:
        at, sig, out = moments[i], signals[i], tmp_path / f"o{i}"
        codes.append(p.returncode)
        text = stderr.decode() + stdout.decode()
        assert "Traceback" not in text and "Aborted" not in text, text
        if p.returncode == 0:  # (a slow start-up can let a short run finish first)
            continue
        assert p.returncode == 130, (at, sig, text)
        if out.exists():
            assert not [f for f in out.rglob("*.tmp")], list(out.rglob("*"))
        res = _invoke("run", cfg, "--out", out, "--resume")
        assert res.exit_code == 0, res.output
        got = _stats(out / "sig.h5")
        for k in expected:
            np.testing.assert_array_equal(got[k], expected[k], err_msg=f"{k} after {at:.2f} s")
    print(f"exit codes at {np.round(np.sort(moments), 2)} s: {sorted(codes)}")
    # A signal after the run's end is a clean exit 0 and tests nothing, so most of them must
    # land inside; "most", not "all", as a loaded machine can still run one ahead of its moment.
    assert codes.count(130) >= 12, codes


@pytest.mark.slow
def test_sigterm_mid_run_is_exit_130_and_resumes_identically(tmp_path):
    """The default suite's one-moment version of the test above: SIGTERM (the signal the
    Ctrl-C test in test_resume.py does not send) once two chunks are written ends in exit 130
    without a traceback or a temporary file, and ``--resume`` gives the numbers of the same
    study run whole (``clean_sum`` is ``slow_sum`` without the pause)."""
    raw = _config("tests.failing_models:slow_sum", n=400, chunk=20)
    raw["methods"][0]["bootstrap"] = 20
    cfg = _write(tmp_path / "sig.yaml", raw)
    ref = _write(tmp_path / "ref.yaml", {**raw, "model": {
        **raw["model"], "function": "tests.failing_models:clean_sum"}})
    assert _invoke("run", ref, "--out", tmp_path / "ref").exit_code == 0
    expected = _stats(tmp_path / "ref" / "ref.h5")
    out = tmp_path / "o"
    p = _start_slow_run(cfg, out)
    _wait_for_chunks(p, out / "sig.run" / "manifest.jsonl", 2)
    p.send_signal(signal.SIGTERM)
    stdout, stderr = p.communicate(timeout=60)
    text = stderr.decode() + stdout.decode()
    assert p.returncode == 130, text
    assert "Traceback" not in text and "Aborted" not in text, text
    assert not [f for f in out.rglob("*.tmp")], list(out.rglob("*"))
    res = _invoke("run", cfg, "--out", out, "--resume")
    assert res.exit_code == 0, res.output
    got = _stats(out / "sig.h5")
    for k in expected:
        np.testing.assert_array_equal(got[k], expected[k], err_msg=k)


def test_an_interrupt_python_swallows_is_not_printed_and_is_raised_later(capsys):
    """A signal that lands in a ``__del__`` or a weakref callback (the import system's module
    locks have one) raises where Python cannot propagate it: it prints "Exception ignored ...
    Traceback" and goes on. The handler's interrupt is kept instead, unprinted, and raised at
    the next check (after a chunk, a deferred block, a command)."""
    import gc

    from uqguide.driver import interrupts

    class Finalised:
        def __del__(self):
            interrupts._handler(signal.SIGTERM, None)  # as if SIGTERM landed here

    hook = sys.unraisablehook
    previous = interrupts.install()
    try:
        Finalised()  # dropped at once: __del__ runs, its Terminated is swallowed
        gc.collect()
        assert "Traceback" not in capsys.readouterr().err
        with pytest.raises(interrupts.Terminated):
            interrupts.raise_swallowed()
        interrupts.raise_swallowed()  # raised once, then clear
        Finalised()
        with pytest.raises(interrupts.Terminated):
            with interrupts.deferred():
                pass
    finally:
        interrupts.restore(previous)
    assert sys.unraisablehook is hook


def test_stale_temporary_files_of_dead_processes_are_removed(tmp_path):
    cfg = _write(tmp_path / "c.yaml", _config(n=100))
    out = tmp_path / "out"
    (out / "c.run").mkdir(parents=True)
    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True).stdout)
    stale = [atomic.temp_path(out / "c.h5", dead), atomic.temp_path(out / "c_stats.csv", dead)]
    alive = atomic.temp_path(out / "c.h5", os.getppid())  # a live writer's file is left alone
    # a user's files named like temporary files, a dead PID in them, are not uqguide's
    users = [out / f".c.h5.{dead}.tmp", out / ".thesis.20240101.tmp",
             out / f".c.h5.{dead}.0123456789abcdef0123.tmp"]
    for p in [*stale, alive, *users]:
        p.write_bytes(b"half")
    res = _invoke("run", cfg, "--out", out)
    assert res.exit_code == 0, res.output
    assert not any(p.exists() for p in stale) and alive.exists()
    assert all(p.read_bytes() == b"half" for p in users)


# ---------------------------------------------------------------------------- 4. hangs, crashes
def _one_sample_above(n: int, chunk: int, seed: int) -> tuple[float, int]:
    """A threshold that exactly one sample's ``a`` exceeds, and that sample's row."""
    from uqguide.config.run_config import validate_config

    c = validate_config(_config(n=n, chunk=chunk, seed=seed))
    a = np.asarray(c.methods[0].design(c.space, c.seed).x)[:, 0]
    top = np.sort(a)[-2:]
    return float(top.mean()), int(np.argmax(a))


@pytest.mark.slow
@pytest.mark.parametrize("kind, workers", [("hang", None), ("crash", 2)])
def test_a_hanging_or_crashing_sample_costs_exactly_one_sample(tmp_path, monkeypatch, kind,
                                                               workers):
    n, chunk = 32, 8
    threshold, row = _one_sample_above(n, chunk, 11)
    monkeypatch.setenv(f"UQGUIDE_TEST_{kind.upper()}_ABOVE", str(threshold))
    cfg = _config(f"tests.failing_models:{kind}_above", n=n, chunk=chunk, timeout_s=2,
                  batch_size=chunk, max_failed_fraction=0.5)
    args = ["run", _write(tmp_path / "c.yaml", cfg), "--out", tmp_path / "o"]
    res = _invoke(*args, *(["--workers", str(workers)] if workers else []))
    assert res.exit_code == 0, res.output
    r = read_hdf5(tmp_path / "o" / "c.h5").run("mc")
    assert r.n_failed == 1 and r.failed[row], r.reasons[r.failed]
    reason = str(r.reasons[row])
    assert ("timeout_s = 2 s" in reason) if kind == "hang" else ("crashed" in reason), reason
    ok = ~r.failed
    np.testing.assert_array_equal(r.scalars["y"][ok, 0], r.x[ok, 0] + r.x[ok, 1])


# slow (~7 CPU-s of respawned workers): the default suite checks the same crash in a pool
# without a timeout in test_execution.py (the crashing sample fails alone, the pool goes on),
# and through the CLI with --workers 2 in the [crash-2] case above.
@pytest.mark.slow
def test_a_sample_that_kills_its_worker_fails_alone_without_a_timeout(tmp_path, monkeypatch):
    n, chunk = 32, 16
    threshold, row = _one_sample_above(n, chunk, 11)
    monkeypatch.setenv("UQGUIDE_TEST_CRASH_ABOVE", str(threshold))
    cfg = _config("tests.failing_models:crash_above", n=n, chunk=chunk, max_failed_fraction=0.5)
    res = _invoke("run", _write(tmp_path / "c.yaml", cfg), "--out", tmp_path / "o",
                  "--workers", "2")
    assert res.exit_code == 0, res.output
    r = read_hdf5(tmp_path / "o" / "c.h5").run("mc")
    assert r.n_failed == 1 and r.failed[row]


# ---------------------------------------------------------------------------- 6. orphans
@pytest.mark.slow  # a signal to a subprocess: the marker's 'crashes and signals'
def test_workers_die_with_a_killed_driver(tmp_path):
    """SIGKILL of the driver (the out-of-memory killer's way): its workers end too, and the
    caller's pipes close (communicate() returns) instead of being held for ever."""
    cfg = _write(tmp_path / "slow.yaml", _config("tests.failing_models:slow_sum", n=4000,
                                                 chunk=100))
    p = _start_slow_run(cfg, tmp_path / "o", None, "--workers", "2")
    _wait_for_chunks(p, tmp_path / "o" / "slow.run" / "manifest.jsonl", 2)
    children = subprocess.run(["pgrep", "-P", str(p.pid)], capture_output=True,
                              text=True).stdout.split()
    assert children, "the pool has workers"
    p.kill()
    p.communicate(timeout=30)  # hangs here if a worker still holds the pipes
    deadline = time.monotonic() + 30
    while any(Path(f"/proc/{c}").exists() and "Z" not in
              Path(f"/proc/{c}/stat").read_text().split()[2] for c in children if
              Path(f"/proc/{c}/stat").exists()):
        assert time.monotonic() < deadline, "workers outlived their driver"
        time.sleep(0.1)


# ---------------------------------------------------------------------------- config fuzz
def _run_a_parallel_kernel_here() -> None:
    import numba

    @numba.njit(parallel=True)
    def total(n):
        s = 0.0
        for i in numba.prange(n):
            s += i
        return s

    assert total(1000) == 499500.0


@pytest.mark.slow
def test_a_sample_of_the_config_fuzz_is_clean():
    """20 of benchmarks/fuzz_configs.py's 519 mutations (run whole: every invalid one a clean
    exit 2, 0 hangs, 0 tracebacks, 0 silent acceptances), each in a forked child killed
    after 20 s."""
    import random

    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import fuzz_configs
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    ms = fuzz_configs.mutations(heavy=False)  # (the 10 MB+ files take seconds to build)
    assert len(ms) >= 500
    rng = random.Random(15)
    sample = [m for m in ms if m.name.startswith(("alias bomb 9^9", "nested brackets 100000",
                                                  "file of 2 MB"))]
    sample += rng.sample(ms, 20 - len(sample))
    _run_a_parallel_kernel_here()  # as the suite's earlier tests may have: a fork is unsafe now
    outcomes = fuzz_configs.run_all(sample)
    bad = [(o.m.name, o.verdict, o.stderr[-200:]) for o in outcomes if o.verdict != "ok"]
    assert not bad, bad


def test_a_smolyak_grid_too_large_to_build_is_refused_by_validate(tmp_path):
    raw = _ftcapn(100)
    raw["methods"] = [{"name": "pce_smolyak", "level": 12, "nested": False}]
    res = _invoke("validate", _write(tmp_path / "c.yaml", raw))
    assert res.exit_code == 2, res.output
    assert res.stderr.strip().startswith("error: methods[0].level: pce_smolyak with level 12 "
                                         "on 7 inputs combines ")
    raw["methods"] = [{"name": "pce_smolyak", "level": 3, "nested": False}]
    res = _invoke("validate", _write(tmp_path / "ok.yaml", raw))
    assert res.exit_code == 0 and "pce_smolyak: up to 120 model runs" in res.output, res.output


def test_the_estimate_counts_the_bootstrap_sums_and_names_them_when_it_refuses(tmp_path):
    """Bootstrap intervals at every step passed the budget whatever their size. Each resample
    keeps four power sums per interval column: FTCAPN's 5 scalars and 2 series of 801 steps are
    5 + 2 x 801 = 1607 columns, so 2000 resamples are 2000 x 1607 x 4 x 8 B = 102.8 MB a set."""
    from uqguide.config.budget import estimate
    from uqguide.config.run_config import validate_config

    raw = _ftcapn(100_000)
    raw["methods"][0].update(intervals="bootstrap", bootstrap=2000, bootstrap_times="all")
    parts = estimate(validate_config(raw)).methods[0].parts
    assert parts["bootstrap sums"] == pytest.approx(2 * 2000 * (5 + 2 * 801) * 4 * 8.0)
    raw["methods"][0]["bootstrap_times"] = "report"  # 9 report times and the last step
    parts = estimate(validate_config(raw)).methods[0].parts
    assert parts["bootstrap sums"] == pytest.approx(2 * 2000 * (5 + 2 * 10) * 4 * 8.0)
    raw["methods"][0].update(intervals="delta")
    assert "bootstrap sums" not in estimate(validate_config(raw)).methods[0].parts
    # refused: by how much, and which setting to lower
    raw = {**_ftcapn(1_000_000), "max_memory": "2 GB"}
    raw.pop("quantiles")
    raw["methods"][0].update(intervals="bootstrap", bootstrap=20_000, bootstrap_times="all")
    res = _invoke("validate", _write(tmp_path / "boot.yaml", raw))
    assert res.exit_code == 2, res.output
    last = res.stderr.strip().splitlines()[-1]
    assert "its largest part, bootstrap" in last and "more than max_memory = 2 GB" in last
    assert "lower bootstrap (the resamples), or bootstrap_times: report" in last
