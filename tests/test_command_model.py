"""The ``command`` model: a C program compiled once per session as the simulator.

The program computes ``y = 2 x1 + 0.5 x2^2`` and the series ``path = y t`` on t = 0.5, 1, 2;
``x1 ~ N(1, 0.5)`` and ``x2 ~ N(0.5, 1)`` give closed-form moments. The environment variable
``UQ_MODE`` makes it misbehave for the samples with ``x1 > UQ_THRESH``: write NaN, flag them in a
``failed`` column, abort, hang (with a forked child), or write a short or malformed file; or,
``mixed``, hang there, abort where ``x1 < UQ_LOW`` and write NaN where ``x2 > UQ_HIGH2``.
"""

from __future__ import annotations

import math
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import uqguide
from tests.doc_pages import blocks
from uqguide.errors import ConfigError, ModelError

A, B = 2.0, 0.5
M1, S1, M2, S2 = 1.0, 0.5, 0.5, 1.0

PROGRAM = r"""
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static double x1[100000], x2[100000];

int main(int argc, char **argv) {
    const char *mode = getenv("UQ_MODE") ? getenv("UQ_MODE") : "";
    double th = getenv("UQ_THRESH") ? atof(getenv("UQ_THRESH")) : INFINITY;
    double low = getenv("UQ_LOW") ? atof(getenv("UQ_LOW")) : -INFINITY;
    double high2 = getenv("UQ_HIGH2") ? atof(getenv("UQ_HIGH2")) : INFINITY;
    int mixed = !strcmp(mode, "mixed");
    char line[4096], spath[4096];
    int n = 0, flag = !strcmp(mode, "flag");
    if (argc < 3) return 2;
    FILE *in = fopen(argv[1], "r");
    if (!in || !fgets(line, sizeof line, in) || strcmp(line, "x1,x2\n")) return 3;
    while (n < 100000 && fscanf(in, "%lf,%lf", &x1[n], &x2[n]) == 2) n++;
    fclose(in);
    for (int i = 0; i < n; i++) {
        if (mixed && x1[i] < low) abort();
        if (x1[i] <= th) continue;
        if (!strcmp(mode, "abort")) abort();
        if (!strcmp(mode, "hang") || mixed) {
            if (fork() == 0) {
                snprintf(spath, sizeof spath, "%s/child-%d", getenv("UQ_PIDDIR"), getpid());
                fclose(fopen(spath, "w"));
            }
            for (;;) pause();
        }
    }
    snprintf(spath, sizeof spath, "%.*s_path.csv", (int)strlen(argv[2]) - 4, argv[2]);
    FILE *out = fopen(argv[2], "w"), *ser = fopen(spath, "w");
    fprintf(out, flag ? "y,failed,reason\n" : "y\n");
    fprintf(ser, "0.5,1,2\n");
    for (int i = 0; i < n - !strcmp(mode, "short"); i++) {
        int bad = x1[i] > th;
        double y = (bad && !strcmp(mode, "nan")) || (mixed && x2[i] > high2)
                   ? NAN : 2 * x1[i] + 0.5 * x2[i] * x2[i];
        if (!strcmp(mode, "malformed") && i == 2) fprintf(out, "%.17g;\n", y);
        else if (flag) fprintf(out, "%.17g,%d,%s\n", y, bad, bad ? "\"x1, too large\"" : "");
        else fprintf(out, "%.17g\n", y);
        fprintf(ser, "%.17g,%.17g,%.17g\n", 0.5 * y, y, 2 * y);
    }
    return fclose(out) || fclose(ser);
}
"""


@pytest.fixture(scope="session")
def program(tmp_path_factory) -> Path:
    """The C model, compiled once per session."""
    cc = shutil.which("cc")
    if cc is None:
        pytest.skip("no C compiler 'cc' on PATH: the command model's tests compile their "
                    "simulator")
    folder = tmp_path_factory.mktemp("csim")
    (folder / "sim.c").write_text(PROGRAM)
    subprocess.run([cc, "-O2", "-o", str(folder / "sim"), str(folder / "sim.c"), "-lm"],
                   check=True, capture_output=True, timeout=120)
    return folder / "sim"


def _config(program: Path | str, work: Path, *, n: int = 200, batch: int = 50, method=None,
            mode: str = "", thresh: float = math.inf, series: bool = True, **model) -> dict:
    outputs = ["y", {"name": "path", "kind": "series", "unit": "m"}] if series else ["y"]
    return {
        "model": {"name": "command", "command": f"{program} {{inputs}} {{outputs}}",
                  "inputs": ["x1", "x2"], "outputs": outputs, "workdir": str(work),
                  "env": {"UQ_MODE": mode, "UQ_THRESH": repr(float(thresh)),
                          "UQ_PIDDIR": str(work)}, **model},
        "inputs": [{"name": "x1", "dist": "normal", "mean": M1, "std": S1},
                   {"name": "x2", "dist": "normal", "mean": M2, "std": S2}],
        "methods": [method or {"name": "monte_carlo", "label": "mc", "n_samples": n}],
        "batch_size": batch, "max_failed_fraction": 0.5, "seed": 3,
    }


def _exact() -> dict[str, float]:
    """Moments of y = A x1 + B x2^2 from cumulants: x1 is normal, x2^2 / S2^2 is noncentral
    chi-square with one degree of freedom and lambda = (M2/S2)^2, cumulants
    2^(r-1) (r-1)! (1 + r lambda)."""
    lam = (M2 / S2) ** 2
    k = {r: B ** r * S2 ** (2 * r) * 2 ** (r - 1) * math.factorial(r - 1) * (1 + r * lam)
         for r in (1, 2, 3, 4)}
    k[1] += A * M1
    k[2] += A ** 2 * S1 ** 2
    return {"mean": k[1], "std": math.sqrt(k[2]), "skewness": k[3] / k[2] ** 1.5,
            "kurtosis": 3 + k[4] / k[2] ** 2}


def _x1(run) -> np.ndarray:
    return np.asarray(run.x)[:, 0]


def test_monte_carlo_through_the_c_program_matches_the_closed_form(program, tmp_path):
    r = uqguide.run(_config(program, tmp_path, n=400, batch=100))
    run = r.run("mc")
    assert run.n_failed == 0
    exact = _exact()
    y = run.estimate.stats["y"]
    assert abs(y.mean[0] - exact["mean"]) <= 4 * y.sem[0]
    # the std's standard error, normal-theory free: sqrt(Var[(y-mu)^2]) / (2 sigma sqrt(n))
    se_std = exact["std"] * math.sqrt(exact["kurtosis"] - 1) / (2 * math.sqrt(run.n_runs))
    assert abs(y.std[0] - exact["std"]) <= 4 * se_std
    path = run.estimate.stats["path"]
    np.testing.assert_array_equal(run.time, [0.5, 1.0, 2.0])
    # path = y t exactly: its mean at t = 2 is twice y's, to round-off
    assert path.mean[2, 0] == pytest.approx(2 * y.mean[0], rel=1e-14)
    # a successful call leaves no work folder behind
    assert list(tmp_path.iterdir()) == []


def test_adaptive_pce_reproduces_the_exact_moments(program, tmp_path):
    method = {"name": "pce_adaptive", "label": "apce", "n_samples": 40, "degree_max": 3,
              "enrich": False}
    r = uqguide.run(_config(program, tmp_path, method=method, batch=20, series=False))
    s = r.run("apce").estimate.stats["y"]
    for stat, value in _exact().items():
        assert s.stat(stat)[0] == pytest.approx(value, abs=1e-8, rel=1e-8), stat


def test_load_config_from_a_file_finds_a_relative_program_beside_it(program, tmp_path,
                                                                     write_config):
    shutil.copy(program, tmp_path / "sim")
    cfg = _config("./sim", tmp_path / "work", n=20, batch=20)
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    path = write_config(cfg)
    cwd = os.getcwd()
    os.chdir(elsewhere)
    try:
        loaded = uqguide.load_config(path)
        assert loaded.model.params.config_dir == str(tmp_path.resolve())
        assert uqguide.run(loaded).run("mc").n_failed == 0
    finally:
        os.chdir(cwd)


@pytest.mark.parametrize("mode,reason", [("nan", "non-finite output value"),
                                         ("flag", "x1, too large")])
def test_a_failing_sample_fails_alone_with_its_reason(program, tmp_path, mode, reason):
    run = uqguide.run(_config(program, tmp_path, mode=mode, thresh=1.8)).run("mc")
    bad = _x1(run) > 1.8
    assert 0 < bad.sum() < 20
    np.testing.assert_array_equal(run.failed, bad)
    assert set(run.reasons[bad]) == {reason}
    assert list(tmp_path.iterdir()) == []  # the batches themselves succeeded


def test_a_crashing_batch_is_split_until_exactly_the_crashing_samples_fail(program, tmp_path):
    run = uqguide.run(_config(program, tmp_path, mode="abort", thresh=1.8)).run("mc")
    bad = _x1(run) > 1.8
    assert 0 < bad.sum() < 20
    np.testing.assert_array_equal(run.failed, bad)
    for reason in run.reasons[bad]:
        assert reason.startswith("CommandFailed: the command was killed by signal SIGABRT; "
                                 "work folder kept: ")
        kept = Path(reason.split("work folder kept: ")[1].split(";")[0])
        assert (kept / "inputs.csv").read_text().count("\n") == 2  # header and the sample
    assert not np.isnan(run.scalars["y"][~bad]).any()


@pytest.mark.slow  # a few hundred program calls
def test_failed_calls_keep_at_most_keep_failed_work_folders(program, tmp_path, monkeypatch):
    """A batch split down to its crashing samples kept a folder per failed call (89 failures
    left 386 folders): past the bound the folder goes and the reason says so."""
    from uqguide.models.command import model

    monkeypatch.setattr(model, "KEEP_FAILED", 3)
    run = uqguide.run(_config(program, tmp_path, mode="abort", thresh=1.0)).run("mc")
    assert run.failed.sum() > 3  # each crashing sample's last call failed alone
    folders = list(tmp_path.glob("batch-*"))
    assert len(folders) == 3
    reasons = [str(r) for r in run.reasons[run.failed]]
    assert any(r.endswith("work folder removed (3 kept already)") for r in reasons)
    for r in reasons:
        if "work folder kept: " in r:
            assert Path(r.split("work folder kept: ")[1].split(";")[0]) in folders


def test_clean_removes_only_the_work_folders_uqguide_left(tmp_path):
    from click.testing import CliRunner

    from uqguide.cli import main

    gone = 99_999_999  # above Linux's pid_max: no process has it
    left = tmp_path / f"batch-{gone}-abcdefgh"
    (left / "sample-0").mkdir(parents=True)
    (left / "sample-0" / "inputs.csv").write_text("a\n1\n")
    running = tmp_path / f"batch-{os.getpid()}-abcdefgh"  # a call still running
    no_inputs = tmp_path / f"batch-{gone}-zzzzzzzz"  # not a call's folder
    user = tmp_path / "batch-notes"
    for d in (running, no_inputs, user):
        d.mkdir()
    (running / "inputs.csv").write_text("a\n")
    (user / "inputs.csv").write_text("a\n")
    link = tmp_path / f"batch-{gone}-linklink"
    link.symlink_to(running)
    res = CliRunner().invoke(main, ["clean", str(tmp_path), "--dry-run"])
    assert res.exit_code == 0 and left.exists(), res.output
    assert res.output.splitlines()[0] == f"would remove {left}"
    res = CliRunner().invoke(main, ["clean", str(tmp_path)])
    assert res.exit_code == 0, res.output
    assert not left.exists()
    assert all(p.exists() for p in (running, no_inputs, user, link))
    assert res.output.splitlines()[-1].startswith(f"1 work folders (0.00 MB) in {tmp_path}")


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie waiting for a reaper does not)."""
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    return "\nState:\tZ" not in status


def test_exactly_the_failing_hanging_and_crashing_samples_fail(program, tmp_path):
    """The issue's acceptance in small: 4 samples write NaN, 1 hangs (with a child it forked),
    1 crashes, among 300; the design is read first to pick them."""
    x = np.asarray(uqguide.run(_config(program, tmp_path, n=300, batch=300, series=False))
                   .run("mc").x)
    x1, x2 = np.sort(x[:, 0]), np.sort(x[:, 1])
    limits = {"thresh": (x1[-1] + x1[-2]) / 2, "UQ_LOW": (x1[0] + x1[1]) / 2,
              "UQ_HIGH2": (x2[-4] + x2[-5]) / 2}
    cfg = _config(program, tmp_path, n=300, batch=10, mode="mixed", thresh=limits["thresh"],
                  timeout_s=1.0)
    cfg["model"]["env"].update({k: repr(float(v)) for k, v in limits.items() if k != "thresh"})
    run = uqguide.run(cfg).run("mc")
    hang, crash = x[:, 0] > limits["thresh"], x[:, 0] < limits["UQ_LOW"]
    nan = (x[:, 1] > limits["UQ_HIGH2"]) & ~hang & ~crash
    assert (hang.sum(), crash.sum(), nan.sum()) == (1, 1, 4)
    np.testing.assert_array_equal(run.failed, hang | crash | nan)
    assert "did not finish within timeout_s = 1 s (its process group was killed)" in \
        run.reasons[hang][0]
    assert "killed by signal SIGABRT" in run.reasons[crash][0]
    assert set(run.reasons[nan]) == {"non-finite output value"}
    children = [int(p.name.split("-")[1]) for p in tmp_path.glob("child-*")]
    assert children, "the hanging program's child did not start"
    assert not [pid for pid in children if _alive(pid)]


@pytest.mark.slow  # seconds of waiting on timeouts
def test_the_runs_timeout_s_kills_the_program_and_its_children_not_only_the_guard(
        program, tmp_path):
    """The config-level ``timeout_s`` kills the guard process that waits for the program. The
    program runs in a session of its own, out of reach of that kill: it (and the child it
    forked) used to run on, one orphan per call of the bisection."""
    cfg = _config(program, tmp_path, n=8, batch=8, mode="hang", thresh=M1 + S1, series=False)
    cfg["timeout_s"], cfg["max_failed_fraction"] = 0.5, 1.0
    run = uqguide.run(cfg).run("mc")
    hang = _x1(run) > M1 + S1
    assert hang.any() and not hang.all()  # seed 3's design: both kinds of sample
    np.testing.assert_array_equal(run.failed, hang)
    children = [int(p.name.split("-")[1]) for p in tmp_path.glob("child-*")]
    assert len(children) >= hang.sum()  # one per call that reached a hanging sample
    time.sleep(0.2)  # the kernel's delivery of SIGKILL to the group
    assert not [pid for pid in children if _alive(pid)]


@pytest.mark.parametrize("mode,message", [
    ("short", r"outputs\.csv: 19 sample rows, expected 20 \(one per sample, in order\): "
              r"line 21 \(sample 19\) is missing"),
    ("malformed", r"outputs\.csv: line 4 \(sample 2\), column 1 'y': '[-0-9.e]+;' is not a "
                  r"number"),
])
def test_a_short_or_malformed_output_file_stops_the_run_naming_file_line_column(
        program, tmp_path, mode, message):
    with pytest.raises(ModelError, match=message) as err:
        uqguide.run(_config(program, tmp_path, n=20, batch=20, mode=mode))
    assert "work folder kept" in str(err.value)
    kept = str(err.value).split(" ")[0].rsplit("/", 1)[0]
    assert Path(kept, "outputs.csv").is_file()


def test_neither_an_argument_nor_an_input_name_can_run_a_command(program, tmp_path):
    cfg = _config(program, tmp_path, n=10, batch=10, series=False)
    cfg["model"]["command"] += " '; touch pwned' '$(touch pwned)' ; touch pwned"
    run = uqguide.run(cfg).run("mc")
    assert run.n_failed == 0  # the program got the arguments and ignored them
    assert not list(Path.cwd().glob("pwned")) and not list(tmp_path.rglob("pwned"))
    bad = _config(program, tmp_path, n=10, series=False)
    bad["model"]["inputs"] = ["x1; touch pwned", "x2"]
    with pytest.raises(ConfigError, match=r"model\.inputs: .*'x1; touch pwned' must be 1 to "
                                          r"200 letters"):
        uqguide.load_config(bad)


@pytest.mark.parametrize("edit,message", [
    ({"command": "./no-such-sim {inputs}"}, r"model\.command: .*no executable file"),
    ({"command": "{inputs} {output}"}, r"model\.command: .*unknown placeholder \{output\}"),
    ({"command": "sim 'unbalanced"}, r"model\.command: .*cannot be split"),
    ({"env": {"A B": "1"}}, r"model\.env: .*'A B' must be letters"),
    ({"outputs": ["failed"]}, r"model\.outputs: .*'failed' and 'reason' name"),
])
def test_a_bad_command_config_is_one_clear_config_error(program, tmp_path, edit, message):
    cfg = _config(program, tmp_path, series=False)
    cfg["model"].update(edit)
    with pytest.raises(ConfigError, match=message):
        uqguide.load_config(cfg)


def test_per_sample_mode_runs_one_process_per_sample_and_fails_the_crashing_one(
        program, tmp_path):
    run = uqguide.run(_config(program, tmp_path, n=12, batch=6, mode="abort", thresh=1.5,
                              per_sample=True)).run("mc")
    bad = _x1(run) > 1.5
    assert 0 < bad.sum() < 12
    np.testing.assert_array_equal(run.failed, bad)
    assert all("/sample-" in r and "SIGABRT" in r for r in run.reasons[bad])
    serial = uqguide.run(_config(program, tmp_path / "b", n=12, batch=6)).run("mc")
    np.testing.assert_array_equal(run.scalars["y"][~bad], serial.scalars["y"][~bad])


def test_hdf5_files_give_the_bits_of_csv_files(program, tmp_path):
    # a Python program reading inputs.h5 and writing outputs.h5 with h5py
    script = tmp_path / "h5sim.py"
    script.write_text(
        "import sys, h5py, numpy as np\n"
        "with h5py.File(sys.argv[1]) as f:\n"
        "    x1, x2 = f['x1'][()], f['x2'][()]\n"
        "y = 2 * x1 + 0.5 * x2 * x2\n"
        "with h5py.File(sys.argv[2], 'w') as f:\n"
        "    f['y'] = y\n"
        "    f['time'] = [0.5, 1.0, 2.0]\n"
        "    f['path'] = y[:, None] * np.array([0.5, 1.0, 2.0])\n"
        "    f['failed'] = (x1 > 1.8).astype(int)\n")
    cfg = _config(Path(sys.executable), tmp_path / "w", n=40, batch=20,
                  input_format="hdf5", output_format="hdf5")
    cfg["model"]["command"] = f"{sys.executable} {script} {{inputs}} {{outputs}}"
    h5 = uqguide.run(cfg).run("mc")
    csv = uqguide.run(_config(program, tmp_path / "c", n=40, batch=20, mode="flag",
                              thresh=1.8)).run("mc")
    np.testing.assert_array_equal(h5.failed, csv.failed)
    assert set(h5.reasons[h5.failed]) == {"the command marked it failed"}
    ok = ~csv.failed
    np.testing.assert_array_equal(h5.scalars["y"][ok], csv.scalars["y"][ok])
    for stat in ("mean", "std"):
        np.testing.assert_array_equal(h5.estimate.stats["path"].stat(stat),
                                      csv.estimate.stats["path"].stat(stat))


def _assert_same_bits(a, b) -> None:
    np.testing.assert_array_equal(a.failed, b.failed)
    for name in ("y", "path"):
        for stat in ("mean", "std", "skewness", "kurtosis"):
            np.testing.assert_array_equal(a.estimate.stats[name].stat(stat),
                                          b.estimate.stats[name].stat(stat))


@pytest.mark.slow
def test_two_workers_give_the_bits_of_a_serial_run(program, tmp_path):
    cfg = _config(program, tmp_path, n=200, batch=25, mode="abort", thresh=1.8)
    serial = uqguide.run(cfg).run("mc")
    assert serial.n_failed > 0
    _assert_same_bits(serial, uqguide.run(cfg, workers=2).run("mc"))


# Slow: a Dask cluster takes about 10 s to start, and the pool above ships the model the same
# way (its registered name and parameters, rebuilt in the worker).
@pytest.mark.slow
def test_a_dask_cluster_gives_the_bits_of_a_serial_run(program, tmp_path):
    from distributed import Client, LocalCluster

    from uqguide.config.run_config import validate_config
    from uqguide.driver.execution import DaskExecutor
    from uqguide.driver.propagate import run as propagate_run

    cfg = _config(program, tmp_path, n=200, batch=25, mode="abort", thresh=1.8)
    serial = uqguide.run(cfg).run("mc")
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        dask = propagate_run(validate_config(cfg), DaskExecutor(client=client)).run("mc")
    assert serial.n_failed > 0
    _assert_same_bits(serial, dask)


DOC = Path(__file__).resolve().parents[1] / "docs" / "your-simulator.md"


def _doc_block(lang: str) -> str:
    return next(b.body for b in blocks(DOC) if b.lang == lang)


def _square_config(command: str, work: Path) -> dict:
    """y = a + b^2, a ~ N(1, 0.1), b ~ N(0.5, 0.2): the documentation's examples."""
    return {"model": {"name": "command", "command": command, "inputs": ["a", "b"],
                      "outputs": ["y"], "workdir": str(work)},
            "inputs": [{"name": "a", "dist": "normal", "mean": 1.0, "std": 0.1},
                       {"name": "b", "dist": "normal", "mean": 0.5, "std": 0.2}],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 40}],
            "batch_size": 20, "seed": 1}


def test_the_documented_c_program_is_the_model_it_says(program, tmp_path):
    """Section 1's config and section 3's program as a reader copies them, nothing edited:
    the run makes every declared output (the series too) and each is the formula."""
    (tmp_path / "mysim.c").write_text(_doc_block("c"))
    subprocess.run(["cc", "-O2", "-o", str(tmp_path / "mysim"), str(tmp_path / "mysim.c")],
                   check=True, capture_output=True, timeout=120)
    path = tmp_path / "sim.yaml"
    path.write_text(_doc_block("yaml"))
    result = uqguide.run(uqguide.load_config(path))
    run = result.run("mc")
    assert run.n_failed == 0 and run.n_runs == 2000
    x = np.asarray(run.x)
    np.testing.assert_array_equal(run.scalars["y"][:, 0], x[:, 0] + x[:, 1] ** 2)
    np.testing.assert_array_equal(result.time, [0.0, 0.5, 1.0, 2.0])
    # path(t) = a t + b: its mean 1.0 t + 0.5 lies in the interval where one is given (the
    # report times: here the last step)
    low, high = (v[:, 0] for v in run.estimate.stats["path"].ci["mean"])
    truth = 1.0 * result.time + 0.5
    given = ~np.isnan(low)
    assert given.any() and np.all((low <= truth) & (truth <= high) | ~given), (low, high)


def test_the_documented_octave_function_is_the_model_it_says(tmp_path):
    if shutil.which("octave") is None:
        pytest.skip("octave is not on PATH (docs/your-simulator.md section 4 is then untested)")
    (tmp_path / "mysim.m").write_text(_doc_block("matlab"))
    command = ("octave --no-gui --quiet --eval "
               "\"addpath('{config_dir}'); mysim('{inputs}', '{outputs}')\"")
    cfg = _square_config(command, tmp_path / "work")
    cwd = os.getcwd()
    os.chdir(tmp_path)  # {config_dir} of a config from Python: the current folder
    try:
        run = uqguide.run(cfg).run("mc")
    finally:
        os.chdir(cwd)
    x = np.asarray(run.x)
    # Octave's own number reader and pow: equal to a few units of round-off
    np.testing.assert_allclose(run.scalars["y"][:, 0], x[:, 0] + x[:, 1] ** 2, rtol=1e-15)


@pytest.mark.parametrize("text,message", [
    ("z\n1\n2\n", r"line 1: no column 'y' in the header 'z'; the model's 'outputs' lists "
                  r"what the program writes \(default \[y\]\): for this header, outputs: \[z\]"),
    ("v[0],v[1],failed\n1,2,0\n",
     r"line 1: no column 'y' .*outputs: \[\{name: v, components: 2\}\]"),
    ("y\n1\n2\n3\n", r"3 sample rows, expected 2 .*line 4 is one too many"),
    ("y,w\n1,2\n3\n", r"line 3 \(sample 1\): 1 cells, the header has 2: column 2 is missing"),
    ("y,failed\n1,0\n2,yes\n", r"line 3 \(sample 1\), column 2 'failed': 'yes' is not 0 or 1"),
    ("y\n1\n\n", r"1 sample rows, expected 2 .*line 3 \(sample 1\) is missing"),
    ("", r"line 1: the file is empty"),
])
def test_each_defect_of_an_outputs_file_is_named_with_its_line_and_column(tmp_path, text,
                                                                           message):
    from uqguide.models.command.files import OutputSpec, read_outputs

    (tmp_path / "outputs.csv").write_text(text)
    with pytest.raises(ModelError, match=re.escape(str(tmp_path / "outputs.csv")) + ": " +
                       message):
        read_outputs(tmp_path / "outputs.csv", [OutputSpec("y", "scalar", 1)], 2, "csv")


def test_a_flagged_sample_may_leave_its_cells_empty_and_a_series_row_too(tmp_path):
    from uqguide.models.command.files import OutputSpec, read_outputs

    (tmp_path / "out.csv").write_text('y[0],y[1],failed,reason\n1,2,0,\n,,1,"a, b"\n')
    (tmp_path / "out_p.csv").write_text("0,1\n5,6\n,\n")
    got = read_outputs(tmp_path / "out.csv", [OutputSpec("y", "scalar", 2),
                                              OutputSpec("p", "series", 1)], 2, "csv")
    np.testing.assert_array_equal(got.scalars["y"], [[1, 2], [np.nan, np.nan]])
    np.testing.assert_array_equal(got.series["p"][:, :, 0], [[5, 6], [np.nan, np.nan]])
    np.testing.assert_array_equal(got.time, [0, 1])
    assert list(got.failed) == [False, True] and list(got.reasons) == ["", "a, b"]
    (tmp_path / "out_p.csv").write_text("0,1\n5,6\n7,x\n")
    with pytest.raises(ModelError, match=r"out_p\.csv: line 3 \(sample 1\), column 2 't=1': "
                                         r"'x' is not a number"):
        read_outputs(tmp_path / "out.csv", [OutputSpec("p", "series", 1)], 2, "csv")


def test_a_recompiled_program_is_a_code_change_a_resume_refuses(program, tmp_path):
    from uqguide.driver.run_folder import model_code_hash

    copy = tmp_path / "sim"
    shutil.copy(program, copy)
    model = uqguide.load_config(_config(copy, tmp_path, series=False)).model
    before = model_code_hash(model)
    assert model_code_hash(model) == before
    with copy.open("ab") as f:
        f.write(b"\0")  # the same program, other bytes: as a rebuild with other flags
    assert model_code_hash(model) != before


def test_at_the_command_line_a_bad_program_is_exit_2_and_a_malformed_file_exit_1(
        program, tmp_path, write_config):
    from click.testing import CliRunner

    from uqguide.cli import main

    cfg = _config("./no-such-sim", tmp_path / "work", n=10, batch=10, series=False)
    res = CliRunner().invoke(main, ["validate", str(write_config(cfg))])
    assert res.exit_code == 2
    assert res.stderr.strip().splitlines() == [
        f"error: model.command: program './no-such-sim': no executable file "
        f"{tmp_path.resolve() / 'no-such-sim'} (a relative path is taken from the config's "
        f"folder) (got './no-such-sim {{inputs}} {{outputs}}')"]
    cfg = _config(program, tmp_path / "work", n=10, batch=10, series=False, mode="short")
    res = CliRunner().invoke(main, ["run", str(write_config(cfg)), "--out",
                                    str(tmp_path / "out")])
    assert res.exit_code == 1 and "Traceback" not in res.output
    assert "outputs.csv: 9 sample rows, expected 10" in res.stderr


def test_with_shell_true_the_placeholders_are_quoted(program, tmp_path):
    # a work folder whose name is itself an injection attempt, and a real pipe in the command
    work = tmp_path / "w; touch pwned"
    cfg = _config(program, work, n=20, batch=10, series=False, shell=True)
    cfg["model"]["command"] = (f"{program} {{inputs}} {{outputs}} && "
                               "echo {batch} | tr a-z A-Z > {workdir}/../seen-{batch}")
    run = uqguide.run(cfg).run("mc")
    assert run.n_failed == 0
    assert not list(tmp_path.rglob("pwned")) and not list(Path.cwd().glob("pwned"))
    seen = sorted(work.glob("seen-batch-*"))
    assert len(seen) == 2  # one call per batch of 10, each saw its own folder's name
    assert [p.read_text().strip() for p in seen] == [p.name[5:].upper() for p in seen]


def test_a_series_of_two_components_is_one_file_per_component_on_one_grid(tmp_path):
    from uqguide.models.command.files import OutputSpec, read_outputs

    spec = OutputSpec("r", "series", 2)
    (tmp_path / "out_r_0.csv").write_text("0,1,2\n1,2,3\n")
    (tmp_path / "out_r_1.csv").write_text("0,1,2\n4,5,6\n")
    got = read_outputs(tmp_path / "out.csv", [spec], 1, "csv")
    np.testing.assert_array_equal(got.series["r"], [[[1, 4], [2, 5], [3, 6]]])
    (tmp_path / "out_r_1.csv").write_text("0,1,3\n4,5,6\n")
    with pytest.raises(ModelError, match=r"out_r_1\.csv: line 1: the time grid differs from "
                                         r"that of .*out_r_0\.csv"):
        read_outputs(tmp_path / "out.csv", [spec], 1, "csv")


def test_a_program_in_the_home_folder_may_be_written_with_a_tilde(program, tmp_path,
                                                                  monkeypatch):
    monkeypatch.setenv("HOME", str(program.parent))
    run = uqguide.run(_config("~/sim", tmp_path, n=10, batch=10, series=False)).run("mc")
    assert run.n_failed == 0
