"""Model calls that cannot hang a run or take a process down with them.

A **guard process** is a child of the process evaluating the chunk, started once and reused.
With ``timeout_s`` every model call runs in one; without it, a model that can crash its process
does in a run without workers. A call that does not answer in time, or whose process dies, is
killed with its process and its batch bisected in fresh guards down to single samples: a
hanging or crashing sample fails alone, with the reason. When and how: ``docs/scale.md#failures``.
"""

from __future__ import annotations

import logging
import multiprocessing
import os
import pickle
import signal
import sys
import types
from collections.abc import Callable, Collection, Iterator, Sequence
from contextlib import contextmanager
from typing import Any

import numpy as np

from ...errors import ModelError, WorkerStartError
from ...core.process_groups import stop_on_sigterm
from ...core.temp_folders import multiprocessing_folder
from ...core.types import ModelOutput
from .isolation import Spent, assemble_pieces, timed_batch
from .processes import (NESTED_RUN_EXIT, OVER_MEMORY_EXIT, WORKERS_DID_NOT_START,
                        die_with_parent, limit_memory, sigint_ignored)

log = logging.getLogger(__name__)

#: Called with (row of the batch, reason) for each sample isolated by a crash or a timeout.
OnIsolated = Callable[[int, str], None]


class GuardUnavailable(ModelError):
    """The guard process started but could not build the model (a function defined in a
    notebook, which another process cannot import). A run whose isolation is only the
    default goes on in its own process; one that asked for it (``isolate: true``,
    ``timeout_s``) stops with this message."""


def _serve(conn: Any, memory_limit: int | None = None) -> None:
    # SIGTERM, not SIGKILL, from a dying parent and from close: the guard's handler kills the
    # external programs it waits for (core.process_groups) before it goes
    die_with_parent(signal.SIGTERM)
    stop_on_sigterm()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the driver handles Ctrl-C
    limit_memory(memory_limit)
    try:
        _answer(conn)
    except MemoryError:
        os._exit(OVER_MEMORY_EXIT)  # the caller bisects it like a crash


def _answer(conn: Any) -> None:
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg[0] == "prepare":  # build the model (imports, kernels) outside the timeout
            # A guard forked from the fork server has the server's environment: the caller's
            # (as it is now) is what the model must see.
            os.environ.clear()
            os.environ.update(msg[2])
            try:
                _ = msg[1].model  # the property builds the model
                reply: tuple[str, Any] = ("ready", None)
            except Exception as exc:  # noqa: BLE001
                reply = ("raised", f"{type(exc).__name__}: {exc}")
        else:
            _, handle, x, names, outputs = msg
            try:
                # timed here: the driver's clock would see only the pipe
                reply = ("ok", timed_batch(handle.model, x, names, outputs))
            except ModelError as exc:
                reply = ("model_error", str(exc))
            except MemoryError:
                raise
            except Exception as exc:  # noqa: BLE001 - reported to the caller, which bisects
                reply = ("raised", f"{type(exc).__name__}: {exc}")
        try:
            conn.send(reply)
        except (BrokenPipeError, ConnectionResetError, EOFError):
            return  # the caller is gone (killed): nobody to answer, and nothing to print


def _needs_main(handle: Any) -> bool:
    """Whether the model refers to the script that started the run (a function defined in
    ``__main__``): only then must a guard re-import that script."""
    try:
        return b"__main__" in pickle.dumps(handle)
    except Exception:  # noqa: BLE001 - unpicklable: the start reports it
        return True


@contextmanager
def _main_hidden() -> Iterator[None]:
    """Start a child without re-running the parent's main script: ``multiprocessing``
    re-imports ``sys.modules["__main__"]`` in a ``spawn`` child (and in the fork server) when
    it has a file or a module spec, and this stand-in has neither."""
    main = sys.modules.get("__main__")
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        if main is not None:
            sys.modules["__main__"] = main


def _context(needs_main: bool) -> Any:
    """Where a guard process comes from: a single-threaded fork server (a fresh guard after a
    crash costs a fork, not the imports), or ``spawn`` for a model defined in the main script.
    Either keeps its temporary files (the fork server's socket) in a marked folder, swept by the
    next run if this one is killed."""
    multiprocessing_folder()
    if needs_main or "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([__name__])
    return ctx


class Guard:
    """One guard process (started on first use, replaced after a timeout or a crash)."""

    #: Seconds a fresh guard may take to start and build the model (not the model's time).
    START_S = 300.0
    #: Seconds a guard is given to end its programs on SIGTERM before it is killed.
    TERM_S = 1.0

    def __init__(self, timeout_s: float | None, memory_limit: int | None = None) -> None:
        self.timeout_s = timeout_s
        self.memory_limit = memory_limit
        self._proc: Any = None
        self._conn: Any = None
        self._prepared: Any = None
        self._needs_main: dict[int, bool] = {}
        #: Why the model cannot run here (a guard that could not start or build it): a run
        #: whose isolation is only the default then evaluates in its own process.
        self.unavailable = ""

    def _start(self, handle: Any) -> None:
        key = id(handle)
        if key not in self._needs_main:
            self._needs_main[key] = _needs_main(handle)
        ctx = _context(self._needs_main[key])
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_serve, args=(child, self.memory_limit), daemon=True,
                           name="uqguide-guard")
        with sigint_ignored():
            if self._needs_main[key]:
                proc.start()
            else:
                with _main_hidden():
                    proc.start()
        child.close()
        self._proc, self._conn = proc, parent
        self._prepared = None

    def _prepare(self, handle: Any) -> None:
        key = id(handle)
        if self._prepared == key:
            return
        try:
            self._conn.send(("prepare", handle, dict(os.environ)))
            if not self._conn.poll(self.START_S):
                raise WorkerStartError(f"the guard process did not start within "
                                       f"{self.START_S:g} s")
            status, value = self._conn.recv()
        except (EOFError, OSError):
            # Dead before it built the model: no sample is to blame, and a fresh guard would
            # die the same way, once per sample of the bisection.
            self._proc.join(5)
            code = self._proc.exitcode
            if code == NESTED_RUN_EXIT:
                raise WorkerStartError(WORKERS_DID_NOT_START) from None
            raise WorkerStartError(f"the guard process died while starting or building the "
                                   f"model (exit code {code}), before any sample ran") from None
        if status != "ready":
            raise GuardUnavailable(f"cannot build the model in the guard process: {value}")
        self._prepared = key

    def close(self) -> None:
        """Stop the guard process (a later call starts a fresh one)."""
        if self._proc is not None:
            if self._proc.is_alive():
                # SIGTERM lets a guard waiting on a command's program kill that program's
                # process group (it runs in a session of its own, out of reach of a kill aimed
                # at the guard); a guard stuck in compiled code cannot answer, and is killed
                self._proc.terminate()
                self._proc.join(self.TERM_S)
                if self._proc.is_alive():
                    self._proc.kill()
            self._proc.join(5)
            self._conn.close()
        self._proc = self._conn = None

    def call(self, handle: Any, x: np.ndarray, names: Sequence[str],
             outputs: Collection[str]) -> tuple[str, Any]:
        """One model call in the guard process (the model rebuilt there once), killed after
        ``timeout_s``: ``("ok", (ModelOutput, Spent there))``, or ``("timeout" | "crashed" |
        "raised", reason)``; a ModelError (the caller's mistake, not the sample's) is raised
        here."""
        if self._proc is None or not self._proc.is_alive():
            self.close()
            self._start(handle)
        try:
            self._prepare(handle)  # the start of a fresh guard is not the model's time
            self._conn.send(("call", handle, x, tuple(names), tuple(outputs)))
            ready = self._conn.poll(self.timeout_s)
            if ready:
                status, value = self._conn.recv()
            else:
                self.close()
                return "timeout", (f"model call did not finish within timeout_s = "
                                   f"{self.timeout_s:g} s (killed)")
        except KeyboardInterrupt:
            self.close()  # a call cut short leaves a guard in an unknown state
            raise
        except (EOFError, OSError, BrokenPipeError):
            if self._proc is not None:
                self._proc.join(5)  # its exit code says why it ended
            code = self._proc.exitcode if self._proc is not None else None
            self.close()
            if code == OVER_MEMORY_EXIT and self.memory_limit is not None:
                return "crashed", (f"model process went over its memory limit (max_memory = "
                                   f"{self.memory_limit / 2**20:.0f} MiB per process)")
            return "crashed", f"model process crashed (exit code {code})"
        if status == "model_error":
            raise ModelError(value)
        return status, value


_GUARDS: dict[tuple[float | None, int | None], Guard] = {}


def guard_for(timeout_s: float | None, memory_limit: int | None = None) -> Guard:
    """This process's guard (one, reused) for ``timeout_s`` (None: crash isolation only) and
    ``memory_limit`` [bytes of address space] (None: no limit)."""
    g = _GUARDS.get((timeout_s, memory_limit))
    if g is None:
        g = _GUARDS[(timeout_s, memory_limit)] = Guard(timeout_s, memory_limit)
    return g


def close_guards() -> None:
    """Stop this process's guard processes."""
    for g in _GUARDS.values():
        g.close()
    _GUARDS.clear()


def guarded_batch(handle: Any, x: np.ndarray, names: Sequence[str], outputs: Collection[str],
                  timeout_s: float | None, memory_limit: int | None = None,
                  on_isolated: OnIsolated | None = None, spent: Spent | None = None
                  ) -> ModelOutput:
    """``evaluate_batch`` in the guard process, bisected on a timeout or a crash down to the
    samples that fail alone; ``x (n, d)``: SI units, column ``j`` for ``names[j]``;
    ``on_isolated(row, reason)``: told of each (the driver records it for a resume);
    ``spent``: incremented by the CPU the calls that answered took in the guard."""
    model = handle.model
    guard = guard_for(timeout_s, memory_limit)
    pieces: list[Any] = []

    def bisect(rows: np.ndarray, first: int) -> None:
        status, value = guard.call(handle, rows, names, outputs)
        if status == "ok":
            out, there = value
            pieces.append(out)
            if spent is not None:
                spent.add(there)
            return
        if rows.shape[0] <= 1:
            pieces.append((rows.shape[0], value))
            log.warning("model '%s': a sample failed: %s", model.name, value)
            if on_isolated is not None and rows.shape[0] == 1 and status != "raised":
                on_isolated(first, value)
            return
        half = rows.shape[0] // 2
        bisect(rows[:half], first)
        bisect(rows[half:], first + half)

    bisect(x, 0)
    return assemble_pieces(model, pieces, outputs)
