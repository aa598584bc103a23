"""A ``command`` program that misbehaves cannot hang, bloat or outlive uqguide, nor run code
through a path: a FIFO or other special file as its outputs, outputs larger than the batch can
need (or lying HDF5 shapes), a repeated column, a daemon detached with ``setsid``, a path
holding ``$(...)`` with ``shell: true``, a replay whose program now fails.

The programs are ``/bin/sh`` scripts (a process start costs about a millisecond); each writes
``y = 1`` per sample from the variables uqguide sets (``$UQ_INPUTS``, ``$UQ_OUTPUTS``).
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import threading
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest
import yaml

import uqguide
from uqguide.core import descendants
from uqguide.errors import ConfigError, ModelError
from uqguide.models.command import files
from uqguide.models.command.files import OutputSpec, read_outputs
from uqguide.models.command.process import CommandFailed, Deadline, shell_script

linux = pytest.mark.skipif(not descendants.supported(),
                           reason="finding a program's daemons needs Linux's /proc")

#: A program's lines writing y = 1 for each sample of its inputs file.
WRITE_Y = 'tail -n +2 "$UQ_INPUTS" | sed "s/.*/1.0/" | { echo y; cat; } > "$UQ_OUTPUTS"'
#: True when the call's inputs hold a negative sample.
NEGATIVE = "tail -n +2 \"$UQ_INPUTS\" | grep -q '^-'"
#: A daemon as a program starts one: a background child in a session of its own (setsid),
#: its pid written beside the work folder; the program goes on once it has.
DAEMON = ("setsid sh -c 'echo $$ > \"$UQ_WORKDIR/../daemon-$$\"; touch \"$UQ_WORKDIR/up-$$\"; "
          "exec sleep 300' </dev/null >/dev/null 2>&1 &\n"
          "until ls \"$UQ_WORKDIR\"/up-* >/dev/null 2>&1; do sleep 0.01; done; "
          "rm \"$UQ_WORKDIR\"/up-*")
Y = [OutputSpec("y", "scalar", 1)]


def _script(folder: Path, body: str, name: str = "prog.sh") -> Path:
    path = folder / name
    path.write_text("#!/bin/sh\n" + body + "\n")
    path.chmod(0o755)
    return path


def _config(command: str, work: Path, *, n: int = 4, batch: int = 4, **model) -> dict:
    return {"model": {"name": "command", "command": command, "inputs": ["a"], "outputs": ["y"],
                      "workdir": str(work), **model},
            "inputs": [{"name": "a", "dist": "normal", "mean": 0.0, "std": 1.0}],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n}],
            "batch_size": batch, "max_failed_fraction": 1.0, "seed": 1}


def _running(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie does not)."""
    p = descendants.info(pid)
    return p is not None and p.state not in "ZX"


def _daemons(work: Path) -> list[int]:
    return [int(p.name.split("-")[1]) for p in work.glob("daemon-*")]


# ---------------------------------------------------------------- special and oversized files
@pytest.mark.parametrize("make,kind", [
    (lambda p: os.mkfifo(p), "a FIFO (named pipe)"),
    (lambda p: p.mkdir(), "a folder"),
    (lambda p: p.symlink_to("/dev/zero"), "a device"),
])
def test_an_outputs_file_that_is_not_a_regular_file_fails_the_call_unread(tmp_path, make,
                                                                             kind):
    start = time.monotonic()
    for name, fmt in (("outputs.csv", "csv"), ("outputs.h5", "hdf5")):
        make(tmp_path / name)
        with pytest.raises(CommandFailed, match=re.escape(f"{name}: the program left {kind} "
                                                          f"here, not a regular file")):
            read_outputs(tmp_path / name, Y, 2, fmt)
    assert time.monotonic() - start < 1.0  # refused, never waited on


def test_a_program_leaving_a_fifo_fails_its_batch_with_one_line_and_never_hangs(tmp_path):
    # seed 1 draws a = 1.13, -0.44: the batch fails, is split, and the negative sample fails
    prog = f'{NEGATIVE} && mkfifo "$UQ_OUTPUTS" || {{ {WRITE_Y}; }}'
    start = time.monotonic()
    run = uqguide.run(_config(prog, tmp_path, n=2, batch=2, shell=True)).run("mc")
    np.testing.assert_array_equal(run.failed, [False, True])
    reason = run.reasons[1]
    assert reason.startswith("CommandFailed: ") and "a FIFO (named pipe)" in reason
    assert "work folder kept" in reason and "\n" not in reason
    assert time.monotonic() - start < 30  # three calls, none waiting on the FIFO


def _sparse(path: Path, head: str, size: int) -> None:
    """``head``, then zeros up to ``size`` bytes, without writing them (a sparse file)."""
    with path.open("w") as f:
        f.write(head)
        f.truncate(size)


def test_an_outputs_file_larger_than_its_batch_can_need_is_refused_without_being_read(
        tmp_path):
    out = tmp_path / "outputs.csv"
    _sparse(out, "y\n1\n2\n", 300 * 2**20)  # the issue's 300 MB, as a program left it
    tracemalloc.start()
    try:
        with pytest.raises(CommandFailed, match=r"outputs\.csv: 314,572,800 bytes, more than "
                                                r"the 8,322 a batch can need \(a header, then "
                                                r"2 row\(s\) of 1 cell\(s\) at 64 bytes a cell "
                                                r"and 4096 a row\); refused unread"):
            read_outputs(out, Y, 2, "csv")
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    # what was read: the header line, in the text buffer of one read (8 kB)
    assert peak < 2**20
    # the limit is rows x columns: the same file passes once it fits 2 rows of 1 column
    _sparse(out, "y\n1\n2\n", 2 + 2 * (files.CELL_BYTES + files.ROW_BYTES))
    with pytest.raises(CommandFailed, match="line 4 is longer than"):
        read_outputs(out, Y, 2, "csv")  # then its zeros are a line too long, no longer the size


def test_a_series_file_larger_than_its_grid_and_rows_can_need_is_refused(tmp_path):
    out = tmp_path / "out.csv"
    _sparse(tmp_path / "out_p.csv", "0,1,2\n1,2,3\n", 10 * 2**20)
    with pytest.raises(CommandFailed, match=r"out_p\.csv: 10,485,760 bytes, more than the 4,294 "
                                            r"a batch can need \(a time grid, then 1 row"):
        read_outputs(out, [OutputSpec("p", "series", 1)], 1, "csv")
    (tmp_path / "out_p.csv").write_text(",".join(["0"] * (files.GRID_POINTS + 1)) + "\n")
    with pytest.raises(CommandFailed, match=r"line 1: a time grid of 1,048,577 points, more "
                                            r"than the 1,048,576 a series may have"):
        read_outputs(out, [OutputSpec("p", "series", 1)], 1, "csv")


def test_a_line_far_longer_or_far_wider_than_a_row_is_refused_before_it_is_parsed(tmp_path):
    out = tmp_path / "outputs.csv"
    # one sample's long line, in a file within the limit of 100 samples
    out.write_text("y\n" + "1\n" * 50 + "1" * 5000 + "\n" + "1\n" * 49)
    with pytest.raises(CommandFailed, match=r"line 52 is longer than the 4,160 characters a "
                                            r"row of 1 cells may take"):
        read_outputs(out, Y, 100, "csv")
    out.write_text("y\n" + "1\n" * 50 + "," * 4100 + "\n" + "1\n" * 49)  # short enough
    with pytest.raises(ModelError, match=r"line 52: 4,101 cells or more, line 1 has 1"):
        read_outputs(out, Y, 100, "csv")


def test_an_hdf5_file_claiming_more_than_the_batch_needs_is_refused_before_reading(tmp_path):
    import h5py

    out = tmp_path / "outputs.h5"
    with h5py.File(out, "w") as f:  # chunked and never written: kilobytes on disk
        f.create_dataset("time", shape=(2**40,), chunks=(2**16,), dtype="f8")
        f.create_dataset("y", shape=(2**40,), chunks=(2**16,), dtype="f8")
    assert out.stat().st_size < 2**20
    with pytest.raises(CommandFailed, match=r"dataset 'time' has 1,099,511,627,776 points, "
                                            r"more than the 1,048,576"):
        read_outputs(out, [OutputSpec("p", "series", 1)], 2, "hdf5")
    with pytest.raises(ModelError, match=r"dataset 'y' has shape \(1099511627776,\), expected "
                                         r"\(2, 1\)"):
        read_outputs(out, Y, 2, "hdf5")


def test_reading_the_outputs_counts_against_timeout_s(tmp_path):
    out = tmp_path / "outputs.csv"
    out.write_text("y\n1\n2\n")
    np.testing.assert_array_equal(
        read_outputs(out, Y, 2, "csv", Deadline.start(60.0)).scalars["y"], [[1], [2]])
    late = Deadline(timeout_s=0.5, at=time.monotonic() - 1.0)  # the program took it all
    with pytest.raises(CommandFailed, match=r"did not finish within timeout_s = 0\.5 s "
                                            r"\(reading outputs\.csv\)"):
        read_outputs(out, Y, 2, "csv", late)


@pytest.mark.parametrize("header,message", [
    ("y,y", r"line 1: column 2 'y' repeats column 1; each column is named once"),
    ("y,z,failed,z", r"line 1: column 4 'z' repeats column 2"),
])
def test_a_repeated_column_is_an_error_not_the_last_one_silently(tmp_path, header, message):
    out = tmp_path / "outputs.csv"
    out.write_text(header + "\n" + "\n".join(",".join(["1"] * (header.count(",") + 1))
                                              for _ in range(2)) + "\n")
    with pytest.raises(ModelError, match=message):
        read_outputs(out, Y, 2, "csv")


def test_a_byte_order_mark_is_read_as_csv_readers_do(tmp_path):
    out = tmp_path / "outputs.csv"
    out.write_bytes(b"\xef\xbb\xbfy\r\n1.5\r\n2.5\r\n")  # Excel's "CSV UTF-8"
    np.testing.assert_array_equal(read_outputs(out, Y, 2, "csv").scalars["y"], [[1.5], [2.5]])


@pytest.mark.slow  # two interpreters, and a program writing 300 MB
def test_peak_memory_of_a_300_mb_outputs_file_is_that_of_a_normal_run(tmp_path):
    """The issue's case end to end: a program that writes 300 MB of extra rows took uqguide to
    4.7 GB of resident memory (3.1 GB measured before the fix, on one batch); now the batch
    fails and the run's peak is a normal run's, within the one line uqguide reads."""
    def peak(extra_mb: int) -> int:
        prog = _script(tmp_path, f'{WRITE_Y}\nhead -c {extra_mb}M /dev/zero | tr "\\0" "\\n" '
                                 f'>> "$UQ_OUTPUTS"', f"prog{extra_mb}.sh")
        cfg = tmp_path / f"c{extra_mb}.yaml"
        cfg.write_text(yaml.safe_dump(_config(f"{prog} {{inputs}}", tmp_path / "w", n=1,
                                              batch=1)))
        code = ("import resource, sys, uqguide\n"
                "try:\n    uqguide.run(uqguide.load_config(sys.argv[1]))\n"
                "except uqguide.errors.UqguideError as e:\n    print(e)\n"
                "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)\n")
        p = subprocess.run([sys.executable, "-c", code, str(cfg)], capture_output=True,
                           text=True, timeout=300, env={**os.environ, "PYTHONPATH": str(
                               Path(uqguide.__file__).parents[1])})
        assert p.returncode == 0, p.stderr
        return int(p.stdout.split()[-1]) * 1024

    normal, oversized = peak(0), peak(300)
    assert oversized < normal + 32 * 2**20, (normal, oversized)


# ---------------------------------------------------------------- no process outlives its call
@linux
def test_a_daemon_detached_with_setsid_dies_with_its_call(tmp_path):
    prog = _script(tmp_path, f"{DAEMON}\n{WRITE_Y}")
    run = uqguide.run(_config(f"{prog}", tmp_path / "w", n=4, batch=2)).run("mc")
    assert run.n_failed == 0
    daemons = _daemons(tmp_path / "w")
    assert len(daemons) == 2  # one per call
    assert not [pid for pid in daemons if _running(pid)]
    assert not descendants.is_subreaper()  # only while calls run


@linux
def test_a_daemon_dies_with_a_call_that_timed_out_and_one_that_cleared_its_environment(
        tmp_path):
    # env -i: no UQ_CALL mark to be found by; adopted, in a session of its own, it is the call's
    hidden = DAEMON.replace("setsid sh -c", "env -i W=\"$UQ_WORKDIR\" setsid sh -c").replace(
        "$UQ_WORKDIR/", "$W/")
    prog = _script(tmp_path, f"{DAEMON}\n{hidden}\n{NEGATIVE} && sleep 60\n{WRITE_Y}")
    start = time.monotonic()
    # 2 s: time for the daemons to start on a loaded machine, twice (the batch, sample 1)
    run = uqguide.run(_config(f"{prog}", tmp_path / "w", n=2, batch=2,
                              timeout_s=2.0)).run("mc")
    np.testing.assert_array_equal(run.failed, [False, True])
    assert "did not finish within timeout_s = 2 s" in run.reasons[1]
    assert time.monotonic() - start < 20
    daemons = _daemons(tmp_path / "w")
    assert len(daemons) == 6  # two in each of three calls
    assert not [pid for pid in daemons if _running(pid)]


@linux
def test_the_end_of_a_call_spares_uqguides_own_children_and_another_calls_processes(
        tmp_path):
    """What a call kills is what it started: not a child this process had before (even in a
    session of its own), nor one it starts meanwhile in its own session, nor the program or
    the daemon of a call running at the same time in another thread."""
    from uqguide.models.command.model import CommandModel

    before = subprocess.Popen(["sleep", "30"], start_new_session=True)
    meanwhile: list[subprocess.Popen] = []
    # the slow call checks, before it writes, that its own daemon outlived the quick call
    slow = _script(tmp_path, f'{DAEMON}\nsleep 1.5\nfor d in "$UQ_WORKDIR"/../daemon-*; do '
                             f'kill -0 "$(cat "$d")" || exit 7; done\n{WRITE_Y}', "slow.sh")
    quick = _script(tmp_path, WRITE_Y, "quick.sh")

    def call(prog: Path, out: list) -> None:
        model = CommandModel(CommandModel.Params(command=str(prog), inputs=["a"],
                                                 workdir=str(tmp_path / prog.stem)))
        out.append(model.evaluate(np.zeros((2, 1)), ["a"], ["y"]))

    got: list = []
    try:
        thread = threading.Thread(target=call, args=(slow, got))
        thread.start()
        time.sleep(0.5)  # the slow call's program and daemon run
        meanwhile.append(subprocess.Popen(["sleep", "30"]))
        call(quick, got)  # ends while the slow one runs
        thread.join(30)
        assert len(got) == 2 and not any(o.failed.any() for o in got)
        assert _running(before.pid) and _running(meanwhile[0].pid)
        assert not [pid for pid in _daemons(tmp_path / "slow") if _running(pid)]
    finally:
        for p in [before, *meanwhile]:
            p.kill()
            p.wait()


@linux
@pytest.mark.slow  # a pool worker (an interpreter) and a second of waiting
def test_a_pool_worker_ended_by_sigterm_takes_its_programs_daemon_with_it(tmp_path):
    """A worker the driver ends (Ctrl-C) with SIGTERM kills its call's program and daemon
    first: SIGTERM's default would have left them running."""
    import multiprocessing

    prog = _script(tmp_path, f"{DAEMON}\nsleep 60")
    ctx = multiprocessing.get_context("spawn")
    proc = ctx.Process(target=_evaluate_in_worker, args=(str(prog), str(tmp_path / "w")))
    proc.start()
    deadline = time.monotonic() + 60
    while not _daemons(tmp_path / "w") and time.monotonic() < deadline:
        time.sleep(0.05)
    os.kill(proc.pid, signal.SIGTERM)
    proc.join(10)
    assert proc.exitcode == 128 + signal.SIGTERM
    time.sleep(0.2)
    daemons = _daemons(tmp_path / "w")
    assert daemons and not [pid for pid in daemons if _running(pid)]


def _evaluate_in_worker(prog: str, work: str) -> None:
    from uqguide.models.command.model import CommandModel

    model = CommandModel(CommandModel.Params(command=prog, inputs=["a"], workdir=work))
    model.evaluate(np.zeros((1, 1)), ["a"], ["y"])


@linux
@pytest.mark.slow  # the guard's timeout, and a guard process per bisected call
def test_the_runs_timeout_s_kills_the_guard_and_the_daemon_its_program_started(tmp_path):
    prog = _script(tmp_path, f"{DAEMON}\n{NEGATIVE} && sleep 60\n{WRITE_Y}")
    cfg = _config(f"{prog}", tmp_path / "w", n=2, batch=2)
    cfg["timeout_s"] = 2.0
    run = uqguide.run(cfg).run("mc")
    np.testing.assert_array_equal(run.failed, [False, True])
    time.sleep(0.2)
    daemons = _daemons(tmp_path / "w")
    assert len(daemons) == 3  # the batch, then each half
    assert not [pid for pid in daemons if _running(pid)]


# ---------------------------------------------------------------- shell: true
@pytest.mark.parametrize("template,script", [
    ("./sim {inputs} {outputs}", '"${UQ_CONFIG_DIR}"/./sim "${UQ_INPUTS}" "${UQ_OUTPUTS}"'),
    ('sim "{inputs}" > "{outputs}"', 'sim "${UQ_INPUTS}" > "${UQ_OUTPUTS}"'),
    ("sim '{inputs}' x", "sim ''\"${UQ_INPUTS}\"'' x"),
    ('cat "$(dirname {inputs})/x" `echo {batch}`',
     'cat "$(dirname "${UQ_INPUTS}")/x" `echo "${UQ_BATCH}"`'),
    ('(cd {workdir} && sim) | tee "{workdir}/log"',
     '(cd "${UQ_WORKDIR}" && sim) | tee "${UQ_WORKDIR}/log"'),
    ("/opt/sim {inputs}; VAR=1 ./b", '/opt/sim "${UQ_INPUTS}"; VAR=1 ./b'),
    ('echo \\"{inputs}\\"', 'echo \\""${UQ_INPUTS}"\\"'),
    # a here-document expands variables, and shows quotes as they are
    ("sim <<EOF\nin {inputs}\nout '{outputs}'\nEOF\necho {batch}",
     "sim <<EOF\nin ${UQ_INPUTS}\nout '${UQ_OUTPUTS}'\nEOF\necho \"${UQ_BATCH}\""),
    ("sim <<-'EOF' {inputs}\n\t$x\n\tEOF\n", "sim <<-'EOF' \"${UQ_INPUTS}\"\n\t$x\n\tEOF\n"),
])
def test_a_shell_template_refers_to_variables_quoted_for_where_they_stand(template, script):
    assert shell_script(template) == script


@pytest.mark.parametrize("quoting", ['"{x}"', "'{x}'", "{x}", "\"$(cat '{x}')\""])
def test_with_shell_true_a_path_holding_code_is_text_however_the_template_quotes_it(
        tmp_path, quoting):
    work = tmp_path / "w$(touch PWNED)`touch PWNED2`\"'; touch PWNED3"
    command = (f'cat {quoting.format(x="{inputs}")} > /dev/null && {WRITE_Y} '
               f'&& echo ok > {quoting.format(x="{workdir}").replace("cat ", "cat ")}/../seen')
    if "$(cat" in quoting:  # a substitution's own quotes: its output is the file's text
        command = f'test -n {quoting.format(x="{inputs}")} && {WRITE_Y}'
    run = uqguide.run(_config(command, work, n=2, batch=2, shell=True)).run("mc")
    assert run.n_failed == 0, run.reasons
    assert not list(tmp_path.rglob("PWNED*")) and not list(Path.cwd().glob("PWNED*"))


def test_with_shell_true_a_here_document_gets_a_path_holding_code_as_text(tmp_path):
    work = tmp_path / "w$(touch PWNED)`touch PWNED2`"
    command = ("read -r f <<EOF\n{inputs}\nEOF\n"
               f'test -f "$f" && {WRITE_Y.replace(chr(36) + "UQ_INPUTS", chr(36) + "f")}')
    run = uqguide.run(_config(command, work, n=2, batch=2, shell=True)).run("mc")
    assert run.n_failed == 0, run.reasons
    assert not list(tmp_path.rglob("PWNED*")) and not list(Path.cwd().glob("PWNED*"))


def test_with_shell_true_a_relative_program_is_found_beside_the_config(tmp_path,
                                                                       write_config):
    _script(tmp_path, WRITE_Y, "sim.sh")
    path = write_config(_config("./sim.sh | cat", str(tmp_path / "w"), shell=True))
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    cwd = os.getcwd()
    os.chdir(elsewhere)
    try:
        loaded = uqguide.load_config(path)
        assert loaded.model.params.program_file() == tmp_path.resolve() / "sim.sh"
        assert uqguide.run(loaded).run("mc").n_failed == 0
    finally:
        os.chdir(cwd)
    with pytest.raises(ConfigError, match=r"model\.command: program './nosim\.sh': no "
                                          r"executable file"):
        uqguide.load_config(write_config(_config("./nosim.sh && true", "w", shell=True)))


def test_a_placeholder_in_a_here_document_the_shell_does_not_expand_is_refused(tmp_path):
    with pytest.raises(ConfigError, match=r"model\.command: placeholder \{inputs\} in a "
                                          r"here-document whose delimiter is quoted \('EOF'\)"):
        uqguide.load_config(_config("cat <<'EOF'\n{inputs}\nEOF", tmp_path, shell=True))


def test_the_variables_uqguide_sets_cannot_be_set_by_env(tmp_path):
    with pytest.raises(ConfigError, match=r"model\.env: .*UQ_INPUTS is set by uqguide for each "
                                          r"call \(the value of \{inputs\}\)"):
        uqguide.load_config(_config("true", tmp_path, env={"UQ_INPUTS": "x"}, shell=True))


# ---------------------------------------------------------------- replay
def test_replay_of_a_result_whose_program_now_fails_is_one_line_exit_1(tmp_path):
    from click.testing import CliRunner

    from uqguide.cli import main
    from uqguide.results.result import write_hdf5

    prog = _script(tmp_path, f'[ -e "{tmp_path}/broken" ] && {{ echo diverged >&2; exit 3; }}\n'
                             f'{WRITE_Y}')
    h5 = write_hdf5(uqguide.run(_config(str(prog), tmp_path / "w", n=2, batch=2)),
                    tmp_path / "r.h5")
    (tmp_path / "broken").touch()
    res = CliRunner().invoke(main, ["replay", str(h5), "--run-code", "--label", "mc",
                                    "--sample", "1", "--out", str(tmp_path / "rp")])
    assert res.exit_code == 1 and "Traceback" not in res.output
    said, error = res.stderr.strip().splitlines()  # what replay runs, then the one error
    assert said.startswith("replay runs the program ")
    assert error.startswith("error: sample 1 of 'mc' could not be run again: "
                            "CommandFailed: the command exited with status 3; ")
    assert "last line of stderr: 'diverged'" in res.stderr
