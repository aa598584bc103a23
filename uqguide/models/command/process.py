"""Running a ``command`` model's program: its arguments from the template, one process (and
everything it starts) per call, all of it ended with the call.

The template is split with :func:`shlex.split` when the config is loaded; the placeholders are
filled in each argument afterwards, so a path with a space stays one argument and nothing the
run supplies is ever read by a shell. With ``shell: true`` the template goes to ``/bin/sh -c``
and each placeholder becomes a reference to an environment variable holding its value
(``{inputs}`` -> ``"${UQ_INPUTS}"``, quoted for where it stands, :func:`shell_script`): the
shell never reads a path as code, whatever the path holds and however the template quotes it.

The program runs in a new session (its own process group) inside a
:func:`~uqguide.core.process_groups.program_call`: the group, and any daemon that left it, is
killed when the call ends (timeout, exit, Ctrl-C). Its stdout and stderr go to ``stdout.txt``
and ``stderr.txt`` in the work folder, not to pipes, which a hung grandchild could hold open.
"""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from ...errors import ModelError
from ...core.process_groups import program_call, spawning

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
#: The environment variable that holds each placeholder's value in every call (``UQ_INPUTS``
#: for ``{inputs}``...): what a ``shell: true`` script refers to, and any program may read.
ENV_NAMES = {p: f"UQ_{p.upper()}" for p in PLACEHOLDERS}
#: A first word that is a path (``./mysim``, ``bin/mysim``, ``/opt/mysim``): the program of a
#: ``shell: true`` template, found as without a shell.
_PATH_WORD = re.compile(r"\s*([\w.+@%:,/-]*/[\w.+@%:,/-]*)(?=[\s;&|<>)]|$)")
#: A here-document's operator and delimiter: ``<<EOF``, ``<<-EOF``, ``<<'EOF'``, ``<<\EOF``.
_HEREDOC = re.compile(r"<<(-?)[ \t]*(?:'([^'\n]*)'|\"([^\"\n]*)\"|(\\?[^\s;&|<>()'\"]+))")


class CommandFailed(RuntimeError):
    """The program exited with a non-zero status or was killed: the call's samples are split
    and tried again (:func:`uqguide.driver.execution.evaluate_batch`) until the failing ones
    are alone."""


@dataclass(frozen=True)
class Deadline:
    """When a call must be over: ``timeout_s`` after it started, the reading of the program's
    outputs included (a program that exits in time but leaves more than can be read in time
    fails the same way as one that hangs)."""

    timeout_s: float
    at: float  # time.monotonic()

    @classmethod
    def start(cls, timeout_s: float | None) -> Deadline | None:
        """The deadline of a call starting now (None without ``timeout_s``)."""
        return None if timeout_s is None else cls(timeout_s, time.monotonic() + timeout_s)

    def left(self) -> float:
        """Seconds to the deadline (0 once past it)."""
        return max(0.0, self.at - time.monotonic())

    def check(self, doing: str) -> None:
        """Raise :class:`CommandFailed` when the deadline has passed while ``doing``."""
        if time.monotonic() > self.at:
            raise CommandFailed(f"the command's call did not finish within timeout_s = "
                                f"{self.timeout_s:g} s ({doing})")


def unknown_placeholders(template: str) -> list[str]:
    """The ``{name}`` placeholders of ``template`` that are not in :data:`PLACEHOLDERS`."""
    return [m for m in _PLACEHOLDER.findall(template) if m not in PLACEHOLDERS]


def shell_program(template: str) -> str | None:
    """The program of a ``shell: true`` template when its first word is a path (``./mysim``,
    ``/opt/mysim``): what is checked and resolved as without a shell; None otherwise (a
    command on ``PATH``, a builtin, a placeholder)."""
    m = _PATH_WORD.match(template)
    return m.group(1) if m else None


def shell_script(template: str) -> str:
    """The ``/bin/sh -c`` script of a ``shell: true`` template.

    Each placeholder becomes its environment variable (:data:`ENV_NAMES`): ``"${UQ_INPUTS}"``
    where it stands unquoted (one word, never split or globbed), ``${UQ_INPUTS}`` inside double
    quotes and in a here-document, and ``'"${UQ_INPUTS}"'`` inside single quotes (closed, the
    value, reopened). No value is spliced into the script, so a ``$(...)``, a backquote or a
    quote in a path is text. A relative first word (``./mysim``) is prefixed with the config's
    folder, as without a shell. ``template`` (the config's ``command``) has balanced quotes
    (checked when the config is loaded). ValueError for a placeholder in a here-document whose
    delimiter is quoted (``<<'EOF'``), where the shell expands nothing.
    """
    program = shell_program(template)
    if program is not None and not program.startswith("/"):
        template = "{config_dir}/" + template.lstrip()
    out: list[str] = []
    # contexts: U unquoted, D "...", P $(...), G (...), B `...` (P, G, B are unquoted inside)
    stack, i, n = ["U"], 0, len(template)
    heredocs: list[tuple[bool, str, bool]] = []  # (strip tabs, delimiter, quoted) to come
    while i < n:
        top, c = stack[-1], template[i]
        m = _PLACEHOLDER.match(template, i)
        if m and m.group(1) in ENV_NAMES:
            var = ENV_NAMES[m.group(1)]
            out.append(f"${{{var}}}" if top == "D" else f'"${{{var}}}"')
            i = m.end()
            continue
        h = _HEREDOC.match(template, i) if top != "D" else None
        step = len(h.group(0)) if h else 1
        if h:
            heredocs.append(_heredoc(h))
        elif c == "\\":
            step = 2
        elif c == "\n" and heredocs and top != "D":
            out.append(c)
            i = _heredoc_bodies(template, i + 1, heredocs, out)
            heredocs = []
            continue
        elif c == "'" and top != "D":
            end = template.find("'", i + 1)
            end = n - 1 if end < 0 else end
            out.append(_PLACEHOLDER.sub(
                lambda m: f"'\"${{{ENV_NAMES[m.group(1)]}}}\"'" if m.group(1) in ENV_NAMES
                else m.group(0), template[i:end + 1]))
            i = end + 1
            continue
        elif c == '"':
            stack.pop() if top == "D" else stack.append("D")
        elif template.startswith("$(", i):
            stack.append("P")
            step = 2
        elif c == "`":
            stack.pop() if top == "B" else stack.append("B")
        elif c == "(" and top != "D":
            stack.append("G")
        elif c == ")" and top in ("P", "G"):
            stack.pop()
        out.append(template[i:i + step])
        i += step
    return "".join(out)


def _heredoc(m: re.Match[str]) -> tuple[bool, str, bool]:
    """A matched here-document operator: (tabs stripped, delimiter, quoted)."""
    strip, single, double, word = m.groups()
    if word is None:
        return strip == "-", single if single is not None else double, True
    return strip == "-", word.lstrip("\\"), word.startswith("\\")


def _heredoc_bodies(template: str, i: int, heredocs: list[tuple[bool, str, bool]],
                    out: list[str]) -> int:
    """Copy the bodies of ``heredocs`` starting at ``template[i]`` to ``out``, each placeholder
    as ``${UQ_...}`` (expanded there, never read as code); returns where they end."""
    for strip, delimiter, quoted in heredocs:
        while i < len(template):
            end = template.find("\n", i)
            end = len(template) if end < 0 else end + 1
            line = template[i:end]
            i = end
            if (line.rstrip("\n").lstrip("\t") if strip else line.rstrip("\n")) == delimiter:
                out.append(line)
                break
            m = _PLACEHOLDER.search(line)
            if quoted and m and m.group(1) in ENV_NAMES:
                raise ValueError(f"placeholder {m.group(0)} in a here-document whose delimiter "
                                 f"is quoted ({delimiter!r}): the shell expands nothing there; "
                                 f"leave the delimiter unquoted")
            out.append(_PLACEHOLDER.sub(lambda m: f"${{{ENV_NAMES[m.group(1)]}}}" if m.group(1)
                                        in ENV_NAMES else m.group(0), line))
    return i


def argv(template: str, values: Mapping[str, str], shell: bool) -> list[str] | str:
    """The arguments of one call of the config's ``command`` with the placeholders' ``values``
    (each name of :data:`PLACEHOLDERS`; with ``shell``: the script of :func:`shell_script`,
    which reads them from the environment variables :data:`ENV_NAMES`)."""
    if shell:
        return shell_script(template)
    args = [_PLACEHOLDER.sub(lambda m: values.get(m.group(1), m.group(0)), token)
            for token in shlex.split(template)]
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
        deadline: Deadline | None) -> None:
    """Run one call of the program in ``workdir`` and wait for it; whatever it started is
    killed when it ends (:func:`~uqguide.core.process_groups.program_call`).

    ``args`` come from :func:`argv` (a str runs through ``/bin/sh -c``); ``workdir`` is its
    current folder and receives ``stdout.txt`` and ``stderr.txt``; ``env`` its whole
    environment; at the ``deadline`` its processes are killed. Raises CommandFailed (naming the
    work folder) on a non-zero exit status, a signal or the deadline, ModelError when the
    program cannot be started.
    """
    shell = isinstance(args, str)
    with open(workdir / "stdout.txt", "wb") as out, open(workdir / "stderr.txt", "wb") as err, \
            program_call() as call:
        try:
            with spawning():
                proc = subprocess.Popen(args, cwd=workdir, env=call.environment(dict(env)),
                                        shell=shell, stdin=subprocess.DEVNULL, stdout=out,
                                        stderr=err, start_new_session=True)
                call.started(proc.pid)
        except OSError as exc:
            program = args if shell else args[0]
            raise ModelError(f"cannot start the command's program {program!r}: "
                             f"{exc.strerror or exc}") from None
        try:
            code = proc.wait(timeout=None if deadline is None else deadline.left())
            call.exited()
        except subprocess.TimeoutExpired:
            call.end()
            proc.wait()
            assert deadline is not None
            raise CommandFailed(f"the command did not finish within timeout_s = "
                                f"{deadline.timeout_s:g} s "
                                f"(its process group was killed); work folder kept: "
                                f"{workdir}") from None
        except BaseException:
            call.end()  # Ctrl-C: leave no simulator behind
            proc.wait()
            raise
    if code != 0:
        how = (f"was killed by signal {signal.Signals(-code).name}" if code < 0 and
               -code in signal.Signals._value2member_map_ else f"exited with status {code}")
        raise CommandFailed(f"the command {how}; work folder kept: {workdir}"
                            f"{_stderr_tail(workdir)}")
