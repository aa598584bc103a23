"""The exception hierarchy of uqguide.

Every error uqguide raises on purpose derives from :class:`UqguideError`; ``cli.py`` maps
:class:`ConfigError` (bad user input) to exit code 2 and other :class:`UqguideError` to 1.
"""

from __future__ import annotations


class UqguideError(Exception):
    """Base class of every error uqguide raises on purpose."""


class ConfigError(UqguideError):
    """The user's input (config file, command-line value) is invalid; the message names the
    field path, the value given and what is allowed, on one line."""

    def __init__(self, message: str, *, field: str | None = None) -> None:
        super().__init__(message)
        self.field = field


class ModelError(UqguideError):
    """A model was used against its contract (wrong input shape, unknown input or output name);
    a sample whose integration fails is *not* one: it is flagged in ``ModelOutput.failed``."""


class MethodError(UqguideError):
    """A propagation method cannot produce statistics (e.g. too many failed runs for a PCE)."""


class MethodsFailed(MethodError):
    """No method produced statistics, but runs of theirs succeeded: ``result`` (a
    :class:`~uqguide.results.result.Result`) holds those runs and each method's reason;
    ``written``: the files :func:`~uqguide.commands.run_and_write.run_and_write` wrote of it."""

    def __init__(self, message: str, result: object) -> None:
        super().__init__(message)
        self.result = result
        self.written: object = None


class ResultError(UqguideError):
    """A result file or baseline is missing, corrupt, or does not match what was asked of it."""


class WorkerStartError(UqguideError):
    """Worker processes died while starting, before they ran a single sample (not a sample's
    fault: new workers would die the same way). Usually a script that calls ``uqguide.run(...,
    workers=N)`` at its top level, without an ``if __name__ == "__main__":`` guard."""


class ClusterLost(UqguideError):
    """A Dask run lost its cluster: no worker for ``--no-workers-timeout`` seconds, or the
    connection to its scheduler. ``n_done`` of ``n_total`` chunks are checkpointed for
    ``--resume`` (None until the driver has counted them)."""

    def __init__(self, message: str, n_done: int | None = None,
                 n_total: int | None = None) -> None:
        super().__init__(message)
        self.n_done = n_done
        self.n_total = n_total


class DiskFull(UqguideError):
    """A write of the file ``path`` found no room (ENOSPC, EFBIG past the file size limit,
    EDQUOT); every file is whole (the old one or none), as :mod:`uqguide.core.atomic` writes
    them."""

    def __init__(self, path: object) -> None:
        super().__init__(f"disk full writing {path}; no file was left half-written: free "
                         f"space and run the command again")
        self.path = path
