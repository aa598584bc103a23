"""Ctrl-C and SIGTERM: one way to stop, at any moment, with exit code 130.

:func:`install` makes SIGINT and SIGTERM raise :class:`KeyboardInterrupt` in the main thread
(SIGTERM as its subclass :class:`Terminated`). Inside :func:`deferred` a signal is held until
the block ends, so a file is written whole. An interrupt Python would swallow goes to a flag
that :func:`raise_swallowed` raises; :func:`raise_received` raises again, when a command ends,
a signal that was caught on the way. Why each is needed: ``docs/scale.md#checkpoints-and-resume``.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType
from typing import Any

#: Exit code of a run stopped by SIGINT or SIGTERM (128 + SIGINT, as shells report Ctrl-C).
EXIT_INTERRUPTED = 130


class Terminated(KeyboardInterrupt):
    """SIGTERM, delivered like Ctrl-C."""


class _Deferral:
    """How many :func:`deferred` blocks are open, and the signal held until they close."""

    depth: int = 0
    pending: int | None = None
    #: the signal whose exception Python swallowed (raised where it could not propagate)
    swallowed: int | None = None
    #: the signal last raised by the handler
    raised: int = signal.SIGINT
    #: the first signal received since :func:`install` (None: none)
    received: int | None = None
    hook: Any = None


_state = _Deferral()


def _handler(signum: int, frame: FrameType | None) -> None:
    if _state.received is None:
        _state.received = signum
    if _state.depth > 0:
        _state.pending = signum
        return
    _state.raised = signum
    _raise(signum)


def _unraisable(info: Any) -> None:
    """``sys.unraisablehook``: an interrupt Python could not propagate is kept, not printed."""
    if info.exc_type is not None and issubclass(info.exc_type, KeyboardInterrupt):
        _state.swallowed = _state.raised
        return
    (_state.hook or sys.__unraisablehook__)(info)


def raise_swallowed() -> None:
    """Raise the interrupt Python swallowed, if any (outside :func:`deferred` blocks)."""
    signum = _state.swallowed
    if signum is not None and _state.depth == 0:
        _state.swallowed = None
        _raise(signum)


def raise_received() -> None:
    """Raise the first signal received since :func:`install`, even if its exception was caught
    on the way (outside :func:`deferred` blocks): a command that got one exits 130, not 0."""
    signum = _state.received
    if signum is not None and _state.depth == 0:
        _state.received = _state.swallowed = None
        _raise(signum)


def _raise(signum: int) -> None:
    if signum == signal.SIGTERM:
        raise Terminated("terminated (SIGTERM)")
    raise KeyboardInterrupt


def install() -> dict[int, Any]:
    """Route SIGINT and SIGTERM to :class:`KeyboardInterrupt` (main thread only; a signal
    ignored stays ignored); returns the handlers replaced, for :func:`restore`."""
    previous: dict[int, Any] = {}
    if threading.current_thread() is not threading.main_thread():
        return previous
    for sig in (signal.SIGINT, signal.SIGTERM):
        old = signal.getsignal(sig)
        if old is not signal.SIG_IGN:
            previous[sig] = old
            signal.signal(sig, _handler)
    if previous and sys.unraisablehook is not _unraisable:
        _state.hook, sys.unraisablehook = sys.unraisablehook, _unraisable
    _state.swallowed = _state.received = None
    return previous


def restore(previous: dict[int, Any]) -> None:
    """Put back the handlers :func:`install` replaced."""
    if threading.current_thread() is threading.main_thread():
        for sig, old in previous.items():
            signal.signal(sig, old if old is not None else signal.SIG_DFL)
        if previous and sys.unraisablehook is _unraisable:
            sys.unraisablehook, _state.hook = _state.hook or sys.__unraisablehook__, None


def ignore_signals() -> None:
    """Ignore SIGINT and SIGTERM from now on (the command has finished)."""
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            signal.signal(sig, signal.SIG_IGN)


@contextmanager
def deferred() -> Iterator[None]:
    """Hold SIGINT / SIGTERM until the block ends, then raise it (KeyboardInterrupt)."""
    _state.depth += 1
    try:
        yield
    finally:
        _state.depth -= 1
        signum = _state.pending
        if _state.depth == 0 and signum is not None:
            _state.pending = None
            _raise(signum)
        raise_swallowed()
