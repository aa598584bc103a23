"""The process groups of external programs this process is waiting for, so that whoever ends
this process can end them too.

A ``command`` model runs its program in a session of its own (``start_new_session``), so that
a timeout kills the program and every child it forked with one ``killpg``. The same isolation
hides the program from a kill aimed at its caller: a guard process killed on the run's
``timeout_s`` left the program (and its solver, its shell pipeline) running to the end, one
orphan per call of the bisection. The caller therefore registers each group while it waits,
and a process that is told to stop (SIGTERM, see :func:`stop_on_sigterm`) kills the groups it
waits for before it exits.
"""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

_running: set[int] = set()


def kill_group(pgid: int) -> None:
    """SIGKILL the process group ``pgid``; a group already gone is not an error."""
    try:
        os.killpg(pgid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        pass


@contextmanager
def tracked(pgid: int) -> Iterator[None]:
    """Register the group ``pgid`` while the caller waits for it."""
    _running.add(pgid)
    try:
        yield
    finally:
        _running.discard(pgid)


def kill_tracked() -> int:
    """Kill every registered group; returns how many there were."""
    groups = list(_running)
    for pgid in groups:
        kill_group(pgid)
    _running.clear()
    return len(groups)


def _on_sigterm(signum: int, frame: Any) -> None:
    kill_tracked()
    os._exit(128 + signum)


def stop_on_sigterm() -> None:
    """Make SIGTERM end this process at once, taking the registered program groups with it.

    For a process (a guard) whose caller ends it with SIGTERM and, if that goes unanswered
    (a model stuck in compiled code cannot run a Python handler), SIGKILL a moment later.
    """
    signal.signal(signal.SIGTERM, _on_sigterm)
