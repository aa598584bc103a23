"""The background thread that writes checkpoints while the driver folds the next chunk.

Writing a chunk takes three fsyncs (its file, its folder, its manifest line): 1.3 s of a
1e6-run study's wall time when they were in line with the driver. The writer takes them off the
driver's thread, in the order the chunks were given. A chunk still queued when the process is
killed is simply not listed, so a resume re-runs it.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable
from typing import Generic, TypeVar

from .interrupts import deferred

Item = TypeVar("Item")


class CheckpointWriter(Generic[Item]):
    """Calls ``write(item)`` on a thread of its own for each item :meth:`put`, one after the
    other in the order given.

    The first error of ``write`` (a full disk) is raised by the next :meth:`put` or by
    :meth:`flush`; the items queued after it are dropped (their chunks re-run on resume).

    Parameters
    ----------
    write : callable
        Writes one item; runs on the writer's thread.
    maxsize : int
        Items queued at most: a writer slower than the workers holds back the driver, not its
        memory.
    """

    def __init__(self, write: Callable[[Item], None], maxsize: int = 16) -> None:
        self._write = write
        # an item travels in a 1-tuple, so that None stays free to mean "stop"
        self._queue: queue.Queue[tuple[Item] | None] = queue.Queue(maxsize=maxsize)
        self._thread: threading.Thread | None = None
        self._error: BaseException | None = None

    def put(self, item: Item) -> None:
        """Queue one item (starting the thread on the first); raise the writer's error."""
        self._raise_error()
        if self._thread is None:
            self._thread = threading.Thread(target=self._loop, name="uqguide-checkpoint",
                                            daemon=True)
            self._thread.start()
        self._queue.put((item,))

    def flush(self) -> None:
        """Wait until every queued item is written; raise the writer's error."""
        self.drain()
        self._raise_error()

    def drain(self) -> None:
        """Wait until the writer is done with every queued item, raising nothing of its own
        (for a run that is stopping with an error or an interrupt). A Ctrl-C or SIGTERM while
        it waits is held until the writer is done (a few chunk writes at most): the process
        must not exit with the writer half-way through a file."""
        if self._thread is not None:
            with deferred():
                self._queue.join()

    def close(self) -> None:
        """:meth:`flush`, then end the thread."""
        try:
            self.flush()
        finally:
            if self._thread is not None:
                with deferred():
                    self._queue.put(None)
                    self._thread.join()
                self._thread = None

    def _raise_error(self) -> None:
        if self._error is not None:
            err, self._error = self._error, None
            raise err

    def _loop(self) -> None:
        while True:
            job = self._queue.get()
            try:
                if job is None:
                    return
                if self._error is None:  # after a failure, nothing more: the chunks re-run
                    self._write(job[0])
            except BaseException as exc:  # noqa: BLE001 - handed to the driver's thread
                self._error = exc
            finally:
                self._queue.task_done()
