"""Containment of hostile ``command`` programs: each layout a real ``uqguide run`` in a process
of its own, checked for a traceback, a run past 60 s, a process left behind, peak memory, and
a file outside ``--out`` (or a command injected through a path) touched.

A layout is a program and a model config: outputs left as a FIFO, a device or a folder; a
daemon detached with ``setsid`` (after a normal exit, past the model's and the run's
``timeout_s``, with its environment cleared, in a pool worker); placeholders quoted every way
with ``shell: true`` in a work folder named ``$(touch PWNED)...``; outputs far larger than the
batch (extra rows, one endless line, a sparse file, an HDF5 file claiming terabytes); a
repeated column; a line of thousands of cells. :func:`cases` yields them, :func:`run_case`
runs one in a sandbox and says what went wrong (:attr:`Outcome.problems`, empty when none).

The sandbox: ``out/`` (the ``--out``), ``work/`` (the model's ``workdir``, where failed calls
keep their folders), ``outside/`` (files that must stay as they are) and the config. The run
carries a token in its environment: a process holding it after the run was left behind (so
is any daemon whose pid file, written in ``pids/``, names a live process). Peak memory is the
run process's (``wait4``), against a normal run's plus :data:`RSS_SLACK`.

Usage::

    python benchmarks/containment_command.py            # every case, prints the table
    python benchmarks/containment_command.py -k daemon  # the cases whose name holds "daemon"
"""

from __future__ import annotations

import argparse
import os
import secrets
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]

#: Seconds a case may take (the acceptance's bound on any run).
LIMIT_S = 60.0
#: Bytes of peak memory a case may take beyond a normal run's: reading at most a first line
#: (1 MiB) and a batch's rows (a few kB here), with room for the allocator's noise.
RSS_SLACK = 64 * 2**20
#: Seconds the processes of a run may take to end after it (a kill's delivery, a fork
#: server's exit once its parent's pipe closes).
GRACE_S = 3.0
#: The environment variable that marks every process a case's run starts.
TOKEN = "CONTAINMENT_CASE"

#: y = 1 for each sample of the call (POSIX sh, coreutils).
WRITE_Y = 'tail -n +2 "$UQ_INPUTS" | sed "s/.*/1.0/" | { echo y; cat; } > "$UQ_OUTPUTS"'
#: The program's first lines: the files from its arguments when uqguide does not set them.
PREAMBLE = 'UQ_INPUTS="${UQ_INPUTS:-$1}"; UQ_OUTPUTS="${UQ_OUTPUTS:-$2}"\n'
#: True when the call holds a negative sample (about half the calls of one sample).
NEGATIVE = "tail -n +2 \"$UQ_INPUTS\" | grep -q '^-'"


def _daemon(pids: Path, env_clear: bool = False) -> str:
    """Lines starting a daemon in a session of its own that writes its pid to ``pids/`` (the
    program waits until it has)."""
    prefix = f"env -i P='{pids}' " if env_clear else f"P='{pids}' "
    return (f"{prefix}setsid sh -c 'echo $$ > \"$P/$$\"; touch \"$P/up-$PPID\"; "
            f"exec sleep 300' </dev/null >/dev/null 2>&1 &\n"
            f"until ls \"{pids}\"/up-* >/dev/null 2>&1; do sleep 0.01; done; "
            f"rm -f \"{pids}\"/up-*")


@dataclass(frozen=True)
class Case:
    """One hostile layout: the program's script (``{pids}`` is the pid folder), the model's
    other settings, the config's and the command line's."""

    name: str
    script: str
    model: dict[str, Any] = field(default_factory=dict)
    config: dict[str, Any] = field(default_factory=dict)
    args: tuple[str, ...] = ()
    #: The model's workdir, inside the sandbox (a name holding code, for the injections).
    workdir: str = "work"
    n: int = 4
    batch: int = 2
    #: Exit codes the run may end with (a malformed file must stop it: 1).
    exits: tuple[int, ...] = (0, 1, 2)


#: WRITE_Y in a ``shell: true`` template, from the placeholders.
_write_y_shell = WRITE_Y.replace('"$UQ_INPUTS"', "{inputs}").replace('"$UQ_OUTPUTS"',
                                                                      "{outputs}")


def cases() -> Iterator[Case]:
    """Every hostile layout."""
    pids = "{pids}"
    for kind, make in (("fifo", 'mkfifo "$UQ_OUTPUTS"'),
                       ("device", 'ln -s /dev/zero "$UQ_OUTPUTS"'),
                       ("folder", 'mkdir "$UQ_OUTPUTS"')):
        yield Case(f"outputs: a {kind}", make)
        yield Case(f"outputs: a {kind} for negative samples",
                   f"{NEGATIVE} && {make} || {{ {WRITE_Y}; }}")
        yield Case(f"outputs: a {kind}, hdf5", make, model={"output_format": "hdf5"})
    yield Case("daemon: setsid, exits", f"{_daemon(Path(pids))}\n{WRITE_Y}")
    yield Case("daemon: setsid, environment cleared", f"{_daemon(Path(pids), True)}\n{WRITE_Y}")
    yield Case("daemon: double fork in the group", f"( sleep 300 & ) ; {WRITE_Y}")
    hang = f"{_daemon(Path(pids))}\n{_daemon(Path(pids), True)}\n{NEGATIVE} && sleep 300\n"
    yield Case("daemon: hangs past the model's timeout_s", hang + WRITE_Y,
               model={"timeout_s": 1.0})
    yield Case("daemon: hangs past the run's timeout_s", hang + WRITE_Y,
               config={"timeout_s": 1.0})
    yield Case("daemon: in a pool worker", f"{_daemon(Path(pids))}\n{WRITE_Y}",
               args=("--workers", "2"), n=8)
    payload = "w$(touch PWNED)`touch PWNED2`\"'; touch PWNED3 #"
    for quoting in ("{x}", '"{x}"', "'{x}'", '"$(echo {x})"', '"`echo {x}`"'):
        # the paths arrive whole: the inputs file and the work folder are found
        command = (f"test -f {quoting.format(x='{inputs}')} && "
                   f"test -d {quoting.format(x='{workdir}')} && {_write_y_shell}")
        yield Case(f"shell: {quoting.format(x='{inputs}')} in {payload!r}", command,
                   model={"shell": True, "command": command}, workdir=payload)
    nested = f"sh -c 'test -r \"$UQ_INPUTS\"' && {_write_y_shell}"
    yield Case("shell: a nested sh -c reading $UQ_INPUTS", nested,
               model={"shell": True, "command": nested}, workdir=payload)
    for mb in (64, 300):
        yield Case(f"oversized: {mb} MB of extra rows",
                   f"{WRITE_Y}\nhead -c {mb}M /dev/zero | tr '\\0' '\\n' >> \"$UQ_OUTPUTS\"",
                   n=2, batch=1)
    yield Case("oversized: one endless line", f"{WRITE_Y}\nhead -c 64M /dev/zero | tr '\\0' 1 "
               f">> \"$UQ_OUTPUTS\"", n=2, batch=1)
    yield Case("oversized: a sparse 1 TB file", f"{WRITE_Y}\ntruncate -s 1T \"$UQ_OUTPUTS\"")
    yield Case("oversized: a line of 100000 cells", f"{WRITE_Y}\nhead -c 100000 /dev/zero | tr "
               f"'\\0' , >> \"$UQ_OUTPUTS\"")
    yield Case("oversized: a series grid of 2 million points",
               f"{WRITE_Y}\n{{ head -c 2000000 /dev/zero | tr '\\0' 1 | sed 's/1/0,/g'; echo 1; "
               f"}} > \"${{UQ_OUTPUTS%.csv}}_p.csv\"",
               model={"outputs": ["y", {"name": "p", "kind": "series"}]})
    h5 = ("import h5py, sys\nf = h5py.File(sys.argv[1], 'w')\n"
          "f.create_dataset('y', shape=(2**40,), chunks=(2**16,), dtype='f8')\n"
          "f.create_dataset('time', shape=(2**40,), chunks=(2**16,), dtype='f8')\n")
    yield Case("oversized: hdf5 claiming terabytes",
               f"{sys.executable} -c \"{h5}\" \"$UQ_OUTPUTS\"", model={"output_format": "hdf5"})
    yield Case("columns: y twice", 'tail -n +2 "$UQ_INPUTS" | sed "s/.*/1,2/" | '
               '{ echo y,y; cat; } > "$UQ_OUTPUTS"', exits=(1,))


@dataclass
class Outcome:
    """What a case's run did, and the checks it failed (:attr:`problems`)."""

    case: Case
    exit_code: int
    seconds: float
    peak_rss: int
    left: list[int]
    touched: list[str]
    traceback: bool
    stderr: str
    problems: list[str] = field(default_factory=list)


def _config(case: Case, box: Path) -> dict[str, Any]:
    prog = box / "prog.sh"
    prog.write_text("#!/bin/sh\n" + PREAMBLE + case.script.replace("{pids}", str(box / "pids"))
                    + "\n")
    prog.chmod(0o755)
    command = case.model.get("command", f"{prog} {{inputs}} {{outputs}}")
    return {"model": {"name": "command", "command": command, "inputs": ["a"], "outputs": ["y"],
                      "workdir": str(box / case.workdir),
                      **{k: v for k, v in case.model.items() if k != "command"}},
            "inputs": [{"name": "a", "dist": "normal", "mean": 0.0, "std": 1.0}],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": case.n}],
            "batch_size": case.batch, "max_failed_fraction": 1.0, "seed": 1, **case.config}


def _snapshot(top: Path) -> dict[str, tuple]:
    out = {}
    for p in sorted(top.rglob("*")):
        st = p.lstat()
        out[str(p.relative_to(top))] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return out


def _marked(token: str) -> list[int]:
    """Live processes whose environment holds ``TOKEN=token``."""
    key = f"{TOKEN}={token}".encode()
    found = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            env = Path(f"/proc/{name}/environ").read_bytes().split(b"\0")
            state = Path(f"/proc/{name}/stat").read_bytes().rsplit(b")", 1)[1].split()[0]
        except OSError:
            continue
        if key in env and state not in (b"Z", b"X"):
            found.append(int(name))
    return found


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_bytes().rsplit(b")", 1)[1].split()[0] not in (
            b"Z", b"X")
    except OSError:
        return False


def _left(token: str, pids: Path) -> list[int]:
    """The case's processes still running once :data:`GRACE_S` has passed (multiprocessing's
    fork server and resource tracker end a moment after the run that started them)."""
    deadline = time.monotonic() + GRACE_S
    while True:
        left = set(_marked(token)) | {int(p.name) for p in pids.iterdir()
                                      if p.name.isdigit() and _alive(int(p.name))}
        if not left or time.monotonic() > deadline:
            return sorted(left)
        time.sleep(0.05)


def _run(cfg: Path, out: Path, args: tuple[str, ...], token: str
         ) -> tuple[int, float, int, str]:
    """``uqguide run`` as a process of its own: exit code, seconds, peak RSS, stderr."""
    env = {**os.environ, TOKEN: token, "PYTHONPATH": str(ROOT)}
    err = out.parent / "stderr.txt"
    start = time.monotonic()
    with err.open("w") as f:
        proc = subprocess.Popen([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                                 str(out), "-q", *args], env=env, stdout=subprocess.DEVNULL,
                                stderr=f, start_new_session=True)
        deadline = start + 2 * LIMIT_S
        while True:
            pid, status, usage = os.wait4(proc.pid, os.WNOHANG)
            if pid:
                break
            if time.monotonic() > deadline:  # a hang: end it, and say so below
                os.killpg(proc.pid, signal.SIGKILL)
                pid, status, usage = os.wait4(proc.pid, 0)
                break
            time.sleep(0.02)
    proc.returncode = os.waitstatus_to_exitcode(status)  # reaped here, not by Popen
    return (proc.returncode, time.monotonic() - start, usage.ru_maxrss * 1024,
            err.read_text(errors="replace"))


def run_case(case: Case, folder: Path, normal_rss: int | None = None) -> Outcome:
    """Run ``case`` in a fresh sandbox under ``folder`` and check it.

    Parameters
    ----------
    case : Case
    folder : Path
        Where the sandbox is made (and removed again).
    normal_rss : int, optional
        Peak RSS of a normal run [bytes] (:func:`baseline_rss`); without it memory is not
        checked.

    Returns
    -------
    Outcome
    """
    box = folder / "box"
    if box.exists():
        shutil.rmtree(box)
    for sub in ("out", "pids", "outside"):
        (box / sub).mkdir(parents=True)
    (box / "outside" / "victim.txt").write_text("outside, untouched\n")
    cfg = box / "case.yaml"
    cfg.write_text(yaml.safe_dump(_config(case, box)))
    before = _snapshot(box / "outside")
    token = secrets.token_hex(8)
    code, seconds, rss, stderr = _run(cfg, box / "out", case.args, token)
    left = _left(token, box / "pids")
    for pid in left:  # the benchmark's own hygiene: what the run left, it ends
        try:
            os.kill(pid, signal.SIGKILL)
        except OSError:
            pass
    after = _snapshot(box / "outside")
    touched = sorted(k for k in set(before) | set(after) if before.get(k) != after.get(k))
    touched += [str(p.relative_to(box)) for p in box.rglob("PWNED*")]
    touched += [str(p) for p in (Path.cwd().glob("PWNED*"))]
    o = Outcome(case, code, seconds, rss, left, touched, "Traceback" in stderr, stderr)
    if o.traceback or code not in case.exits:
        o.problems.append(f"exit {code}{', traceback' if o.traceback else ''}")
    if seconds > LIMIT_S:
        o.problems.append(f"{seconds:.0f} s")
    if left:
        o.problems.append(f"{len(left)} process(es) left")
    if touched:
        o.problems.append(f"touched {touched}")
    if normal_rss is not None and rss > normal_rss + RSS_SLACK:
        o.problems.append(f"peak RSS {rss / 2**20:.0f} MiB")
    shutil.rmtree(box, ignore_errors=True)
    return o


def baseline_rss(folder: Path) -> int:
    """Peak RSS of a normal run of the same shape [bytes]."""
    o = run_case(Case("normal", WRITE_Y), folder)
    assert not o.problems and o.exit_code == 0, (o.problems, o.stderr)
    return o.peak_rss


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-k", default="", help="only the cases whose name holds this text")
    args = ap.parse_args(argv)
    if not sys.platform.startswith("linux"):
        print("Linux only: a left process is found through /proc")
        return 0
    chosen = [c for c in cases() if args.k in c.name]
    with tempfile.TemporaryDirectory() as t:
        normal = baseline_rss(Path(t))
        outcomes = [run_case(c, Path(t), normal) for c in chosen]
    print(f"normal run: peak RSS {normal / 2**20:.0f} MiB\n")
    print("| case | exit | s | peak RSS MiB | verdict |\n|---|---|---|---|---|")
    for o in outcomes:
        print(f"| {o.case.name} | {o.exit_code} | {o.seconds:.1f} | {o.peak_rss / 2**20:.0f} | "
              f"{'; '.join(o.problems) or 'ok'} |")
    print(f"\n{len(outcomes)} cases: {sum(bool(o.touched) for o in outcomes)} touching files "
          f"outside --out, {sum(o.seconds > LIMIT_S for o in outcomes)} past {LIMIT_S:g} s, "
          f"{sum(o.traceback for o in outcomes)} tracebacks, "
          f"{sum(len(o.left) for o in outcomes)} processes left behind, "
          f"{sum(o.peak_rss > normal + RSS_SLACK for o in outcomes)} over the peak RSS of a "
          f"normal run + {RSS_SLACK / 2**20:.0f} MiB")
    return 1 if any(o.problems for o in outcomes) else 0


if __name__ == "__main__":
    sys.exit(main())
