"""External programs this process runs, and everything they start, ended with their call.

A ``command`` model runs its program in a session of its own (``start_new_session``), so that
a timeout kills the program and every child it forked with one ``killpg``. Two things escape
that kill: a daemon that leaves the group (a double fork and ``setsid``), and the whole group
when the process waiting for it is killed. So each call is a :func:`program_call`: on Linux
this process is a child subreaper while calls run (orphans of the program are handed to it,
not to init, :mod:`.descendants`) and every process the call started is killed when it ends;
each call's program group is registered while it runs, and SIGTERM (:func:`stop_on_sigterm`,
and for the length of a call in any process that left SIGTERM at its default) kills them all
before the process exits. Derivation of what counts as the call's: ``docs/your-simulator.md``.
"""

from __future__ import annotations

import logging
import os
import secrets
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from typing import Any

from . import descendants

log = logging.getLogger(__name__)

#: The environment variable that marks a call's processes: its value is unique to the call,
#: and every process the program starts inherits it unless it clears its environment.
MARK = "UQ_CALL"
#: Seconds the processes a call left are given to die of SIGKILL and be reaped.
REAP_S = 5.0

_lock = threading.RLock()
#: Program process group -> its call, while the call runs.
_running: dict[int, ProgramCall] = {}
_adopting = {"calls": 0, "was_on": 0}
_warned = {"left": False}


def kill_group(pgid: int) -> None:
    """SIGKILL the process group ``pgid``; a group already gone is not an error."""
    with suppress(ProcessLookupError, PermissionError):
        os.killpg(pgid, signal.SIGKILL)


def _kill_subtree(pid: int) -> None:
    """SIGKILL ``pid`` and every process below it; one already gone is not an error."""
    for p in descendants.subtree(pid):
        with suppress(ProcessLookupError, PermissionError):
            os.kill(p, signal.SIGKILL)


class ProgramCall:
    """One call of an external program (made by :func:`program_call`)."""

    def __init__(self) -> None:
        self.mark = f"{os.getpid()}-{secrets.token_hex(8)}"
        self.pgid: int | None = None
        #: Processes killed at the call's end besides the program's group (found adopted).
        self.left = 0
        self._before: set[int] = set()
        self._exited = False
        self._ended = False

    def environment(self, env: dict[str, str]) -> dict[str, str]:
        """``env`` with the call's mark (:data:`MARK`) set."""
        return {**env, MARK: self.mark}

    def started(self, pid: int) -> None:
        """Register the program ``pid`` (the leader of its own process group)."""
        self.pgid = pid
        _running[pid] = self

    def exited(self) -> None:
        """The program has exited and been reaped: its pid is no longer its own."""
        self._exited = True

    def stop(self) -> None:
        """SIGKILL the program, its group and every process below it (a daemon still its
        child has left the group), and wait until it has died: its orphans are then this
        process's, for :func:`_kill_left` to find."""
        if self.pgid is None:
            return
        if not self._exited:  # unreaped: the pid still names the program
            _kill_subtree(self.pgid)
        kill_group(self.pgid)
        deadline = time.monotonic() + REAP_S
        while not self._exited and time.monotonic() < deadline:
            p = descendants.info(self.pgid)
            if p is None or p.state in "ZX":
                break
            time.sleep(1e-3)

    def end(self) -> None:
        """Stop the program (:meth:`stop`) and kill every process the call left, and reap
        those (the program itself is its ``Popen``'s to reap). Once; later calls do nothing."""
        if self._ended:
            return
        self._ended = True
        self.stop()
        self.left = _kill_left({self.mark}, self._before)
        if self.pgid is not None:
            _running.pop(self.pgid, None)


@contextmanager
def program_call() -> Iterator[ProgramCall]:
    """The lifetime of one program call: start it inside, with the call's environment, and
    hand its pid to :meth:`ProgramCall.started` (under :func:`spawning`); on leaving,
    whatever way, nothing it started runs any more."""
    call = ProgramCall()
    _adopt(True)
    restore = _handle_sigterm()
    try:
        call._before = set(descendants.children(os.getpid()))
        try:
            yield call
        finally:
            call.end()
    finally:
        restore()
        _adopt(False)
    if call.left and not _warned["left"]:
        _warned["left"] = True
        log.warning("a command's program left %d process(es) running after its call (a "
                    "daemon, a detached child): killed, as every process a call starts is "
                    "when the call ends", call.left)


@contextmanager
def spawning() -> Iterator[None]:
    """Hold while a program is started and registered: no call ending in another thread then
    takes the new process for one of its own leftovers."""
    with _lock:
        yield


def _adopt(on: bool) -> None:
    """Count calls in flight; this process is a child subreaper while there are any (unless
    it was one before, which is left as it was)."""
    with _lock:
        if on:
            if _adopting["calls"] == 0:
                _adopting["was_on"] = int(descendants.is_subreaper())
                if not _adopting["was_on"]:
                    descendants.set_subreaper(True)
            _adopting["calls"] += 1
            return
        _adopting["calls"] -= 1
        if _adopting["calls"] == 0 and not _adopting["was_on"]:
            descendants.set_subreaper(False)


def _left_roots(marks: set[str], before: set[int]) -> list[int]:
    """Children of this process that belong to the calls ``marks``: adopted, so in a session
    other than this process's (uqguide's own children share it), not the program of a call
    (its ``Popen`` reaps it), and carrying one of ``marks`` or no mark at all (a process that
    cleared its environment, or a zombie whose environment is gone)."""
    me = descendants.info(os.getpid())
    if me is None:
        return []
    programs = set(_running)
    roots = []
    for pid in descendants.children(me.pid):
        if pid in before or pid in programs:
            continue
        p = descendants.info(pid)
        if p is None or p.session == me.session:
            continue
        mark = descendants.environ_value(pid, MARK)
        if mark is None or mark in marks:
            roots.append(pid)
    return roots


def _kill_left(marks: set[str], before: set[int]) -> int:
    """SIGKILL what the calls ``marks`` left (each adopted process and all below it), reap
    them, and repeat until none is left: a killed process's children are adopted in turn.
    Returns how many adopted processes there were."""
    if not descendants.supported():
        return 0
    deadline = time.monotonic() + REAP_S
    n = 0
    while True:
        with _lock:
            roots = _left_roots(marks, before)
            for root in roots:
                _kill_subtree(root)
            for root in roots:
                _reap(root, deadline)
        if not roots:
            return n
        n += len(roots)
        if time.monotonic() > deadline:
            log.warning("processes left by a command's program did not die within %g s of "
                        "SIGKILL (uninterruptible I/O?): %s", REAP_S, roots)
            return n


def _reap(pid: int, deadline: float) -> None:
    pause = 1e-4
    while True:
        try:
            done, _ = os.waitpid(pid, os.WNOHANG)
        except ChildProcessError:
            return  # reaped already, or not a child
        if done or time.monotonic() > deadline:
            return
        time.sleep(pause)
        pause = min(2 * pause, 0.05)


def kill_tracked() -> int:
    """Kill the program of every call in flight, all below it and what those calls left;
    returns how many calls there were."""
    with _lock:
        calls = list(_running.values())
        for call in calls:
            call.stop()
        _kill_left({c.mark for c in calls}, set())
        _running.clear()
    return len(calls)


def _on_sigterm(signum: int, frame: Any) -> None:
    kill_tracked()
    os._exit(128 + signum)


def stop_on_sigterm() -> None:
    """Make SIGTERM end this process at once, taking the registered program groups with it.

    For a process (a guard) whose caller ends it with SIGTERM and, if that goes unanswered
    (a model stuck in compiled code cannot run a Python handler), SIGKILL a moment later.
    """
    signal.signal(signal.SIGTERM, _on_sigterm)


def _handle_sigterm() -> Any:
    """For the length of a call, make a SIGTERM that would end this process at once (its
    default: a pool worker ended by the driver's Ctrl-C) end the call's processes first.
    Only from the main thread, and never over a handler someone else installed."""
    if threading.current_thread() is not threading.main_thread():
        return lambda: None
    try:
        if signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL:
            return lambda: None
        signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:  # not the main interpreter
        return lambda: None
    return lambda: signal.signal(signal.SIGTERM, signal.SIG_DFL)
