"""A Dask cluster that cannot finish the run: no worker for ``no_workers_timeout`` seconds, or
the scheduler lost. Either stops the run (exit 1), its finished chunks kept for ``--resume``;
Dask itself would wait for a worker forever. Pure logic over a worker count and a clock, so
the rules are tested without a cluster."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

from ...errors import ClusterLost

log = logging.getLogger(__name__)

#: Seconds a Dask run waits without any worker before it stops (``--no-workers-timeout``):
#: long enough for a batch system to replace a lost node's workers, short enough that a run
#: whose workers are all gone says so within a minute and a half.
NO_WORKERS_TIMEOUT = 60.0

#: Why Dask cancels every future of a client whose scheduler connection closed.
SCHEDULER_LOST = "scheduler-connection-lost"


class NoWorkerWatch:
    """Raises :class:`~uqguide.errors.ClusterLost` once a cluster has had no worker for
    ``timeout`` seconds in a row, or at once when ``count()`` (the scheduler's workers now)
    gives None (the connection is lost); ``where``: the scheduler's address."""

    def __init__(self, count: Callable[[], int | None], timeout: float, where: str,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.count = count
        self.timeout = timeout
        self.where = where
        self.clock = clock
        #: When the watch first saw no worker (None: it saw one at its last look).
        self.none_since: float | None = None

    @property
    def poll_seconds(self) -> float:
        """How often to look while no chunk comes back (one small request each time)."""
        return min(1.0, self.timeout / 20)

    def saw_worker(self) -> None:
        """A chunk came back, so a worker was there: the time without one starts again."""
        self.none_since = None

    def check(self) -> None:
        """Look at the cluster once; ClusterLost when it is gone."""
        n = self.count()
        if n is None:
            raise ClusterLost(scheduler_lost(self.where))
        now = self.clock()
        if n > 0:
            if self.none_since is not None:
                log.warning("the Dask cluster at %s has %d worker(s) again", self.where, n)
            self.none_since = None
            return
        if self.none_since is None:
            self.none_since = now
            log.warning("the Dask cluster at %s has no worker; waiting up to %g s for one "
                        "(--no-workers-timeout)", self.where, self.timeout)
        if now - self.none_since >= self.timeout:
            raise ClusterLost(f"the Dask cluster at {self.where} has had no worker for "
                              f"{self.timeout:g} s (--no-workers-timeout)")


def scheduler_lost(where: str) -> str:
    """The message of a run whose connection to the scheduler at ``where`` closed."""
    return f"lost the connection to the Dask scheduler at {where}"


def cancelled_message(exc: BaseException, where: str, connected: bool) -> str:
    """Why the chunks in flight were cancelled (Dask's ``FuturesCancelledError`` of ``wait`` or
    ``FutureCancelledError`` of ``result``), for :class:`~uqguide.errors.ClusterLost`."""
    groups = getattr(exc, "error_groups", None)
    reason = getattr(exc, "reason", None)
    reasons = ({str(g.reason) for g in groups} if groups is not None else
               {str(reason)} if reason is not None else set())
    if not connected or SCHEDULER_LOST in reasons:
        return scheduler_lost(where)
    why = ", ".join(sorted(reasons)) or "no reason given"
    return f"the Dask cluster at {where} cancelled the chunks in flight ({why})"
