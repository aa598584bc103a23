"""Signals and lifetimes of the processes a run starts (pool workers, guard processes): they
ignore Ctrl-C, which the driver handles, and die with their parent."""

from __future__ import annotations

import multiprocessing
import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

#: Exit code of a child process whose model went over its memory limit (a MemoryError under
#: :func:`limit_memory`): the process is ended, not reused, since what leaked is still held.
OVER_MEMORY_EXIT = 75

#: Smallest per-process limit applied: Python, NumPy, numba and uqguide take about half a GB
#: of address space before any sample runs.
MIN_PROCESS_MEMORY = 1 << 30

_memory_limit: dict[str, int] = {}


def limit_memory(n_bytes: int | None) -> None:
    """Cap this child process's address space (``RLIMIT_AS``: what Linux can cap per process)
    at ``n_bytes`` (None: unchanged); an allocation over it ends the child with
    :data:`OVER_MEMORY_EXIT`, and its call is bisected like a crash."""
    if n_bytes is None or _memory_limit.get("bytes") == n_bytes:
        return
    try:
        import resource
    except ImportError:  # pragma: no cover - not on POSIX
        return
    limit = max(int(n_bytes), MIN_PROCESS_MEMORY)
    _, hard = resource.getrlimit(resource.RLIMIT_AS)
    if hard != resource.RLIM_INFINITY:
        limit = min(limit, hard)
    resource.setrlimit(resource.RLIMIT_AS, (limit, hard))
    _memory_limit["bytes"] = n_bytes


def memory_limited() -> bool:
    """Whether :func:`limit_memory` capped this process (a MemoryError then ends it)."""
    return "bytes" in _memory_limit


def die_with_parent(sig: int = signal.SIGKILL) -> None:
    """Make this process end by ``sig`` when its parent does (call first thing in a child)."""
    parent = os.getppid()
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            PR_SET_PDEATHSIG = 1
            libc.prctl(PR_SET_PDEATHSIG, int(sig), 0, 0, 0)
        except (OSError, AttributeError):  # pragma: no cover - no prctl
            pass
    if os.getppid() != parent:  # the parent died before prctl took effect
        os._exit(1)

    def watch() -> None:
        # Anywhere prctl is missing (or the parent was a thread that ended): a new parent
        # means the old one is gone.
        while True:
            time.sleep(1.0)
            if os.getppid() != parent:
                os.kill(os.getpid(), sig)  # as prctl would have: the same handler runs
                time.sleep(1.0)
                os._exit(1)

    threading.Thread(target=watch, name="uqguide-parent-watch", daemon=True).start()


def init_worker(threads: int, started: Any = None) -> None:
    """Worker start: ignore SIGINT, cap compiled kernels' ``threads`` at the worker's share of
    the cores (``NUMBA_NUM_THREADS``, unless set), and set ``started``: a pool that breaks
    before any worker set it died starting up, not on a sample."""
    # Ctrl-C on a terminal reaches the whole process group: the driver handles it (stops and
    # leaves a resumable run); workers must not die printing tracebacks.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent()  # a driver killed (out of memory) must not leave workers holding its pipes
    os.environ.setdefault("NUMBA_NUM_THREADS", str(threads))
    if started is not None:
        started.set()


#: Exit code of a worker that found itself asked to start a run while it was starting up.
NESTED_RUN_EXIT = 3

WORKERS_DID_NOT_START = (
    "the worker processes died while starting, before any sample ran. A worker process "
    "(workers=N; or a guard process: with timeout_s, and by default for a model function "
    "defined in the script itself, to contain its crashes) re-imports the script that started "
    "the run; "
    "if that script calls uqguide.run at its top level, put the call under "
    "`if __name__ == \"__main__\":`")


def refuse_nested_run() -> None:
    """End quietly a spawned worker still importing its parent's unguarded main script, which
    would start the whole run again: the parent then raises one WorkerStartError saying how to
    fix the script, where a traceback from every worker would bury that line."""
    # Python marks that phase with current_process()._inheriting, the flag its own "before the
    # current process has finished its bootstrapping phase" check reads.
    if getattr(multiprocessing.current_process(), "_inheriting", False):
        raise SystemExit(NESTED_RUN_EXIT)


@contextmanager
def sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while child processes are started, so they inherit the ignore from birth
    and a Ctrl-C during their start-up cannot kill them with a traceback."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
