"""Running a ``command`` model's program: its arguments from the template, one process (and
its children) per call, killed as a group on timeout.

The template is split with :func:`shlex.split` when the config is loaded; the placeholders are
filled in each argument afterwards, so a path with a space stays one argument and nothing the
run supplies is ever read by a shell. With ``shell: true`` the template goes to ``/bin/sh -c``
and the placeholders are filled shell-quoted.

The program runs in a new session (its own process group): a timeout kills the whole group with
``os.killpg``, so a hung simulator's children (a solver it forked, a shell pipeline) die too.
Its stdout and stderr go to ``stdout.txt`` and ``stderr.txt`` in the work folder, not to
pipes, which a hung grandchild could hold open.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path

from ...errors import ModelError
from ...core.process_groups import kill_group, tracked

#: The placeholders a template may hold, and what each becomes.
PLACEHOLDERS = {
    "inputs": "the inputs file of the call",
    "input_file": "the same as {inputs} (the one-row file of a per-sample call)",
    "outputs": "the outputs file the program writes",
    "output_file": "the same as {outputs}",
    "workdir": "the call's fresh work folder (also the program's current folder)",
    "batch": "the name of the work folder, unique among the calls of a run",
    "config_dir": "the config file's folder (the current folder for a config from Python)",
}
_PLACEHOLDER = re.compile(r"\{(\w+)\}")


class CommandFailed(RuntimeError):
    """The program exited with a non-zero status or was killed: the call's samples are split
    and tried again (:func:`uqguide.driver.execution.evaluate_batch`) until the failing ones
    are alone."""


def unknown_placeholders(template: str) -> list[str]:
    """The ``{name}`` placeholders of ``template`` that are not in :data:`PLACEHOLDERS`.

    Parameters
    ----------
    template : str

    Returns
    -------
    list of str
    """
    return [m for m in _PLACEHOLDER.findall(template) if m not in PLACEHOLDERS]


def fill(template: str, values: Mapping[str, str], quote: bool = False) -> str:
    """``template`` with each known ``{name}`` replaced by ``values[name]``.

    Parameters
    ----------
    template : str
    values : mapping of str to str
        A value for every name of :data:`PLACEHOLDERS`.
    quote : bool
        Shell-quote the values (for ``shell: true``).

    Returns
    -------
    str
    """
    def sub(m: re.Match[str]) -> str:
        if m.group(1) not in values:
            return m.group(0)
        v = values[m.group(1)]
        return shlex.quote(v) if quote else v

    return _PLACEHOLDER.sub(sub, template)


def argv(template: str, values: Mapping[str, str], shell: bool) -> list[str] | str:
    """The arguments of one call (or the shell command line with ``shell``).

    Parameters
    ----------
    template : str
        The config's ``command``.
    values : mapping of str to str
        The placeholders' values.
    shell : bool

    Returns
    -------
    list of str or str
    """
    if shell:
        return fill(template, values, quote=True)
    args = [fill(token, values) for token in shlex.split(template)]
    program = args[0] = os.path.expanduser(args[0])  # no shell to expand ~ as users expect
    if "/" in program and not os.path.isabs(program):
        # the program runs in its work folder: a relative program path means the config's
        args[0] = os.path.join(values["config_dir"], program)
    return args


def _stderr_tail(workdir: Path) -> str:
    try:
        lines = (workdir / "stderr.txt").read_text(errors="replace").strip().splitlines()
    except OSError:
        return ""
    return f"; last line of stderr: {lines[-1][:200]!r}" if lines else ""


def run(args: Sequence[str] | str, workdir: Path, env: Mapping[str, str],
        timeout_s: float | None) -> None:
    """Run one call of the program in ``workdir`` and wait for it.

    Parameters
    ----------
    args : list of str, or str
        From :func:`argv` (a str runs through ``/bin/sh -c``).
    workdir : Path
        Its current folder; receives ``stdout.txt`` and ``stderr.txt``.
    env : mapping of str to str
        Its whole environment.
    timeout_s : float, optional
        Seconds before its process group is killed.

    Raises
    ------
    CommandFailed
        A non-zero exit status, a signal or the timeout; the message names the work folder.
    ModelError
        The program cannot be started (not found, not executable).
    """
    shell = isinstance(args, str)
    with open(workdir / "stdout.txt", "wb") as out, open(workdir / "stderr.txt", "wb") as err:
        try:
            proc = subprocess.Popen(args, cwd=workdir, env=dict(env), shell=shell,
                                    stdin=subprocess.DEVNULL, stdout=out, stderr=err,
                                    start_new_session=True)
        except OSError as exc:
            program = args if shell else args[0]
            raise ModelError(f"cannot start the command's program {program!r}: "
                             f"{exc.strerror or exc}") from None
        try:
            with tracked(proc.pid):  # a guard killed on the run's timeout_s kills it too
                code = proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            kill_group(proc.pid)
            proc.wait()
            raise CommandFailed(f"the command did not finish within timeout_s = {timeout_s:g} s "
                                f"(its process group was killed); work folder kept: "
                                f"{workdir}") from None
        except BaseException:
            kill_group(proc.pid)  # Ctrl-C: leave no simulator behind
            proc.wait()
            raise
        # children it left running in the background belong to this call and end with it
        kill_group(proc.pid)
    if code != 0:
        how = (f"was killed by signal {signal.Signals(-code).name}" if code < 0 and
               -code in signal.Signals._value2member_map_ else f"exited with status {code}")
        raise CommandFailed(f"the command {how}; work folder kept: {workdir}"
                            f"{_stderr_tail(workdir)}")
