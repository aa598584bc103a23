"""This process's descendants as Linux shows them in ``/proc``, and the kernel's "child
subreaper" switch that keeps them descendants when their parent dies.

A process whose parent exits is handed to the nearest ancestor that is a child subreaper
(``prctl(PR_SET_CHILD_SUBREAPER)``), else to init: with the switch on, a daemon that detaches
with a double fork and ``setsid`` stays in this process's tree, where it can be found and
killed. Everything here is a no-op returning nothing off Linux (``supported()`` says which).
"""

from __future__ import annotations

import ctypes
import functools
import os
import sys
from dataclasses import dataclass
from typing import Any

_PR_SET_CHILD_SUBREAPER = 36
_PR_GET_CHILD_SUBREAPER = 37


@functools.cache
def supported() -> bool:
    """Whether this system has ``/proc`` process files and the subreaper switch (Linux)."""
    return sys.platform.startswith("linux") and os.path.exists("/proc/self/stat")


@functools.cache
def _libc() -> Any:
    return ctypes.CDLL(None, use_errno=True)


def _prctl(option: int, arg: object) -> bool:
    try:
        return int(_libc().prctl(option, arg, 0, 0, 0)) == 0
    except (OSError, AttributeError):  # no libc prctl
        return False


def is_subreaper() -> bool:
    """Whether this process is a child subreaper now (False where that cannot be asked)."""
    if not supported():
        return False
    flag = ctypes.c_int(0)
    return _prctl(_PR_GET_CHILD_SUBREAPER, ctypes.pointer(flag)) and flag.value != 0


def set_subreaper(on: bool) -> bool:
    """Turn this process's child-subreaper attribute on or off; whether the kernel took it."""
    return supported() and _prctl(_PR_SET_CHILD_SUBREAPER, int(on))


def _read(path: str) -> bytes | None:
    try:
        with open(path, "rb", buffering=0) as f:
            return f.read()
    except OSError:
        return None


@dataclass(frozen=True)
class ProcInfo:
    """What ``/proc/<pid>/stat`` says of a process: its parent, session and state letter."""

    pid: int
    ppid: int
    session: int
    state: str


def info(pid: int) -> ProcInfo | None:
    """The process ``pid``'s :class:`ProcInfo`; None when it is gone (or off Linux)."""
    raw = _read(f"/proc/{pid}/stat")
    if raw is None:
        return None
    # "pid (comm) state ppid pgrp session ...": comm may hold spaces and parentheses
    fields = raw[raw.rfind(b")") + 2:].split()
    try:
        return ProcInfo(pid, int(fields[1]), int(fields[3]), fields[0].decode())
    except (IndexError, ValueError):
        return None


def children(pid: int) -> list[int]:
    """The processes whose parent is ``pid`` now (any of its threads).

    Read from ``/proc/<pid>/task/*/children``; a kernel without those files
    (``CONFIG_PROC_CHILDREN`` off) is answered by a scan of every process's parent.
    """
    try:
        tasks = os.listdir(f"/proc/{pid}/task")
    except OSError:
        return []
    out: list[int] = []
    for tid in tasks:
        raw = _read(f"/proc/{pid}/task/{tid}/children")
        if raw is None:
            if os.path.exists(f"/proc/{pid}/task/{tid}") and not _has_children_files():
                return _children_by_scan(pid)
            continue  # the thread ended
        out += [int(c) for c in raw.split()]
    return sorted(set(out))


@functools.cache
def _has_children_files() -> bool:
    return os.path.exists(f"/proc/self/task/{os.getpid()}/children")


def _children_by_scan(pid: int) -> list[int]:
    found = []
    for name in os.listdir("/proc"):
        if name.isdigit():
            p = info(int(name))
            if p is not None and p.ppid == pid:
                found.append(p.pid)
    return found


def subtree(pid: int) -> list[int]:
    """``pid`` and every process below it, parents before their children."""
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += children(p)
    return out


def environ_value(pid: int, name: str) -> str | None:
    """The value of the environment variable ``name`` the process ``pid`` was started with;
    None when it has none, or its environment cannot be read (another user's, a zombie)."""
    raw = _read(f"/proc/{pid}/environ")
    key = name.encode() + b"="
    for entry in (raw or b"").split(b"\0"):
        if entry.startswith(key):
            return entry[len(key):].decode(errors="replace")
    return None
