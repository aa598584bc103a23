"""Hostile ``command`` programs, cases of benchmarks/fuzz_containment.py: each layout a real
``uqguide run`` in a child process, judged there (traceback, past 60 s, processes left, files
outside ``--out``) and here (a command injected through a path, a daemon's pid file alive;
peak RSS against a normal run's plus :data:`RSS_SLACK`).

A layout is a program and a model config: outputs left as a FIFO, a device or a folder; a
daemon detached with ``setsid`` (after a normal exit, past the model's and the run's
``timeout_s``, with its environment cleared, in a pool worker); placeholders quoted every way
with ``shell: true`` in a work folder named ``$(touch PWNED)...``; outputs far larger than the
batch (extra rows, one endless line, a sparse file, an HDF5 file claiming terabytes); a
repeated column; a line of thousands of cells.

    python benchmarks/containment_command.py        # = fuzz_containment.py --group command
"""

from __future__ import annotations

import contextlib
import functools
import os
import signal
import sys
import tempfile
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml
from fuzz_containment import MAX_MEMORY, ROOT, Box, Case, Run, try_case
from fuzz_containment import main_ as fuzz_main

#: Bytes of peak memory a case may take beyond a normal run's: reading at most a first line
#: (1 MiB) and a batch's rows (a few kB here), with room for the allocator's noise.
RSS_SLACK = 64 * 2**20

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
class Layout:
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


def layouts() -> Iterator[Layout]:
    """Every hostile layout."""
    pids = "{pids}"
    for kind, make in (("fifo", 'mkfifo "$UQ_OUTPUTS"'),
                       ("device", 'ln -s /dev/zero "$UQ_OUTPUTS"'),
                       ("folder", 'mkdir "$UQ_OUTPUTS"')):
        yield Layout(f"outputs: a {kind}", make)
        yield Layout(f"outputs: a {kind} for negative samples",
                   f"{NEGATIVE} && {make} || {{ {WRITE_Y}; }}")
        yield Layout(f"outputs: a {kind}, hdf5", make, model={"output_format": "hdf5"})
    yield Layout("daemon: setsid, exits", f"{_daemon(Path(pids))}\n{WRITE_Y}")
    yield Layout("daemon: setsid, environment cleared", f"{_daemon(Path(pids), True)}\n{WRITE_Y}")
    yield Layout("daemon: double fork in the group", f"( sleep 300 & ) ; {WRITE_Y}")
    hang = f"{_daemon(Path(pids))}\n{_daemon(Path(pids), True)}\n{NEGATIVE} && sleep 300\n"
    yield Layout("daemon: hangs past the model's timeout_s", hang + WRITE_Y,
               model={"timeout_s": 1.0})
    yield Layout("daemon: hangs past the run's timeout_s", hang + WRITE_Y,
               config={"timeout_s": 1.0})
    yield Layout("daemon: in a pool worker", f"{_daemon(Path(pids))}\n{WRITE_Y}",
               args=("--workers", "2"), n=8)
    payload = "w$(touch PWNED)`touch PWNED2`\"'; touch PWNED3 #"
    for quoting in ("{x}", '"{x}"', "'{x}'", '"$(echo {x})"', '"`echo {x}`"'):
        # the paths arrive whole: the inputs file and the work folder are found
        command = (f"test -f {quoting.format(x='{inputs}')} && "
                   f"test -d {quoting.format(x='{workdir}')} && {_write_y_shell}")
        yield Layout(f"shell: {quoting.format(x='{inputs}')} in {payload!r}", command,
                   model={"shell": True, "command": command}, workdir=payload)
    nested = f"sh -c 'test -r \"$UQ_INPUTS\"' && {_write_y_shell}"
    yield Layout("shell: a nested sh -c reading $UQ_INPUTS", nested,
               model={"shell": True, "command": nested}, workdir=payload)
    for mb in (64, 300):
        yield Layout(f"oversized: {mb} MB of extra rows",
                   f"{WRITE_Y}\nhead -c {mb}M /dev/zero | tr '\\0' '\\n' >> \"$UQ_OUTPUTS\"",
                   n=2, batch=1)
    yield Layout("oversized: one endless line", f"{WRITE_Y}\nhead -c 64M /dev/zero | tr '\\0' 1 "
               f">> \"$UQ_OUTPUTS\"", n=2, batch=1)
    yield Layout("oversized: a sparse 1 TB file", f"{WRITE_Y}\ntruncate -s 1T \"$UQ_OUTPUTS\"")
    yield Layout("oversized: a line of 100000 cells", f"{WRITE_Y}\nhead -c 100000 /dev/zero | tr "
               f"'\\0' , >> \"$UQ_OUTPUTS\"")
    yield Layout("oversized: a series grid of 2 million points",
               f"{WRITE_Y}\n{{ head -c 2000000 /dev/zero | tr '\\0' 1 | sed 's/1/0,/g'; echo 1; "
               f"}} > \"${{UQ_OUTPUTS%.csv}}_p.csv\"",
               model={"outputs": ["y", {"name": "p", "kind": "series"}]})
    h5 = ("import h5py, sys\nf = h5py.File(sys.argv[1], 'w')\n"
          "f.create_dataset('y', shape=(2**40,), chunks=(2**16,), dtype='f8')\n"
          "f.create_dataset('time', shape=(2**40,), chunks=(2**16,), dtype='f8')\n")
    yield Layout("oversized: hdf5 claiming terabytes",
               f"{sys.executable} -c \"{h5}\" \"$UQ_OUTPUTS\"", model={"output_format": "hdf5"})
    yield Layout("columns: y twice", 'tail -n +2 "$UQ_INPUTS" | sed "s/.*/1,2/" | '
               '{ echo y,y; cat; } > "$UQ_OUTPUTS"', exits=(1,))


# ---------------------------------------------------------------------------- as fuzz cases
def _config(layout: Layout, box: Box) -> dict[str, Any]:
    prog = box.inputs / "prog.sh"
    prog.write_text("#!/bin/sh\n" + PREAMBLE + layout.script.replace("{pids}", str(_pids(box)))
                    + "\n")
    prog.chmod(0o755)
    command = layout.model.get("command", f"{prog} {{inputs}} {{outputs}}")
    return {"model": {"name": "command", "command": command, "inputs": ["a"], "outputs": ["y"],
                      "workdir": str(box.root / layout.workdir),
                      **{k: v for k, v in layout.model.items() if k != "command"}},
            "inputs": [{"name": "a", "dist": "normal", "mean": 0.0, "std": 1.0}],
            "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": layout.n}],
            "batch_size": layout.batch, "max_failed_fraction": 1.0, "seed": 1, **layout.config}


def _pids(box: Box) -> Path:
    return box.root / "pids"


def _prepare(layout: Layout) -> Callable[[Box], list[str | Path]]:
    def prepare(box: Box) -> list[str | Path]:
        _pids(box).mkdir()
        (box.outside / "victim.txt").write_text("outside, untouched\n")
        cfg = box.inputs / "case.yaml"
        cfg.write_text(yaml.safe_dump(_config(layout, box)))
        # the model's workdir (failed calls keep their folders) and the daemons' pid files
        box.own.update({layout.workdir, f"{layout.workdir}/*", "pids/*"})
        return ["run", cfg, "--out", box.out, "-q", *layout.args]
    return prepare


def _check(box: Box, run: Run) -> list[str]:
    """A daemon whose pid file names a live process (one that escaped the subreaper and the
    token: ended here), and a command injected through a path (``PWNED*`` anywhere)."""
    alive = [int(p.name) for p in _pids(box).iterdir() if p.name.isdigit() and
             _alive(int(p.name))]
    for pid in alive:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)
    problems = [f"{len(alive)} daemon(s) alive"] if alive else []
    injected = [str(p) for top in (box.root, ROOT) for p in top.glob("**/PWNED*")]
    return problems + ([f"injected: {injected}"] if injected else [])


def _alive(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_bytes().rsplit(b")", 1)[1].split()[0] not in (
            b"Z", b"X")
    except OSError:
        return False


def _case(layout: Layout, max_memory: int) -> Case:
    return Case(f"command {layout.name}", _prepare(layout), expect=layout.exits, child=True,
                max_memory=max_memory, check=_check)


@functools.cache
def normal_rss() -> int:
    """Peak RSS of a normal run of the same shape [bytes]."""
    with tempfile.TemporaryDirectory() as t:
        o = try_case(_case(Layout("normal", WRITE_Y), MAX_MEMORY), Path(t), {})
    assert o.ok and o.run.exit_code == 0, (o.problems, o.run.stderr)
    return o.run.peak_rss


def cases() -> Iterator[Case]:
    """Every layout as a case of fuzz_containment, its peak RSS bounded by a normal run's +
    :data:`RSS_SLACK` (Linux only: a daemon's pid file is checked through /proc)."""
    if not sys.platform.startswith("linux"):
        return
    bound = normal_rss() + RSS_SLACK
    for layout in layouts():
        yield _case(layout, bound)


def main(argv: list[str] | None = None) -> int:
    """fuzz_containment's campaign, the command cases only."""
    return fuzz_main(["--group", "command", *(sys.argv[1:] if argv is None else argv)])


if __name__ == "__main__":
    sys.exit(main())
