"""Model calls that cannot hang a run or take a process down with them.

With ``timeout_s`` set, every model call runs in a **guard process**: a child of the process
evaluating the chunk (the driver, or a pool worker), started once and reused. The caller waits
at most ``timeout_s`` for the answer. A call that does not answer in time is killed with its
process; a call whose process dies (segfault, ``os._exit``, out-of-memory kill) likewise. Either
way the batch is split in halves and each half is tried again in a fresh guard, down to single
samples: one hanging or crashing sample costs that sample (failed, with the reason), not its
chunk, at ``log2(batch)`` extra calls and waits.

Guard and pool processes die with their parent (``PR_SET_PDEATHSIG`` on Linux, and a watchdog
thread that notices a new parent elsewhere): a driver killed by the out-of-memory killer leaves
no process behind holding its pipes.
"""

from __future__ import annotations

import logging
import multiprocessing
import signal
from collections.abc import Collection, Sequence
from typing import Any

import numpy as np

from ...errors import ModelError, WorkerStartError
from ...core.types import ModelOutput
from .isolation import assemble_pieces, evaluate_batch
from .processes import (NESTED_RUN_EXIT, WORKERS_DID_NOT_START, die_with_parent,
                        sigint_ignored)

log = logging.getLogger(__name__)


def _serve(conn: Any) -> None:
    die_with_parent()
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the driver handles Ctrl-C
    while True:
        try:
            msg = conn.recv()
        except (EOFError, OSError):
            return
        if msg[0] == "prepare":  # build the model (imports, kernels) outside the timeout
            try:
                _ = msg[1].model  # the property builds the model
                conn.send(("ready", None))
            except Exception as exc:  # noqa: BLE001
                conn.send(("raised", f"{type(exc).__name__}: {exc}"))
            continue
        _, handle, x, names, outputs = msg
        try:
            out = evaluate_batch(handle.model, x, names, outputs)
            conn.send(("ok", out))
        except ModelError as exc:
            conn.send(("model_error", str(exc)))
        except Exception as exc:  # noqa: BLE001 - reported to the caller, which bisects
            conn.send(("raised", f"{type(exc).__name__}: {exc}"))


class Guard:
    """One guard process (started on first use, replaced after a timeout or a crash)."""

    #: Seconds a fresh guard may take to start and build the model (not the model's time).
    START_S = 300.0

    def __init__(self, timeout_s: float | None) -> None:
        self.timeout_s = timeout_s
        self._proc: Any = None
        self._conn: Any = None
        self._prepared: Any = None

    def _start(self) -> None:
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe()
        proc = ctx.Process(target=_serve, args=(child,), daemon=True, name="uqguide-guard")
        with sigint_ignored():
            proc.start()
        child.close()
        self._proc, self._conn = proc, parent
        self._prepared = None

    def _prepare(self, handle: Any) -> None:
        key = id(handle)
        if self._prepared == key:
            return
        try:
            self._conn.send(("prepare", handle))
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
            raise ModelError(f"cannot build the model in the guard process: {value}")
        self._prepared = key

    def _stop(self) -> None:
        if self._proc is not None:
            if self._proc.is_alive():
                self._proc.kill()
            self._proc.join(5)
            self._conn.close()
        self._proc = self._conn = None

    def call(self, handle: Any, x: np.ndarray, names: Sequence[str],
             outputs: Collection[str]) -> tuple[str, Any]:
        """One model call in the guard process, killed after ``timeout_s``.

        Parameters
        ----------
        handle : ModelHandle
            The model (rebuilt in the guard once).
        x : ndarray, shape (n, d)
            Inputs in SI units.
        names : sequence of str, length d
        outputs : collection of str

        Returns
        -------
        tuple
            ``("ok", ModelOutput)``, or ``("timeout" | "crashed" | "raised", reason)``; a
            ModelError (the caller's mistake, not the sample's) is raised here.
        """
        if self._proc is None or not self._proc.is_alive():
            self._stop()
            self._start()
        try:
            self._prepare(handle)  # the start of a fresh guard is not the model's time
            self._conn.send(("call", handle, x, tuple(names), tuple(outputs)))
            ready = self._conn.poll(self.timeout_s)
            if ready:
                status, value = self._conn.recv()
            else:
                self._stop()
                return "timeout", (f"model call did not finish within timeout_s = "
                                   f"{self.timeout_s:g} s (killed)")
        except KeyboardInterrupt:
            self._stop()  # a call cut short leaves a guard in an unknown state
            raise
        except (EOFError, OSError, BrokenPipeError):
            code = self._proc.exitcode if self._proc is not None else None
            self._stop()
            return "crashed", f"model process crashed (exit code {code})"
        if status == "model_error":
            raise ModelError(value)
        return status, value

    def close(self) -> None:
        self._stop()


_GUARDS: dict[float | None, Guard] = {}


def guard_for(timeout_s: float | None) -> Guard:
    """This process's guard for ``timeout_s`` (one, reused).

    Parameters
    ----------
    timeout_s : float or None
        Seconds a call may take (None: no limit, crash isolation only).

    Returns
    -------
    Guard
    """
    g = _GUARDS.get(timeout_s)
    if g is None:
        g = _GUARDS[timeout_s] = Guard(timeout_s)
    return g


def close_guards() -> None:
    """Stop this process's guard processes."""
    for g in _GUARDS.values():
        g.close()
    _GUARDS.clear()


def guarded_batch(handle: Any, x: np.ndarray, names: Sequence[str], outputs: Collection[str],
                  timeout_s: float | None) -> ModelOutput:
    """``evaluate_batch`` in the guard process, bisected on a timeout or a crash (module
    docstring); the samples that time out or crash alone fail with the reason.

    Parameters
    ----------
    handle : ModelHandle
        The model.
    x : ndarray, shape (n, d)
        Inputs in SI units, column ``j`` for ``names[j]``.
    names : sequence of str, length d
    outputs : collection of str
    timeout_s : float or None
        Seconds one call may take.

    Returns
    -------
    ModelOutput
        The ``n`` samples in order; those isolated fail with the reason.
    """
    model = handle.model
    guard = guard_for(timeout_s)
    pieces: list[Any] = []

    def bisect(rows: np.ndarray) -> None:
        status, value = guard.call(handle, rows, names, outputs)
        if status == "ok":
            pieces.append(value)
            return
        if rows.shape[0] <= 1:
            pieces.append((rows.shape[0], value))
            log.warning("model '%s': a sample failed: %s", model.name, value)
            return
        half = rows.shape[0] // 2
        bisect(rows[:half])
        bisect(rows[half:])

    bisect(x)
    return assemble_pieces(model, pieces, outputs)
