"""Signals and lifetimes of the processes a run starts (pool workers, guard processes): they
ignore Ctrl-C, which the driver handles, and die with their parent."""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

def die_with_parent() -> None:
    """Make this process end when its parent does (call first thing in a child process)."""
    parent = os.getppid()
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            PR_SET_PDEATHSIG = 1
            libc.prctl(PR_SET_PDEATHSIG, signal.SIGKILL, 0, 0, 0)
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
                os._exit(1)

    threading.Thread(target=watch, name="uqguide-parent-watch", daemon=True).start()


def ignore_sigint() -> None:
    # Ctrl-C on a terminal reaches the whole process group: the driver handles it (stops and
    # leaves a resumable run); workers must not die printing tracebacks.
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def init_worker(threads: int) -> None:
    """Worker start: ignore SIGINT and cap compiled kernels' threads at the worker's share of
    the cores (N workers each running an all-core numba kernel would oversubscribe the machine).
    Numba reads the variable when first imported, which in a spawned worker is after this.

    Parameters
    ----------
    threads : int
        Threads a compiled kernel may use in this worker (``NUMBA_NUM_THREADS``, unless set).
    """
    ignore_sigint()
    die_with_parent()  # a driver killed (out of memory) must not leave workers holding its pipes
    os.environ.setdefault("NUMBA_NUM_THREADS", str(threads))


@contextmanager
def sigint_ignored() -> Iterator[None]:
    """Ignore SIGINT while worker processes are started, so they inherit the ignore from birth
    (Python keeps an inherited SIG_IGN) and a Ctrl-C during their start-up cannot kill them
    with a traceback."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
