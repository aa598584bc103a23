"""Containment fuzz (issue 44): hostile layouts around a run, then a uqguide command; after each,
nothing of the user's is lost or changed, nothing outside ``--out`` is written, nothing hangs,
crashes or is left running, and the peak RSS stays under ``max_memory``.

A :class:`Case` prepares a sandbox (:class:`Box`), runs one command (in this process, or as a
child under limits) and is judged on snapshots of the whole box, before and after; what was
there is the user's unless in ``box.own``. Findings: docs/scale.md ("Checkpoints and --resume").

A module with a ``cases()`` generator of :class:`Case` (or of objects or dicts with its fields;
``from fuzz_containment import Box, Case``) plugs in with one line in :data:`CASE_MODULES`:
containment_command.py (hostile ``command`` programs), containment_data.py (data files, FMUs).

    python benchmarks/fuzz_containment.py                # every case: table and summary line
    python benchmarks/fuzz_containment.py --sample 40    # 40 cases at random
    python benchmarks/fuzz_containment.py --group disk   # the groups whose name has "disk"
"""

from __future__ import annotations

import argparse
import contextlib
import ctypes
import fnmatch
import hashlib
import importlib
import os
import random
import resource
import secrets
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from collections import Counter
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
for _p in (ROOT, ROOT / "benchmarks"):  # the test models live in tests/, case modules here
    if str(_p) not in sys.path:
        sys.path.insert(0, str(_p))
if __name__ == "__main__":  # a case module's `from fuzz_containment import Case` gets this one
    sys.modules.setdefault("fuzz_containment", sys.modules["__main__"])

import psutil  # noqa: E402
from click.testing import CliRunner  # noqa: E402

from tests import failing_models  # noqa: E402
from uqguide.cli import main  # noqa: E402
from uqguide.core import atomic  # noqa: E402
from uqguide.driver.execution.guard import close_guards  # noqa: E402
from uqguide.errors import ConfigError  # noqa: E402
from uqguide.models.fmu import archive as fmu_archive  # noqa: E402

#: Case modules beside this file, one line each (a module not found is skipped, and said so).
CASE_MODULES: list[str] = ["containment_command", "containment_data"]

#: Seconds a command may take; a case over it is killed and counted.
MAX_SECONDS = 60.0
#: The configs' max_memory, which every case's peak RSS must stay under.
MAX_MEMORY = 2 * 10**9
#: The environment variable marking every process a case's command starts: one holding it
#: after the case was left behind, wherever it was reparented to.
TOKEN = "UQGUIDE_FUZZ_CASE"
#: Seconds the processes of a command may take to end after it (a kill's delivery, a fork
#: server's exit once its parent's pipe closes).
GRACE_S = 3.0

NAME = "st"
CONFIG = {**failing_models.mc_config("tests.failing_models:ctrl_c_on_third_call", 200, 50),
          "name": NAME, "max_memory": "2 GB"}
CONFIG["model"] = {**CONFIG["model"], "isolate": False}  # the Ctrl-C must reach the driver
TABLES = [f"{NAME}_stats.csv", f"{NAME}_cost.csv", f"{NAME}_summary.md"]


# ---------------------------------------------------------------------------- the interface
@dataclass
class Box:
    """The sandbox of one case, under ``root``; ``own`` collects glob patterns (relative to
    ``root``) of what the command may create, replace or delete there."""

    root: Path
    shared: Mapping[str, Path] = field(default_factory=dict)
    own: set[str] = field(default_factory=set)

    def owns(self, rel: str) -> bool:
        """Whether the entry at ``rel`` is the command's (matches a pattern of ``own``)."""
        return any(fnmatch.fnmatchcase(rel, pat) for pat in self.own)

    @property
    def out(self) -> Path:
        """The ``--out`` of the command."""
        return self.root / "out"

    @property
    def outside(self) -> Path:
        """Files of the user's outside ``--out`` (links and hard links point here)."""
        return self.root / "outside"

    @property
    def inputs(self) -> Path:
        """The case's config and input files (read, never written)."""
        return self.root / "in"

    @property
    def tmp(self) -> Path:
        """The command's TMPDIR: what is left in it is a write outside ``--out``."""
        return self.root / "tmp"


@dataclass
class Run:
    """What a command did: exit code (None: killed at the time limit), output, time, memory."""

    exit_code: int | None
    stdout: str
    stderr: str
    seconds: float
    peak_rss: int
    traceback: bool
    error: str = ""


@dataclass
class Case:
    """One case.

    Attributes
    ----------
    name : str
        ``"group: detail"``, unique.
    prepare : callable
        ``prepare(box)`` makes the case's files (and adds to ``box.own``) and returns the
        arguments of ``uqguide``.
    expect : tuple of int
        Exit codes allowed.
    child : bool
        Run ``python -m uqguide.cli`` as a child process (else in this process).
    fsize : int, optional
        The child's ``RLIMIT_FSIZE`` in bytes (a full disk at that file size).
    env : mapping
        Environment variables of the command.
    max_memory : int
        Bytes the peak RSS must stay under.
    check : callable, optional
        ``check(box, run)`` after the command: a list of problems (empty: fine).
    signal : int
        Sent to the child once its run folder holds a chunk (0: none); dying of it is no crash.
    address_space : int, optional
        The child's ``RLIMIT_AS`` in bytes: a runaway read fails there, not the machine.
    call : callable, optional
        In place of a command, ``call(box)`` in this process (the Python API): a ConfigError
        is exit 2 with its message, another exception a traceback.
    """

    name: str
    prepare: Callable[[Box], Sequence[str | Path]]
    expect: tuple[int, ...] = (0, 1, 2)
    child: bool = False
    fsize: int | None = None
    env: Mapping[str, str] = field(default_factory=dict)
    max_memory: int = MAX_MEMORY
    check: Callable[[Box, Run], list[str]] | None = None
    signal: int = 0
    address_space: int | None = None
    call: Callable[[Box], object] | None = None

    @property
    def group(self) -> str:
        return self.name.split(":", 1)[0]


@dataclass
class Outcome:
    case: str
    run: Run
    lost: list[str]
    outside: list[str]
    left_behind: int
    max_memory: int
    problems: list[str]

    @property
    def past(self) -> bool:
        return self.run.exit_code is None or self.run.seconds > MAX_SECONDS

    @property
    def over_memory(self) -> bool:
        return self.run.peak_rss >= self.max_memory

    @property
    def ok(self) -> bool:
        return not (self.lost or self.outside or self.left_behind or self.past or
                    self.run.traceback or self.over_memory or self.problems)


# ---------------------------------------------------------------------------- snapshots
def snapshot(top: Path, own: Callable[[str], bool] = lambda rel: False) -> dict[str, tuple]:
    """Every entry under ``top`` by its path relative to ``top``: its type and, for a file, its
    bytes' digest and inode, for a link its target; an entry ``own`` accepts is only named (a
    model's 1 TB sparse output left in its workdir is not read). Nothing is followed or opened
    but files."""
    out: dict[str, tuple] = {}
    for dirpath, dirnames, filenames in os.walk(top, followlinks=False):
        d = Path(dirpath)
        for n in dirnames + filenames:
            p = d / n
            rel = p.relative_to(top).as_posix()
            st = os.lstat(p)
            if own(rel):
                out[rel] = ("own",)
            elif stat.S_ISLNK(st.st_mode):
                out[rel] = ("link", os.readlink(p))
            elif stat.S_ISDIR(st.st_mode):
                out[rel] = ("dir",)
            elif stat.S_ISREG(st.st_mode):
                out[rel] = ("file", _digest(p), st.st_ino)
            else:
                out[rel] = ("special", stat.S_IFMT(st.st_mode), st.st_ino)
    return out


def _digest(path: Path) -> str:
    """A file's sha256, read in blocks (a case's 2 GB input must not raise this process's
    peak RSS, which the in-process cases report)."""
    h = hashlib.sha256()
    with path.open("rb") as f:
        while block := f.read(2**22):
            h.update(block)
    return h.hexdigest()


def judge(box: Box, before: dict[str, tuple], after: dict[str, tuple]) -> tuple[list[str],
                                                                                list[str]]:
    """(user entries lost or changed, entries outside ``out/`` created, changed or deleted
    other than the case's own: a model's ``workdir``, a daemon's pid file)."""
    own = box.owns
    lost = sorted(k for k, v in before.items() if after.get(k) != v and not own(k))
    outside = sorted(k for k in set(before) | set(after) if not k.startswith("out/") and
                     k != "out" and before.get(k) != after.get(k) and not own(k))
    return lost, outside


# ---------------------------------------------------------------------------- running
class _PastTime(BaseException):
    """The in-process command ran past MAX_SECONDS."""


def _on_alarm(signum: int, frame: Any) -> None:
    raise _PastTime


def _subreaper() -> None:
    """Orphans of the commands (a daemon that left with setsid) become our children: counted."""
    if sys.platform.startswith("linux"):
        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL(None, use_errno=True).prctl(36, 1, 0, 0, 0)  # PR_SET_CHILD_SUBREAPER


@contextlib.contextmanager
def _environment(env: Mapping[str, str], tmp: Path) -> Iterator[None]:
    old = {k: os.environ.get(k) for k in [*env, "TMPDIR"]}
    os.environ.update(env)
    os.environ["TMPDIR"] = str(tmp)
    tempfile.tempdir = None
    try:
        yield
    finally:
        for k, v in old.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        tempfile.tempdir = None


def run_in_process(args: Sequence[str], env: Mapping[str, str], tmp: Path,
                   call: Callable[[], object] | None = None) -> Run:
    """``uqguide ARGS`` through click's runner (or ``call()``) in this process."""
    failing_models._calls["n"] = 0
    old = signal.signal(signal.SIGALRM, _on_alarm)
    t0 = time.monotonic()
    try:
        with _environment({"UQGUIDE_TEST_ARM_CTRL_C": "0", **env}, tmp):
            signal.setitimer(signal.ITIMER_REAL, MAX_SECONDS)
            try:
                if call is not None:
                    return _called(call, t0)
                res = CliRunner().invoke(main, [str(a) for a in args])
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
    except _PastTime:
        return Run(None, "", "", time.monotonic() - t0, _self_rss(), False)
    finally:
        signal.signal(signal.SIGALRM, old)
        close_guards()  # as the process's end would: a guard is reused within a process
    raised = res.exception is not None and not isinstance(res.exception, SystemExit)
    error = "".join(traceback.format_exception(res.exception))[-2000:] if raised else ""
    return Run(res.exit_code, res.stdout, res.stderr, time.monotonic() - t0, _self_rss(),
               raised or "Traceback" in res.output, error)


def _called(call: Callable[[], object], t0: float) -> Run:
    """A call of the Python API as a command: a ConfigError is exit 2 with its one line."""
    try:
        call()
    except ConfigError as exc:
        return Run(2, "", f"error: {exc}\n", time.monotonic() - t0, _self_rss(), False)
    except Exception:  # noqa: BLE001 - a traceback is what the case counts
        error = traceback.format_exc()[-2000:]
        return Run(1, "", error, time.monotonic() - t0, _self_rss(), True, error)
    return Run(0, "", "", time.monotonic() - t0, _self_rss(), False)


def _self_rss() -> int:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def run_child(args: Sequence[str], env: Mapping[str, str], tmp: Path,
              fsize: int | None, address_space: int | None = None, send: int = 0,
              out: Path | None = None) -> Run:
    """``python -m uqguide.cli ARGS`` as a child (its peak RSS from ``wait4``), under the
    limits given; ``send``: a signal sent once ``out`` holds a run folder's chunk."""
    def limits() -> None:
        signal.signal(signal.SIGINT, signal.SIG_DFL)  # a background job's SIGINT is ignored
        if fsize is not None:
            resource.setrlimit(resource.RLIMIT_FSIZE, (fsize, fsize))
        if address_space is not None:
            resource.setrlimit(resource.RLIMIT_AS, (address_space, address_space))

    full_env = {**os.environ, "PYTHONPATH": str(ROOT), "UQGUIDE_TEST_ARM_CTRL_C": "0",
                "TMPDIR": str(tmp), **env}
    full_env.pop(fmu_archive.ENV, None)  # the unzipped FMU this process was handed, if any
    t0 = time.monotonic()
    p = subprocess.Popen([sys.executable, "-m", "uqguide.cli", *map(str, args)], cwd=ROOT,
                         env=full_env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         preexec_fn=limits, start_new_session=True)
    texts: dict[str, bytes] = {}
    readers = [threading.Thread(target=lambda k=k, s=s: texts.__setitem__(k, s.read()))
               for k, s in (("out", p.stdout), ("err", p.stderr))]
    for r in readers:
        r.start()
    timer = threading.Timer(MAX_SECONDS, lambda: _kill_group(p.pid))
    timer.start()
    reaped = threading.Event()
    if send:
        threading.Thread(target=_send_after_a_chunk, args=(p.pid, send, out, reaped),
                         daemon=True).start()
    try:
        _, status, usage = os.wait4(p.pid, 0)
    finally:
        reaped.set()
        timer.cancel()
    p.returncode = os.waitstatus_to_exitcode(status)
    for r in readers:
        r.join()
    seconds = time.monotonic() - t0
    code: int | None = None if seconds > MAX_SECONDS else p.returncode
    err = texts.get("err", b"").decode(errors="replace")
    out = texts.get("out", b"").decode(errors="replace")
    # a signal's death (a segfault: -11) is a crash, counted with the tracebacks, unless
    # it is the one sent
    tb = "Traceback" in err or "Traceback" in out or (
        code is not None and code < 0 and code != -send)
    return Run(code, out, err, seconds, usage.ru_maxrss * 1024, tb)


def _send_after_a_chunk(pid: int, signum: int, out: Path | None,
                        reaped: threading.Event) -> None:
    deadline = time.monotonic() + MAX_SECONDS
    while out is not None and not any(out.glob("*.run/*.npz")) and not reaped.is_set() \
            and time.monotonic() < deadline:
        time.sleep(0.05)
    if not reaped.is_set():
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signum)


def _kill_group(pid: int) -> None:
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(pid, signal.SIGKILL)


def _left_behind(before: set[int], token: str) -> int:
    """Processes of ours (children, adopted orphans) that appeared during the case, and any
    holding its token, still there after :data:`GRACE_S`; they are killed."""
    me = psutil.Process()
    deadline = time.monotonic() + GRACE_S
    while True:
        new = [c for c in me.children(recursive=True) if c.pid not in before and _alive(c)]
        seen = {c.pid for c in new} | before | {me.pid}
        new += [psutil.Process(pid) for pid in _marked(token) if pid not in seen]
        if not new or time.monotonic() > deadline:
            break
        time.sleep(0.05)
    for c in new:
        with contextlib.suppress(psutil.Error):
            c.kill()
    for c in me.children(recursive=False):
        with contextlib.suppress(psutil.Error, ChildProcessError):
            if c.pid not in before:
                c.wait(timeout=5)
    return len(new)


def _marked(token: str) -> list[int]:
    """Live processes whose environment holds ``TOKEN=token`` (Linux's /proc; elsewhere
    none: the subreaper's children are then all that is counted)."""
    key = f"{TOKEN}={token}".encode()
    found = []
    for p in psutil.process_iter():
        with contextlib.suppress(OSError, psutil.Error):
            if key in Path(f"/proc/{p.pid}/environ").read_bytes().split(b"\0") and _alive(p):
                found.append(p.pid)
    return found


def _alive(p: psutil.Process) -> bool:
    try:
        return p.is_running() and p.status() != psutil.STATUS_ZOMBIE
    except psutil.Error:
        return False


def try_case(case: Case, work: Path, shared: Mapping[str, Path]) -> Outcome:
    """Prepare the case in a fresh box under ``work``, run it, judge it."""
    root = work / "box"
    if root.exists():
        shutil.rmtree(root)
    box = Box(root, shared)
    for d in (box.out.parent, box.outside, box.inputs, box.tmp):
        d.mkdir(parents=True, exist_ok=True)
    args = [str(a) for a in case.prepare(box)]
    before = snapshot(root, box.owns)
    pids = {c.pid for c in psutil.Process().children(recursive=True)}
    token = secrets.token_hex(8)
    env = {**case.env, TOKEN: token}
    call = case.call
    run = (run_child(args, env, box.tmp, case.fsize, case.address_space, case.signal, box.out)
           if case.child else run_in_process(args, env, box.tmp,
                                             None if call is None else lambda: call(box)))
    left = _left_behind(pids, token)
    problems = []
    if run.exit_code is not None and run.exit_code not in case.expect:
        problems.append(f"exit {run.exit_code} (expected {case.expect})")
    if case.check is not None and run.exit_code is not None:
        problems += case.check(box, run)
    after = snapshot(root, box.owns)
    lost, outside = judge(box, before, after)
    return Outcome(case.name, run, lost, outside, left, case.max_memory, problems)


# ---------------------------------------------------------------------------- shared states
def _invoke(*args: str | Path, armed: bool = False) -> Any:
    failing_models._calls["n"] = 0
    with _environment({"UQGUIDE_TEST_ARM_CTRL_C": "1" if armed else "0"}, Path(
            tempfile.gettempdir())):
        return CliRunner().invoke(main, [str(a) for a in args])


def templates(work: Path) -> dict[str, Path]:
    """The states the cases start from, made by real runs: the config, a finished ``--out``
    (``done``), a run folder interrupted after two chunks (``resume``), one with only its
    header (``started``), one whose chunks are all done but whose result was interrupted
    (``cleanup``)."""
    made = {"config": work / "st.yaml"}
    made["config"].write_text(yaml.safe_dump(CONFIG))
    res = _invoke("run", made["config"], "--out", work / "t_done", "-q")
    assert res.exit_code == 0, res.output
    made["done"] = work / "t_done"
    made["baseline"] = work / "baseline.json"
    res = _invoke("baseline", made["done"] / f"{NAME}.h5", "-o", made["baseline"])
    assert res.exit_code == 0, res.output
    res = _invoke("run", made["config"], "--out", work / "t_resume", "-q", armed=True)
    assert res.exit_code == 130, res.output
    made["resume"] = work / "t_resume" / f"{NAME}.run"
    started = work / "t_started" / f"{NAME}.run"
    shutil.copytree(made["resume"], started)
    manifest = started / "manifest.jsonl"
    manifest.write_text(manifest.read_text().splitlines(keepends=True)[0])
    for p in started.glob("*.npz"):
        p.unlink()
    made["started"] = started
    from uqguide.commands import run_and_write as rw

    real = rw.write_hdf5

    def stopped(*a: Any, **k: Any) -> Any:
        raise KeyboardInterrupt

    rw.write_hdf5 = stopped
    try:
        res = _invoke("run", made["config"], "--out", work / "t_cleanup", "-q")
    finally:
        rw.write_hdf5 = real
    assert res.exit_code == 130, res.output
    made["cleanup"] = work / "t_cleanup" / f"{NAME}.run"
    return made


# ---------------------------------------------------------------------------- plants
#: A process that is gone (its temporary files are stale): a child started and reaped.
_DEAD = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                       capture_output=True, text=True, check=True).stdout.strip()

#: Names in ``out/``: the run's own (result, tables, run folder, lock), the user's, and the
#: user's files named like temporary files (a date, an old-style uqguide name with a dead PID,
#: a forged token).
OUT_NAMES = [f"{NAME}.h5", *TABLES, f"{NAME}.run", f"{NAME}.run.lock", "notes.txt", "data",
             ".thesis.20240101.tmp", f".{NAME}.h5.{_DEAD}.tmp",
             f".{NAME}.h5.{_DEAD}.0123456789abcdef0123.tmp"]
#: Names in the run folder: the manifest, chunks (listed, not listed), names like a chunk's,
#: the user's, temporary-looking names.
RUN_NAMES = ["manifest.jsonl", "mc.s0.c000000.npz", "mc.s0.c000003.npz", "mc.s0.c000007.npz",
             "mc.s0.c0.npz", "notes.txt", "sub", f".mc.s0.c000002.npz.{_DEAD}.tmp",
             ".thesis.20240101.tmp"]
#: Names a run replaces by a rename (a plain file or a hard link there is the run's to
#: replace; its other name, outside, stays as it was).
REPLACED = {f"{NAME}.h5", *TABLES}
KINDS = ["file", "folder", "link_file", "link_folder", "link_absent", "hardlink", "backup",
         "fifo", "socket"]
PHASES = ["run", "rerun", "started", "resume", "cleanup"]


@dataclass(frozen=True)
class Plant:
    where: str  # "out" or "run"
    name: str
    kind: str

    @property
    def rel(self) -> str:
        return self.name if self.where == "out" else f"{NAME}.run/{self.name}"


def _clear(path: Path) -> None:
    if path.is_symlink() or (path.exists() and not path.is_dir()):
        path.unlink()
    elif path.is_dir():
        shutil.rmtree(path)


def plant(box: Box, p: Plant) -> None:
    path = box.out / p.rel
    path.parent.mkdir(parents=True, exist_ok=True)
    if p.kind == "backup":  # a second name, outside, of what is there (cp -al)
        backup = box.outside / "backup" / p.rel.replace("/", "__")
        backup.parent.mkdir(parents=True, exist_ok=True)
        os.link(path, backup)
        return
    _clear(path)
    if p.kind == "file":
        path.write_text(f"the user's {p.name}\n")
    elif p.kind == "folder":
        path.mkdir()
        (path / "keep.txt").write_text("the user's\n")
    elif p.kind == "link_file":
        path.symlink_to(box.outside / "victim.txt")
    elif p.kind == "link_folder":
        path.symlink_to(box.outside / "vdir", target_is_directory=True)
    elif p.kind == "link_absent":
        path.symlink_to(box.outside / "ghost")
    elif p.kind == "hardlink":
        os.link(box.outside / "victim.txt", path)
    elif p.kind == "fifo":
        os.mkfifo(path)
    elif p.kind == "socket":
        s = socket.socket(socket.AF_UNIX)
        try:
            s.bind(str(path))
        finally:
            s.close()


def _exists_in(phase: str, shared: Mapping[str, Path], p: Plant) -> bool:
    """Whether the phase's starting state has something at the plant's name."""
    if phase == "rerun":
        return p.where == "out" and (shared["done"] / p.name).exists()
    if phase in ("started", "resume", "cleanup") and p.where == "run":
        return (shared[phase] / p.name).exists()
    return False


def layout_case(phase: str, plants: tuple[Plant, ...]) -> Case:
    def prepare(box: Box) -> list[str | Path]:
        (box.outside / "vdir").mkdir(parents=True)
        (box.outside / "victim.txt").write_text("outside, untouched\n")
        (box.outside / "vdir" / "f.txt").write_text("outside, untouched\n")
        box.out.mkdir()
        shared = box.shared
        if phase == "rerun":
            for f in shared["done"].iterdir():
                shutil.copy2(f, box.out / f.name)
                box.own.add(f"out/{f.name}")
        elif phase in ("started", "resume", "cleanup"):
            shutil.copytree(shared[phase], box.out / f"{NAME}.run")
            box.own.update({f"out/{NAME}.run", f"out/{NAME}.run/*"})
        for p in plants:
            plant(box, p)
        planted = {f"out/{p.rel}" for p in plants if p.kind != "backup"}
        # a plant replaces what was there: it is the user's, not the run's (the run folder
        # itself stays the run's when only its content is planted)
        box.own -= planted
        if any(p.where == "out" and p.name == f"{NAME}.run" for p in plants):
            box.own.discard(f"out/{NAME}.run/*")
        for p in plants:
            if p.name in REPLACED and p.where == "out" and p.kind in ("file", "hardlink"):
                box.own.add(f"out/{p.rel}")  # replacing them is the run's job
            if p.where == "run" and p.kind in ("file", "hardlink") and phase != "run" and \
                    _exists_in(phase, shared, Plant(p.where, p.name, "backup")) and \
                    p.name != "manifest.jsonl":
                box.own.add(f"out/{p.rel}")  # a listed chunk's file: the run rewrites it
        # uqguide's own stale temporary files (its PID gone) are removed by design
        stale = atomic.temp_path(box.out / f"{NAME}.h5", int(_DEAD))
        stale.write_bytes(b"half")
        box.own.add(f"out/{stale.name}")
        return ["run", shared["config"], "--out", box.out, "-q",
                *(["--resume"] if phase == "resume" else [])]

    label = ", ".join(f"{p.kind}@{p.rel}" for p in plants)
    return Case(f"layout {phase}: {label}", prepare)


def layout_cases(n_random: int = 150, seed: int = 44) -> Iterator[Case]:
    """Every single plant in every phase it applies to, then ``n_random`` layouts of 2 to 4
    plants."""
    singles = [Plant("out", n, k) for n in OUT_NAMES for k in KINDS] + \
        [Plant("run", n, k) for n in RUN_NAMES for k in KINDS]

    def applies(phase: str, p: Plant) -> bool:
        if p.where == "run" and phase in ("run", "rerun"):
            return False  # no run folder: out/st.run plants cover it
        if p.where == "run" and p.name == "manifest.jsonl" and p.kind == "file":
            return False  # the run's own manifest, replaced by a user's file: not a layout
        if p.kind == "backup":
            return _exists_in(phase, _SHARED_NAMES, p)
        return True

    for phase in PHASES:
        for p in singles:
            if applies(phase, p):
                yield layout_case(phase, (p,))
    rng = random.Random(seed)
    while n_random > 0:
        phase = rng.choice(PHASES)
        pool = [p for p in singles if applies(phase, p)]
        picked = rng.sample(pool, rng.randint(2, 4))
        if len({p.rel for p in picked}) != len(picked) or any(
                p.where == "run" for p in picked) and any(
                p.rel == f"{NAME}.run" for p in picked):
            continue  # one plant per name; the run folder itself is not also a plant
        yield layout_case(phase, tuple(picked))
        n_random -= 1


#: What each starting state holds, by name (for which plants apply; no run needed).
_SHARED_NAMES: dict[str, Path] = {}


# ---------------------------------------------------------------------------- --out unusable
def _said(run: Run) -> list[str]:
    """The lines of a command's stderr but a replay's notice of the code it runs (issue 44,
    item 9: said before it runs, not an error line)."""
    return [ln for ln in run.stderr.strip().splitlines()
            if ln.strip() and not ln.startswith("replay runs ")]


def _one_error_line(run: Run) -> list[str]:
    """One ``error:`` line (or click's usage error, whose last line is its one ``Error:``)."""
    lines = _said(run)
    errors = [ln for ln in lines if ln.lower().startswith("error: ")]
    ours = len(lines) == 1 and errors == lines
    click = lines[:1] and lines[0].startswith("Usage: ") and errors == lines[-1:]
    return [] if ours or click else [f"not one error line: {lines[-3:]}"]


def unusable_out_cases() -> Iterator[Case]:
    """``--out`` (and the output of plot, report, baseline, replay) that cannot be used:
    exit 2 with one line, before any work."""
    kinds: dict[str, Callable[[Box], Path]] = {
        "dangling link": lambda b: _link(b.root / "o", b.root / "nowhere"),
        "link loop": lambda b: _link(b.root / "o", b.root / "o"),
        "under a file": lambda b: _file(b.root / "f") / "sub",
        "under a dangling link": lambda b: _link(b.root / "o", b.root / "nowhere") / "sub",
        "/dev/null": lambda b: Path("/dev/null"),
        "a FIFO": lambda b: _fifo(b.root / "o"),
        "read-only": lambda b: Path("/proc/uqguide-out"),
        "a file": lambda b: _file(b.root / "o"),
    }
    files = ("/dev/null", "a FIFO", "a file")  # kinds that baseline -o names itself
    commands: dict[str, Callable[[Box, Path, str], list[str | Path]]] = {
        "run": lambda b, o, k: ["run", b.shared["config"], "--out", o, "-q"],
        "plot": lambda b, o, k: ["plot", b.shared["done"] / f"{NAME}.h5", "--out", o],
        "report": lambda b, o, k: ["report", b.shared["done"] / f"{NAME}.h5", "--out", o],
        "replay": lambda b, o, k: ["replay", b.shared["done"] / f"{NAME}.h5", "--label", "mc",
                                   "--sample", "3", "--out", o, *_own_code(b)],
        "baseline": lambda b, o, k: ["baseline", b.shared["done"] / f"{NAME}.h5", "-o",
                                     o if k in files else o / "b.json", "--force"],
    }
    for cname, command in commands.items():
        for kname, make in kinds.items():
            if cname == "baseline" and kname == "a file":
                continue  # baseline -o FILE --force replaces it: asked for
            def prepare(box: Box, make: Callable = make, command: Callable = command,
                        kname: str = kname) -> list[str | Path]:
                return command(box, make(box), kname)

            yield Case(f"unusable out: {cname} --out {kname}", prepare, expect=(2,),
                       check=lambda box, run: _one_error_line(run))


def _own_code(box: Box) -> list[str | Path]:
    """A replay's leave to run the result's model: the user's own config of it (without it
    every replay stops at that question, exit 2, before the case's point)."""
    return ["--config", box.shared["config"]]


def _link(path: Path, target: Path) -> Path:
    path.symlink_to(target)
    return path


def _file(path: Path) -> Path:
    path.write_text("the user's\n")
    return path


def _fifo(path: Path) -> Path:
    os.mkfifo(path)
    return path


# ---------------------------------------------------------------------------- inputs as FIFOs
def fifo_input_cases() -> Iterator[Case]:
    """A FIFO (or socket) where a command reads its config, result or baseline: refused at
    once (exit 2), never a blocking open."""
    for kind in ("fifo", "socket"):
        def special(box: Box, name: str, kind: str = kind) -> Path:
            p = box.inputs / name
            if kind == "fifo":
                os.mkfifo(p)
            else:
                s = socket.socket(socket.AF_UNIX)
                s.bind(str(p))
                s.close()
            return p

        def tail(box: Box, cmd: str) -> list[str | Path]:
            return {"check": ["--baseline", box.shared["baseline"]],
                    "baseline": ["-o", box.out / "b.json"], "plot": ["--out", box.out],
                    "report": ["--out", box.out],
                    "replay": ["--label", "mc", "--sample", "3", "--out", box.out,
                               *_own_code(box)]}[cmd]

        yield Case(f"input {kind}: config", lambda b, s=special: [
            "run", s(b, "c.yaml"), "--out", b.out, "-q"], expect=(2,))
        for cmd in ("plot", "report", "check", "baseline", "replay"):
            yield Case(f"input {kind}: {cmd} RESULT", lambda b, s=special, c=cmd: [
                c, s(b, "r.h5"), *tail(b, c)], expect=(2,))
        yield Case(f"input {kind}: check --baseline", lambda b, s=special: [
            "check", b.shared["done"] / f"{NAME}.h5", "--baseline", s(b, "b.json")],
            expect=(2,))
        yield Case(f"input {kind}: run --check BASELINE", lambda b, s=special: [
            "run", b.shared["config"], "--out", b.out, "-q", "--check", s(b, "b.json")],
            expect=(2,))


# ---------------------------------------------------------------------------- a full disk
def _same_statistics(box: Box) -> list[str]:
    got = box.out / f"{NAME}_stats.csv"
    want = box.shared["done"] / f"{NAME}_stats.csv"
    if not got.is_file():
        return ["no statistics after --resume"]
    return [] if got.read_bytes() == want.read_bytes() else ["statistics differ after --resume"]


def _disk_full_then_resume(box: Box, run: Run) -> list[str]:
    problems = []
    lines = _said(run)
    if run.exit_code == 1:
        want = "error: disk full writing "
        if len(lines) != 1 or not lines[0].startswith(want) or \
                "the run folder is intact; free space and --resume" not in lines[0]:
            problems.append(f"not the disk-full line: {lines[-3:]}")
    again = run_in_process(["run", box.shared["config"], "--out", box.out, "-q", "--resume"],
                           {}, box.tmp)
    if again.exit_code != 0 or again.traceback:
        problems.append(f"--resume: exit {again.exit_code}: {again.stderr.strip()[-200:]}"
                        f"{again.error}")
    else:
        problems += _same_statistics(box)
    return problems


def _disk_full_other(box: Box, run: Run) -> list[str]:
    lines = _said(run)
    if run.exit_code == 1 and (len(lines) != 1 or not lines[0].startswith(
            "error: disk full writing ")):
        return [f"not the disk-full line: {lines[-3:]}"]
    return []


def disk_limits(shared: Mapping[str, Path]) -> list[int]:
    """Ten file-size limits, each stopping a fresh run at another moment: the lock, the
    manifest's header, the first chunk, the manifest's chunk lines, and the result file at
    four points of its writing (from the sizes of a finished run's files)."""
    header = len((shared["started"] / "manifest.jsonl").read_bytes())
    chunk = min(p.stat().st_size for p in shared["resume"].glob("*.npz"))
    lines = (shared["resume"] / "manifest.jsonl").read_bytes().splitlines(keepends=True)
    line = max(len(ln) for ln in lines[1:])
    h5 = (shared["done"] / f"{NAME}.h5").stat().st_size
    return sorted({0, 16, header // 2, chunk // 2, chunk + header + line // 2,
                   chunk + header + 2 * line + line // 2, h5 // 10, h5 // 3, (2 * h5) // 3,
                   h5 - 256})


def disk_full_cases(shared: Mapping[str, Path]) -> Iterator[Case]:
    """A full disk (``RLIMIT_FSIZE`` in a child process) at ten moments of a fresh run, at
    three of a resumed one and with two workers: exit 1 with the one line, then ``--resume``
    gives the statistics of an uninterrupted run; and in plot, report, baseline."""
    def fresh(box: Box) -> list[str | Path]:
        box.own.add("out/*")
        return ["run", box.shared["config"], "--out", box.out, "-q"]

    def resumed(box: Box) -> list[str | Path]:
        shutil.copytree(box.shared["resume"], box.out / f"{NAME}.run")
        box.own.update({"out/*", f"out/{NAME}.run/*"})
        return ["run", box.shared["config"], "--out", box.out, "-q", "--resume"]

    for limit in disk_limits(shared):
        yield Case(f"disk full: run, files over {limit} bytes", fresh, expect=(0, 1),
                   child=True, fsize=limit, check=_disk_full_then_resume)
    chunk = min(p.stat().st_size for p in shared["resume"].glob("*.npz"))
    lines = (shared["resume"] / "manifest.jsonl").read_bytes().splitlines(keepends=True)
    manifest = sum(map(len, lines))
    for limit in (16, chunk // 2, max(chunk, manifest) + max(map(len, lines[1:])) // 2):
        yield Case(f"disk full: --resume, files over {limit} bytes", resumed, expect=(0, 1),
                   child=True, fsize=limit, check=_disk_full_then_resume)
    yield Case("disk full: run --workers 2, files over 2000 bytes",
               lambda b: [*fresh(b), "--workers", "2"], expect=(0, 1), child=True,
               fsize=2000, check=_disk_full_then_resume)
    result = shared["done"] / f"{NAME}.h5"
    for cmd, limit in (("plot", 2000), ("report", 500), ("baseline", 100), ("replay", 1)):
        def other(box: Box, cmd: str = cmd) -> list[str | Path]:
            box.own.add("out/*")
            box.own.add("out/*/*")
            tail = {"plot": ["--out", box.out], "report": ["--out", box.out],
                    "baseline": ["-o", box.out / "b.json"],
                    "replay": ["--label", "mc", "--sample", "3", "--out", box.out,
                               *_own_code(box)]}[cmd]
            return [cmd, result, *tail]

        yield Case(f"disk full: {cmd}, files over {limit} bytes", other, expect=(1,),
                   child=True, fsize=limit, check=_disk_full_other)


# ---------------------------------------------------------------------------- all of it
def own_cases(shared: Mapping[str, Path]) -> Iterator[Case]:
    yield from layout_cases()
    yield from unusable_out_cases()
    yield from fifo_input_cases()
    yield from disk_full_cases(shared)


def all_cases(shared: Mapping[str, Path]) -> tuple[list[Case], list[str]]:
    """This module's cases and those of :data:`CASE_MODULES`; and the notes on modules."""
    cases = list(own_cases(shared))
    notes = []
    if str(ROOT / "benchmarks") not in sys.path:  # an importer may have taken it out again
        sys.path.insert(0, str(ROOT / "benchmarks"))
    for name in CASE_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:
            notes.append(f"{name}: not found ({exc}); skipped")
            continue
        found = [_as_case(c) for c in module.cases()]
        notes.append(f"{name}: {len(found)} cases")
        cases += found
    return cases, notes


def _as_case(obj: Any) -> Case:
    """A Case from a Case of another copy of this module, or an object or a dict with its
    attributes."""
    names = Case.__dataclass_fields__
    if isinstance(obj, dict):
        return Case(**{k: v for k, v in obj.items() if k in names})
    return Case(**{k: getattr(obj, k) for k in names if hasattr(obj, k)})


def run_all(sample: int | None = None, seed: int = 44, group: str | None = None
            ) -> list[Outcome]:
    """Every case (or ``sample`` of them at random, or those of groups containing
    ``group``), each in a fresh box."""
    _subreaper()
    with tempfile.TemporaryDirectory() as t:
        work = Path(t)
        shared = templates(work)
        _SHARED_NAMES.update(shared)
        cases, notes = all_cases(shared)
        for n in notes:
            print(n, file=sys.stderr)
        if group is not None:
            cases = [c for c in cases if group in c.group]
        if sample is not None:
            cases = random.Random(seed).sample(cases, min(sample, len(cases)))
        return [try_case(c, work, shared) for c in cases]


def summary_line(outcomes: Sequence[Outcome]) -> str:
    """The acceptance's line (issue 44)."""
    lost = sum(len(o.lost) for o in outcomes)
    outside = sum(len(o.outside) for o in outcomes)
    past = sum(o.past for o in outcomes)
    tbs = sum(o.run.traceback for o in outcomes)
    left = sum(o.left_behind for o in outcomes)
    over = [o for o in outcomes if o.over_memory]
    rss = "peak RSS under max_memory in every case" if not over else \
        f"peak RSS over max_memory in {len(over)} cases"
    return (f"{lost} user files lost or changed, {outside} writes outside --out, {past} runs "
            f"past {MAX_SECONDS:.0f} s, {tbs} tracebacks, {left} processes left behind, {rss}")


def main_(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--sample", type=int, default=None)
    ap.add_argument("--group", default=None)
    args = ap.parse_args(argv)
    t0 = time.monotonic()
    outcomes = run_all(args.sample, group=args.group)
    by = Counter((o.case.split(":", 1)[0], o.run.exit_code, o.ok) for o in outcomes)
    print("| group | exit | verdict | cases |\n|---|---|---|---|")
    for (g, code, ok), n in sorted(by.items(), key=lambda kv: (kv[0][0], str(kv[0][1]))):
        print(f"| {g} | {code} | {'ok' if ok else 'BAD'} | {n} |")
    bad = [o for o in outcomes if not o.ok]
    for o in bad[:60]:
        print(f"  BAD {o.case}: exit {o.run.exit_code}, {o.run.seconds:.1f} s, lost {o.lost}, "
              f"outside {o.outside}, left {o.left_behind}, tb {o.run.traceback}, "
              f"problems {o.problems}; {o.run.stderr.strip()[-300:]!r}")
    peak = max(outcomes, key=lambda o: o.run.peak_rss / o.max_memory, default=None)
    closest = "" if peak is None else (
        f"; the peak RSS closest to its case's max_memory {peak.run.peak_rss / 2**20:.0f} MiB "
        f"of {peak.max_memory / 2**20:.0f} MiB ({peak.case})")
    print(f"\n{len(outcomes)} cases in {time.monotonic() - t0:.0f} s{closest}; "
          f"{len(bad)} cases not clean, {sum(bool(o.problems) for o in outcomes)} with "
          f"another problem (exit code, message, --resume)")
    print(summary_line(outcomes))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main_())
