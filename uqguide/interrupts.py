"""Ctrl-C and SIGTERM: one way to stop, at any moment, with exit code 130.

:func:`install` makes SIGINT and SIGTERM raise :class:`KeyboardInterrupt` in the main thread
(SIGTERM as its subclass :class:`Terminated`), so a run stopped either way leaves the same
resumable state and the command line exits 130 without a traceback. Inside :func:`deferred`
(the writing of the result files) a signal is remembered instead and raised when the block
ends: a file is then written whole, never abandoned half-way by an exception raised inside a
C library (HDF5), which may swallow it.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

#: Exit code of a run stopped by SIGINT or SIGTERM (128 + SIGINT, as shells report Ctrl-C).
EXIT_INTERRUPTED = 130


class Terminated(KeyboardInterrupt):
    """SIGTERM, delivered like Ctrl-C."""


_state = {"depth": 0, "pending": None}


def _handler(signum: int, frame: FrameType | None) -> None:
    if _state["depth"] > 0:
        _state["pending"] = signum
        return
    _raise(signum)


def _raise(signum: int) -> None:
    if signum == signal.SIGTERM:
        raise Terminated("terminated (SIGTERM)")
    raise KeyboardInterrupt


def install() -> None:
    """Route SIGINT and SIGTERM to :class:`KeyboardInterrupt` (main thread only)."""
    if threading.current_thread() is not threading.main_thread():
        return
    for sig in (signal.SIGINT, signal.SIGTERM):
        if signal.getsignal(sig) is not signal.SIG_IGN:
            signal.signal(sig, _handler)


@contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT / SIGTERM until the block ends, then raise it (KeyboardInterrupt)."""
    _state["depth"] += 1
    try:
        yield
    finally:
        _state["depth"] -= 1
        if _state["depth"] == 0 and _state["pending"] is not None:
            signum, _state["pending"] = _state["pending"], None
            _raise(signum)
