"""Nothing of the user's is touched, nothing blocks, a full disk is one line (issue 44, the run
folder and the files uqguide writes).

1. Only uqguide's own temporary files and the files a run folder's manifest lists are deleted.
2. No file is written through a second name: every file opened for writing goes through
   ``atomic.open_writable`` (a regular file of one name, never through a link).
3. A FIFO or socket where uqguide reads or writes is refused at once, exit 2.
4. A full disk at any write is exit 1 with one line, the run folder resumable; an unusable
   ``--out`` is exit 2 before any work.

The whole campaign is ``benchmarks/fuzz_containment.py`` (plot, report and replay included);
its sample closes this file.
"""

from __future__ import annotations

import errno
import os
import signal
import socket
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

import uqguide
from uqguide.cli import main
from uqguide.core import atomic
from uqguide.driver import run_folder
from uqguide.driver.run_folder import RunStore, run_identity
from uqguide.errors import ConfigError, DiskFull

from .failing_models import mc_config

ROOT = Path(__file__).resolve().parents[1]
NAME = "st"


def _raw() -> dict:
    raw = {**mc_config("tests.failing_models:ctrl_c_on_third_call", 200, 50), "name": NAME}
    raw["model"]["isolate"] = False  # the model's Ctrl-C must reach the driver
    return raw


@pytest.fixture
def cfg(tmp_path, monkeypatch) -> Path:
    from tests import failing_models

    monkeypatch.setenv("UQGUIDE_TEST_ARM_CTRL_C", "0")
    monkeypatch.setitem(failing_models._calls, "n", 0)
    path = tmp_path / "st.yaml"
    path.write_text(yaml.safe_dump(_raw()))
    return path


def _run(*args: str | Path, timeout: float = 30):
    """The command in this process; a blocking open fails the test instead of hanging it."""
    def late(signum, frame):
        raise TimeoutError(f"uqguide {args[0]} still running after {timeout} s")

    old = signal.signal(signal.SIGALRM, late)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    try:
        return CliRunner().invoke(main, [str(a) for a in args])
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _one_line(res) -> str:
    assert "Traceback" not in res.output, res.output
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


@pytest.fixture
def interrupted(cfg, tmp_path, monkeypatch):
    """``out/st.run`` of a run stopped by Ctrl-C after 2 of its 4 chunks."""
    from tests import failing_models

    monkeypatch.setenv("UQGUIDE_TEST_ARM_CTRL_C", "1")
    res = _run("run", cfg, "--out", tmp_path / "out", "-q")
    assert res.exit_code == 130, res.output
    monkeypatch.setenv("UQGUIDE_TEST_ARM_CTRL_C", "0")
    monkeypatch.setitem(failing_models._calls, "n", 0)
    return tmp_path / "out"


def _started(cfg: Path, out: Path) -> Path:
    """A run folder as a run stopped before its first chunk leaves it: its header only."""
    c = uqguide.load_config(cfg)
    store = RunStore.open(out / f"{NAME}.run", run_identity(c.resolved(), c.model),
                          resume=False)
    store.close()
    return out / f"{NAME}.run"


# ---------------------------------------------------------------------------- 1. ours only
def test_a_temporary_name_says_whose_it_is():
    p = atomic.temp_path(Path("/x/table.csv"), 1234)
    assert p.parent == Path("/x") and p.name.startswith(".table.csv.1234.")
    assert atomic.temp_owner(p.name) == 1234 and atomic.temp_target(p.name) == "table.csv"
    assert atomic.temp_path(Path("/x/table.csv"), 1234) != p  # a random token each time
    for name in (".table.csv.1234.tmp", ".thesis.20240101.tmp", p.name.replace(".tmp", ".TMP"),
                 p.name[:-10] + "0" * 6 + ".tmp"):
        assert atomic.temp_owner(name) is None, name


def test_cleanup_removes_only_uqguides_temporary_files_of_dead_writers(tmp_path, monkeypatch):
    dead = int(subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                              capture_output=True, text=True).stdout)
    stale = atomic.temp_path(tmp_path / "r.h5", dead)
    alive = atomic.temp_path(tmp_path / "r.h5", os.getppid())
    monkeypatch.setattr(atomic.socket, "gethostname", lambda: "another-host")
    elsewhere = atomic.temp_path(tmp_path / "r.h5", dead)  # another host's: its PID is not ours
    monkeypatch.undo()
    users = [tmp_path / ".thesis.20240101.tmp", tmp_path / f".r.h5.{dead}.tmp",
             tmp_path / f".r.h5.{dead}.0123456789abcdef0123.tmp"]
    for p in [stale, alive, elsewhere, *users]:
        p.write_text("x")
    link = atomic.temp_path(tmp_path / "s.h5", dead)
    link.symlink_to(tmp_path / ".thesis.20240101.tmp")
    assert atomic.clean_stale_temps(tmp_path) == [stale]
    assert all(p.exists() for p in [alive, elsewhere, *users]) and link.is_symlink()


def test_a_fresh_run_leaves_the_users_things_in_a_started_run_folder(cfg, tmp_path, caplog):
    """A run folder of a run stopped before its first chunk held a user's sub-folder named
    like a chunk: a fresh run deleted it with rmtree. Now only the manifest goes."""
    out = tmp_path / "out"
    folder = _started(cfg, out)
    (folder / "mc.s0.c0.npz").mkdir()
    (folder / "mc.s0.c0.npz" / "thesis.txt").write_text("years of work")
    (folder / "notes.txt").write_text("mine")
    res = _run("run", cfg, "--out", out, "-q")
    assert res.exit_code == 0, res.output
    assert f"{folder}: left in place, not written by this run: mc.s0.c0.npz, notes.txt" in \
        caplog.messages
    assert (folder / "mc.s0.c0.npz" / "thesis.txt").read_text() == "years of work"
    assert sorted(p.name for p in folder.iterdir()) == ["mc.s0.c0.npz", "notes.txt"]
    assert (out / f"{NAME}.h5").is_file()


@pytest.mark.parametrize("kind", ["folder", "file"])
def test_a_users_thing_at_a_chunks_name_is_refused_not_replaced(cfg, tmp_path, kind):
    out = tmp_path / "out"
    at = _started(cfg, out) / "mc.s0.c000001.npz"
    if kind == "folder":
        at.mkdir()
        (at / "keep.txt").write_text("mine")
    else:
        at.write_text("mine")
    res = _run("run", cfg, "--out", out, "-q")
    assert res.exit_code == 2, res.output
    what = "a folder" if kind == "folder" else "not a uqguide chunk file"
    assert _one_line(res).startswith(f"error: --out: {at} is {what};")
    assert (at / "keep.txt" if kind == "folder" else at).read_text() == "mine"
    assert not (out / f"{NAME}.h5").exists()


def test_a_users_file_at_the_locks_name_is_refused_not_taken(cfg, tmp_path):
    """The lock was taken over whatever file held its name (truncated, then deleted at the
    end); only a lock file (empty, or 'pid N on host H') is uqguide's."""
    lock = tmp_path / "out" / f"{NAME}.run.lock"
    lock.parent.mkdir()
    lock.write_text("my notes on the run\n")
    res = _run("run", cfg, "--out", tmp_path / "out", "-q")
    assert res.exit_code == 2
    assert _one_line(res).startswith(f"error: --out: {lock} is not a uqguide lock file;")
    assert lock.read_text() == "my notes on the run\n"
    lock.write_text("pid 999999999 on host elsewhere\n")  # a killed run's: taken over
    assert _run("run", cfg, "--out", tmp_path / "out", "-q").exit_code == 0
    assert not lock.exists()


# ---------------------------------------------------------------------------- 2. one name
def _make(kind: str, path: Path, outside: Path) -> None:
    if kind == "symlink":
        path.symlink_to(outside)
    elif kind == "hard link":
        os.link(outside, path)
    elif kind == "FIFO":
        os.mkfifo(path)
    elif kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        s.bind(str(path))
        s.close()
    elif kind == "folder":
        path.mkdir()


@pytest.mark.parametrize("kind, what", [
    ("symlink", "a symbolic link"), ("hard link", "a hard link (2 names)"),
    ("FIFO", "a FIFO (named pipe)"), ("socket", "a socket"), ("folder", "a folder"),
    ("device", "a device")])
def test_open_writable_opens_only_a_regular_file_of_one_name(tmp_path, kind, what):
    outside = tmp_path / "outside.txt"
    outside.write_text("the user's\n")
    path = Path("/dev/null") if kind == "device" else tmp_path / "f"
    _make(kind, path, outside)
    for flags in (os.O_WRONLY | os.O_APPEND, os.O_RDWR | os.O_CREAT):
        with pytest.raises(ConfigError) as e:
            atomic.open_writable(path, flags)
        assert f"{path} is {what}" in str(e.value) and "\n" not in str(e.value)
    assert outside.read_text() == "the user's\n"


def test_a_backups_hard_link_to_the_manifest_is_refused_on_resume(interrupted, cfg, tmp_path):
    """A backup made with hard links (``cp -al``, rsnapshot) shares the manifest's inode: the
    lines a resume appended reached the backup. Refused now, before any work."""
    manifest = interrupted / f"{NAME}.run" / "manifest.jsonl"
    backup = tmp_path / "backup.jsonl"
    os.link(manifest, backup)
    before = backup.read_bytes()
    res = _run("run", cfg, "--out", interrupted, "-q", "--resume")
    assert res.exit_code == 2, res.output
    assert _one_line(res).startswith(f"error: --out: {manifest} is a hard link (2 names); the "
                                     f"run's manifest goes there and")
    assert backup.read_bytes() == before
    backup.unlink()
    assert _run("run", cfg, "--out", interrupted, "-q", "--resume").exit_code == 0


def _writes_inside(out: Path, commands: list[list]) -> set[str]:
    """The names of the files ``commands`` open for writing inside ``out``, each checked to be
    opened with O_NOFOLLOW (the mark of open_writable), never by a library by name."""
    writes: list[tuple[str, object, int]] = []
    on = [True]

    def hook(event: str, args: tuple) -> None:
        if event == "open" and on[0] and isinstance(args[0], (str, bytes, os.PathLike)):
            path, mode, flags = os.fsdecode(args[0]), args[1], args[2]
            writing = flags & (os.O_WRONLY | os.O_RDWR | os.O_APPEND | os.O_CREAT) if \
                isinstance(flags, int) else 0
            if writing and path.startswith(str(out)):  # (mode None: os.open)
                writes.append((path, mode, flags))

    sys.addaudithook(hook)  # (a hook stays for the process: switched off below)
    try:
        for args in commands:
            res = _run(*args)
            assert res.exit_code == 0, res.output
    finally:
        on[0] = False
    assert [w for w in writes if not w[2] & os.O_NOFOLLOW] == []
    return {Path(p).name for p, _, _ in writes}


def test_every_file_a_run_writes_is_opened_through_open_writable(cfg, tmp_path, monkeypatch):
    """An audit hook sees every open for writing: the run's are its lock, its manifest and
    temporary files (chunks, result, tables), each opened by open_writable; h5py, numpy and
    pandas write to the open file they are given (HDF5's own opens, in C, are not audited:
    h5py.File is watched for a name instead)."""
    import h5py

    from uqguide.results import result as result_module

    given = []
    real = h5py.File
    monkeypatch.setattr(result_module.h5py, "File", lambda name, mode="r", *a, **k: (
        given.append((type(name).__name__, mode)), real(name, mode, *a, **k))[1])
    out = tmp_path / "out"
    names = _writes_inside(out, [["run", cfg, "--out", out, "-q"],
                                 ["baseline", out / f"{NAME}.h5", "-o", out / "b.json"]])
    temps = {n for n in names if atomic.temp_owner(n) == os.getpid()}
    assert names - temps == {f"{NAME}.run.lock", "manifest.jsonl"}
    assert {atomic.temp_target(n) for n in temps} == {
        f"{NAME}.h5", *(f"{NAME}{t}" for t in ("_stats.csv", "_cost.csv", "_summary.md")),
        *(f"mc.s0.c{i:06d}.npz" for i in range(4)), "b.json"}
    assert [g for g in given if g[1] != "r"] == [("HeldErrorFile", "w")]


@pytest.mark.slow
def test_every_file_plot_report_and_replay_write_is_opened_through_open_writable(cfg,
                                                                                 tmp_path):
    """As above for the figures (matplotlib), the report and a replay's history (~5 CPU-s)."""
    out = tmp_path / "out"
    assert _run("run", cfg, "--out", out, "-q").exit_code == 0
    h5 = out / f"{NAME}.h5"
    names = _writes_inside(out, [
        ["plot", h5, "--out", out / "f"], ["report", h5, "--out", out / "r"],
        ["replay", h5, "--label", "mc", "--sample", "3", "--out", out / "p", "--config", cfg]])
    assert len(names) > 3
    assert all(atomic.temp_owner(n) == os.getpid() for n in names), names


# ---------------------------------------------------------------------------- 3. no blocking
@pytest.mark.parametrize("name", [f"{NAME}.h5", f"{NAME}_stats.csv", f"{NAME}.run.lock",
                                  f"{NAME}.run/manifest.jsonl", f"{NAME}.run/mc.s0.c000000.npz"])
def test_a_fifo_where_a_resume_reads_or_writes_is_refused_at_once(interrupted, cfg, name):
    at = interrupted / name
    at.unlink(missing_ok=True)
    os.mkfifo(at)
    res = _run("run", cfg, "--out", interrupted, "-q", "--resume", timeout=20)
    assert res.exit_code == 2, res.output
    line = _one_line(res)
    assert line.startswith(f"error: --out: {at} is a FIFO (named pipe);"), line
    assert at.is_fifo()


def test_a_fifo_at_the_run_folders_name_is_refused(cfg, tmp_path):
    (tmp_path / "out").mkdir()
    os.mkfifo(tmp_path / "out" / f"{NAME}.run")
    res = _run("run", cfg, "--out", tmp_path / "out", "-q")
    assert res.exit_code == 2 and "is not a uqguide run folder" in _one_line(res)


@pytest.mark.parametrize("command", ["run CONFIG", "check RESULT", "check --baseline",
                                     "run --check"])
def test_a_fifo_given_to_read_is_refused_at_once(cfg, tmp_path, command):
    out = tmp_path / "out"
    assert _run("run", cfg, "--out", out, "-q").exit_code == 0
    h5 = out / f"{NAME}.h5"
    assert _run("baseline", h5, "-o", tmp_path / "b.json").exit_code == 0
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    args = {"run CONFIG": ["run", fifo, "--out", out],
            "check RESULT": ["check", fifo, "--baseline", tmp_path / "b.json"],
            "check --baseline": ["check", h5, "--baseline", fifo],
            "run --check": ["run", cfg, "--out", out, "--check", fifo]}[command]
    res = _run(*args, timeout=20)
    assert res.exit_code == 2, res.output
    assert str(fifo) in _one_line(res) and "not a" in _one_line(res)


# ---------------------------------------------------------------------------- 4. full disk
def test_a_full_disk_at_a_chunk_is_one_line_and_the_run_resumes_identically(cfg, tmp_path,
                                                                             monkeypatch):
    assert _run("run", cfg, "--out", tmp_path / "ref", "-q").exit_code == 0
    real, calls = np.savez, []

    def full_at_the_second(*args, **kwargs):
        calls.append(1)
        if len(calls) == 2:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(*args, **kwargs)

    monkeypatch.setattr(run_folder.np, "savez", full_at_the_second)
    out = tmp_path / "out"
    res = _run("run", cfg, "--out", out, "-q")
    assert res.exit_code == 1, res.output
    assert _one_line(res) == (
        f"error: disk full writing {out / 'st.run' / 'mc.s0.c000001.npz'}; the run folder is "
        f"intact; free space and --resume: `uqguide run {cfg} --resume --out {out}`")
    assert sorted(p.name for p in (out / "st.run").iterdir()) == ["manifest.jsonl",
                                                                  "mc.s0.c000000.npz"]
    monkeypatch.undo()
    assert _run("run", cfg, "--out", out, "-q", "--resume").exit_code == 0
    stats = f"{NAME}_stats.csv"
    assert (out / stats).read_bytes() == (tmp_path / "ref" / stats).read_bytes()


def test_a_line_the_disk_had_no_room_for_is_taken_back_whole(cfg, tmp_path, monkeypatch):
    """Half a manifest line written, then ENOSPC: the file is as it was, so the next line
    does not join a torn one."""
    folder = _started(cfg, tmp_path)
    manifest = folder / "manifest.jsonl"
    before = manifest.read_bytes()
    real = os.write

    def half(fd: int, data: bytes) -> int:
        if len(data) > 20:
            real(fd, data[: len(data) // 2])
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(fd, data)

    c = uqguide.load_config(cfg)
    store = RunStore.open(folder, run_identity(c.resolved(), c.model), resume=True)
    monkeypatch.setattr(run_folder.os, "write", half)
    with pytest.raises(DiskFull) as e:
        store.manifest.record_isolated("mc", 0, 3, "a crash")
    monkeypatch.undo()
    assert e.value.path == manifest and manifest.read_bytes() == before
    store.manifest.record_isolated("mc", 0, 3, "a crash")
    assert store.manifest.isolated() == {("mc", 0): {3: "a crash"}}


def test_a_result_file_on_a_full_disk_is_refused_whole(cfg, tmp_path, monkeypatch):
    """HDF5 crashed the process at exit (exit 139) after a failed write, with a traceback of
    each object it could not close: it now writes through a file that holds the error until
    the library has closed the file, and the error is one DiskFull."""
    from uqguide.results.result import read_hdf5, write_hdf5

    assert _run("run", cfg, "--out", tmp_path / "ref", "-q").exit_code == 0
    result = read_hdf5(tmp_path / "ref" / f"{NAME}.h5")
    real, written = os.pwrite, [0]

    def full_after_8_kib(fd: int, data, offset: int) -> int:
        if written[0] + len(data) > 8192:
            raise OSError(errno.EFBIG, "File too large")
        written[0] += len(data)
        return real(fd, data, offset)

    monkeypatch.setattr(atomic.os, "pwrite", full_after_8_kib)
    target = tmp_path / "o" / "r.h5"
    with pytest.raises(DiskFull) as e:
        write_hdf5(result, target)
    monkeypatch.undo()
    assert e.value.path == target and list((tmp_path / "o").iterdir()) == []
    write_hdf5(result, target)
    assert read_hdf5(target).run("mc").n_failed == 0


def test_hdf5_writing_to_dev_full_raises_once_and_exits_cleanly():
    """The library's own crash, in a child: /dev/full fails every write with ENOSPC."""
    code = ("import os, h5py, numpy as np\n"
            "from uqguide.core.atomic import HeldErrorFile\n"
            "fd = os.open('/dev/full', os.O_RDWR)\n"
            "raw = HeldErrorFile(fd)\n"
            "try:\n"
            "    with h5py.File(raw, 'w') as f:\n"
            "        for i in range(30):\n"
            "            f.create_dataset(f'd{i}', data=np.arange(1000.0))\n"
            "finally:\n"
            "    try:\n"
            "        raw.close()\n"
            "    except OSError as exc:\n"
            "        print('held', exc.errno)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=60)
    assert (p.returncode, p.stdout, p.stderr) == (0, f"held {errno.ENOSPC}\n", "")


def _dangling(tmp: Path) -> Path:
    (tmp / "o").symlink_to(tmp / "nowhere")
    return tmp / "o"


def _loop(tmp: Path) -> Path:
    (tmp / "o").symlink_to(tmp / "o")
    return tmp / "o"


def _under_a_file(tmp: Path) -> Path:
    (tmp / "f").write_text("mine")
    return tmp / "f" / "sub"


def _a_fifo(tmp: Path) -> Path:
    os.mkfifo(tmp / "o")
    return tmp / "o"


@pytest.mark.parametrize("make, says", [
    (_dangling, "is a symbolic link to {tmp}/nowhere, which does not exist"),
    (_loop, "{tmp}/o is a symbolic link loop"),
    (_under_a_file, "{tmp}/f is a file, not a folder (the folder {tmp}/f/sub would be under it)"),
    (lambda tmp: Path("/dev/null"), "/dev/null is a device, not a folder"),
    (_a_fifo, "{tmp}/o is a FIFO (named pipe), not a folder"),
    (lambda tmp: Path("/proc/uqguide-out"), "cannot make /proc/uqguide-out"),
], ids=["dangling link", "link loop", "under a file", "/dev/null", "a FIFO", "read-only"])
def test_an_unusable_out_is_one_line_before_any_work(cfg, tmp_path, make, says):
    sandbox = tmp_path / "s"
    sandbox.mkdir()
    out = make(sandbox)
    before = sorted(sandbox.iterdir())
    res = _run("run", cfg, "--out", out, "-q")
    assert res.exit_code == 2, res.output
    assert says.format(tmp=sandbox) in _one_line(res)
    assert sorted(sandbox.iterdir()) == before


@pytest.mark.skipif(os.geteuid() == 0, reason="root writes into a folder without write rights")
def test_an_out_without_write_rights_is_one_line(cfg, tmp_path):
    (tmp_path / "ro").mkdir(mode=0o500)
    res = _run("run", cfg, "--out", tmp_path / "ro" / "out", "-q")
    assert res.exit_code == 2
    assert f"{tmp_path / 'ro'} is not writable by this user" in _one_line(res)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="RLIMIT_FSIZE as on Linux")
def test_a_full_disk_in_a_real_process_at_three_moments():
    """benchmarks/fuzz_containment.py's disk-full cases at the lock, the manifest and the
    result file (child processes under RLIMIT_FSIZE, each then resumed): about 30 s."""
    fuzz = _fuzz()
    import tempfile

    with tempfile.TemporaryDirectory() as t:
        work = Path(t)
        shared = fuzz.templates(work)
        limits = fuzz.disk_limits(shared)
        cases = [c for c in fuzz.disk_full_cases(shared) if c.fsize in
                 (limits[0], limits[1], limits[-2]) and c.name.startswith("disk full: run,")]
        outcomes = [fuzz.try_case(c, work, shared) for c in cases]
    assert len(outcomes) == 3
    assert [(o.case, o.run.exit_code, o.ok) for o in outcomes] == [
        (o.case, 1, True) for o in outcomes], [(o.problems, o.run.stderr) for o in outcomes]


def _fuzz():
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import fuzz_containment
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return fuzz_containment


@pytest.mark.slow
def test_a_sample_of_the_containment_fuzz_is_clean():
    """40 of benchmarks/fuzz_containment.py's cases, child processes included (about 15 CPU-s;
    its full run gives the summary line of docs/scale.md)."""
    fuzz = _fuzz()
    outcomes = fuzz.run_all(sample=40, seed=7)
    assert len(outcomes) == 40 and len({o.case.split(":")[0] for o in outcomes}) >= 4
    assert [o.case for o in outcomes if not o.ok] == []
    assert fuzz.summary_line(outcomes) == (
        "0 user files lost or changed, 0 writes outside --out, 0 runs past 60 s, 0 tracebacks, "
        "0 processes left behind, peak RSS under max_memory in every case")


def _case_module(name: str):
    _fuzz()  # the case modules import fuzz_containment's Case
    sys.path.insert(0, str(ROOT / "benchmarks"))
    try:
        import importlib

        return importlib.import_module(name)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))


def test_the_data_cases_run_in_the_one_campaign(tmp_path):
    """benchmarks/containment_data.py's cases are fuzz_containment's: a repeated column refused
    with its line, the Python API's repeated column a ConfigError, each judged by
    fuzz_containment's one harness (in this process, about 1 CPU-s)."""
    fuzz, data = _fuzz(), _case_module("containment_data")
    assert {"containment_command", "containment_data"} <= set(fuzz.CASE_MODULES)
    cases = {c.name: c for c in data.cases(quick=True)}
    assert all(isinstance(c, fuzz.Case) and c.group in ("data file", "data fmu")
               for c in cases.values())
    picked = ["data file: csv_repeated_name", "data file: fit_repeated_column"]
    outcomes = [fuzz.try_case(cases[n], tmp_path, {}) for n in picked]
    assert [(o.case, o.run.exit_code, o.ok) for o in outcomes] == [
        (picked[0], 2, True), (picked[1], 2, True)], [(o.problems, o.run.stderr)
                                                      for o in outcomes]
    wrong = fuzz.Case("data file: wrong message", cases[picked[0]].prepare,
                      check=lambda box, run: ["a problem"])
    assert not fuzz.try_case(wrong, tmp_path, {}).ok  # a check's problem is counted


def _clean(names: tuple[str, ...], quick_data: bool = True) -> list:
    """fuzz_containment's outcomes of the first command or data case whose name starts with
    each of ``names``, run in a temporary folder."""
    import tempfile

    fuzz = _fuzz()
    command, data = _case_module("containment_command"), _case_module("containment_data")
    every = [*command.cases(), *data.cases(quick=quick_data)]
    cases = [next(c for c in every if c.name.startswith(n)) for n in names]
    fuzz._subreaper()
    with tempfile.TemporaryDirectory() as t:
        return [fuzz.try_case(c, Path(t), {}) for c in cases]


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="daemons found through /proc")
def test_command_and_data_cases_in_child_processes_are_clean():
    """A FIFO as outputs, a setsid daemon, a quoted placeholder in a ``$(...)`` path, 64 MB of
    extra rows, a repeated column (benchmarks/containment_command.py); a 200 MB sparse CSV, a
    lying npz header, an FMU run stopped by Ctrl-C (containment_data.py, quick sizes): about
    40 s."""
    outcomes = _clean(("command outputs: a fifo", "command daemon: setsid, exits",
                       "command shell: \"{inputs}\" in", "command oversized: 64 MB",
                       "command columns: y twice", "data file: csv_sparse",
                       "data file: npz_header", "data fmu: fmu_ctrl_c"))
    assert [o.case for o in outcomes if not o.ok] == [], [
        (o.case, o.problems, o.lost, o.outside, o.left_behind, o.run.stderr[-300:])
        for o in outcomes if not o.ok]
    assert _fuzz().summary_line(outcomes).startswith("0 user files lost or changed, 0 writes")


@pytest.mark.slow
def test_an_fmu_run_killed_then_validated_leaves_nothing():
    """containment_data.py's killed FMU run, then ``validate`` (about 15 s): nothing of it in
    TMPDIR, neither its unzipped FMU nor multiprocessing's folder (the fork server's socket),
    which a killed run left as ``pymp-*`` before."""
    (o,) = _clean(("data fmu: fmu_killed_then_validate",))
    assert o.ok, (o.outside, o.run.stderr[-500:])
