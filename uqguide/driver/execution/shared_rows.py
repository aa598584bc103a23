"""Per-run values that pool workers write in place, in memory shared with the driver.

The driver lays out one array per value for the whole stage, from the first chunk that comes
back, in files under ``/dev/shm``; later chunks write their rows in place and send only the
sums through the pool's pipe. Each file is reserved whole before a worker writes to it, so a
small ``/dev/shm`` means the pipe, never a SIGBUS. The files are unlinked when the stage ends;
a killed driver's by the next run's sweep. Why: ``docs/scale.md#memory``.
"""

from __future__ import annotations

import logging
import os
import secrets
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from ...core.atomic import pid_alive
from .chunks import ChunkResult, RowsLayout, Slot

log = logging.getLogger(__name__)

SHM_DIR = Path("/dev/shm")
_PREFIX = "uqguide-rows-"


def write_in_place(layout: RowsLayout, r: ChunkResult) -> ChunkResult:
    """In a worker: write the result's per-run values into the shared arrays and return the
    result without them, ``in_place`` naming what was written and how many runs. A value that
    cannot be written (its file gone) stays in the result and travels by the pipe."""
    scalars, summary = dict(r.scalars), dict(r.summary)
    done = []
    for s in layout:
        src = scalars if s.part == "scalars" else summary
        v = src.get(s.key)
        if v is None or v.ndim != len(s.shape) or v.dtype != np.dtype(s.dtype):
            continue
        n = v.shape[s.runs_axis]
        try:
            arr = s.open()
        except OSError:
            continue
        if s.runs_axis == 0:
            arr[r.task.start:r.task.start + n] = v
        else:
            arr[:, r.task.start:r.task.start + n] = v
        del arr  # unmapped now: a worker holds no stage's memory between chunks
        del src[s.key]
        done.append((s.part, s.key, n))
    return replace(r, scalars=scalars, summary=summary, in_place=tuple(done))


@dataclass
class SharedRows:
    """The driver's side: the stage's shared arrays, views of them for each result."""

    layout: RowsLayout
    arrays: dict[tuple[str, str], np.ndarray]

    @classmethod
    def for_result(cls, first: ChunkResult, n_runs: int,
                   per_run: Callable[[str], bool]) -> SharedRows | None:
        """Arrays for ``n_runs`` runs shaped after the first result back: its scalars and the
        summary entries ``per_run`` names (lane-major). None without room in ``/dev/shm``."""
        specs = [("scalars", k, (n_runs, *v.shape[1:]), v.dtype, 0)
                 for k, v in first.scalars.items()]
        specs += [("summary", k, (v.shape[0], n_runs), v.dtype, 1)
                  for k, v in first.summary.items() if per_run(k) and v.ndim == 2]
        if not specs or not SHM_DIR.is_dir():
            return None
        _sweep()
        tag = f"{_PREFIX}{os.getpid()}-{secrets.token_hex(4)}"
        slots, arrays = [], {}
        try:
            for i, (part, key, shape, dtype, axis) in enumerate(specs):
                path = SHM_DIR / f"{tag}-{i}"
                size = max(int(np.prod(shape)) * dtype.itemsize, 1)
                fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_EXCL, 0o600)
                try:
                    os.posix_fallocate(fd, 0, size)  # all of it now, or ENOSPC now
                finally:
                    os.close(fd)
                slot = Slot(part, key, str(path), shape, dtype.str, axis)
                slots.append(slot)
                # a plain ndarray view (its base keeps the mapping alive): what NumPy computes
                # from it is an ndarray too, never a memmap
                arrays[(part, key)] = np.asarray(slot.open())
        except (OSError, AttributeError) as exc:  # AttributeError: no posix_fallocate
            log.info("per-run values go through the pipe: no room for them in %s (%s)",
                     SHM_DIR, exc)
            for p in SHM_DIR.glob(f"{tag}-*"):
                p.unlink(missing_ok=True)
            return None
        return cls(tuple(slots), arrays)

    def scalar_array(self, key: str) -> np.ndarray | None:
        """The stage's array of a scalar output, ``(n_runs, ...)``, if it is shared."""
        return self.arrays.get(("scalars", key))

    def adopt(self, r: ChunkResult) -> ChunkResult:
        """The result with views of what its worker wrote in place."""
        if not r.in_place:
            return r
        scalars, summary = dict(r.scalars), dict(r.summary)
        a = r.task.start
        for part, key, n in r.in_place:
            arr = self.arrays[(part, key)]
            if part == "scalars":
                scalars[key] = arr[a:a + n]
            else:
                summary[key] = arr[:, a:a + n]
        return replace(r, scalars=scalars, summary=summary)

    def close(self) -> None:
        """Unlink the files (the driver's views stay valid until they are dropped)."""
        for s in self.layout:
            Path(s.path).unlink(missing_ok=True)


def _sweep() -> None:
    """Remove the files of drivers that are gone (killed before they could unlink them)."""
    for p in SHM_DIR.glob(f"{_PREFIX}*"):
        try:
            pid = int(p.name[len(_PREFIX):].split("-", 1)[0])
        except ValueError:
            continue
        if pid != os.getpid() and not pid_alive(pid):
            p.unlink(missing_ok=True)
