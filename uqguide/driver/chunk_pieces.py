"""A small stage in pieces: its chunks evaluated in several model calls each, whose results
come back, are counted and checkpointed one by one, then are joined and reduced here.

A chunk (a Monte Carlo one: 8,192 runs by default) is the unit of a random stream and of the
reduction, so it cannot shrink without changing the numbers; the model calls inside it can. A
stage with no more chunks than the executor runs at once would show no progress and keep
nothing on Ctrl-C until its chunks end; its chunks go out in pieces instead: first two
:data:`PIECES_PER_CHUNK`-ths of a chunk per worker (the second one's speed is without a
start-up), then pieces of about :data:`PIECE_SECONDS` at the latest one's speed (a fast model's
chunk in three calls, not sixteen). The rows joined are those the chunk's own calls give, so
the numbers are the same. What a user sees and what is kept: docs/scale.md, "Small runs in
pieces".
"""
from __future__ import annotations

import math
import time

from .execution import ChunkResult, Task

#: The first pieces of a stage: this fraction of a chunk (at most the batch size).
PIECES_PER_CHUNK = 16
#: Model seconds a piece after the first ones takes, at their speed: a progress step a user
#: sees, a loss on Ctrl-C that does not matter, a call long enough that its overhead does not.
PIECE_SECONDS = 2.0
#: Seconds a stage runs before its pieces are checkpointed: a run that ends sooner has nothing
#: worth a file per model call.
SAVE_AFTER_S = 1.0


def piece_rows(chunk_rows: int, batch_size: int) -> int:
    """Rows per piece of a chunk of ``chunk_rows``: a :data:`PIECES_PER_CHUNK`-th, at most a
    model call's ``batch_size``."""
    return max(1, min(batch_size, -(-chunk_rows // PIECES_PER_CHUNK)))


def at_once(executor: object) -> int:
    """Chunks the executor runs at once: half its window of chunks in flight (one in this
    process)."""
    return max(1, getattr(executor, "window", 2) // 2)


def goes_in_pieces(n_chunks: int, executor: object) -> bool:
    """Whether a stage with ``n_chunks`` chunks to run goes in pieces: no more than the
    executor runs at once, so that none would finish before all end."""
    return 0 < n_chunks <= at_once(executor)


class Pieces:
    """The pieces of the chunks ``tasks`` (each piece a Task of its chunk's index and its own
    rows), restored or evaluated, until each chunk is whole; ``batch_size``: rows per model
    call; ``speed``: ``[model seconds per run]`` of the model's latest piece (``inf``: none yet;
    shared by the stages of one model, and updated)."""

    def __init__(self, tasks: list[Task], batch_size: int,
                 speed: list[float] | None = None) -> None:
        self.chunks = {t.index: t for t in tasks}
        self.batch_size = batch_size
        self._got: dict[int, list[ChunkResult]] = {t.index: [] for t in tasks}
        self._unsaved: list[ChunkResult] = []
        self._t0 = time.monotonic()
        self._speed = speed if speed is not None else [math.inf]

    def restore(self, r: ChunkResult) -> bool:
        """Take a stored piece unless it overlaps one taken (a split of another session);
        whether it was taken."""
        have = self._got[r.task.index]
        if any(p.task.start < r.task.stop and r.task.start < p.task.stop for p in have):
            return False
        have.append(r)
        return True

    def todo(self) -> list[Task]:
        """The pieces to evaluate, chunk by chunk: the rows not kept, cut at multiples of
        :meth:`step` from the chunk's first row."""
        out = []
        for i, t in self.chunks.items():
            if i not in self._got:
                continue  # whole already
            step = self.step(t.n)
            done = sorted((p.task.start, p.task.stop) for p in self._got[i])
            for a in range(t.start, t.stop, step):
                out += [Task(i, lo, hi) for lo, hi in _gaps(a, min(a + step, t.stop), done)]
        return out

    def step(self, chunk_rows: int) -> int:
        """Rows per piece of a chunk of ``chunk_rows``: a batch no larger than the chunk is the
        call size a user chose (a ``command`` program's start-up, a licence per call): its
        calls, as a whole chunk's. Else :func:`piece_rows` until a piece was evaluated, then
        :data:`PIECE_SECONDS` at the latest one's speed (at most the batch size)."""
        if self.batch_size <= chunk_rows:
            return self.batch_size
        first = piece_rows(chunk_rows, self.batch_size)
        per_run = self._speed[0]
        if per_run == math.inf:
            return first
        if per_run <= 0:
            return self.batch_size
        return max(first, min(self.batch_size, int(PIECE_SECONDS / per_run)))

    def whole(self, index: int) -> list[ChunkResult] | None:
        """The pieces of chunk ``index`` in row order when they cover it (then forgotten)."""
        have = self._got.get(index)
        if have is None or sum(p.task.n for p in have) < self.chunks[index].n:
            return None
        del self._got[index]
        self._unsaved = [p for p in self._unsaved if p.task.index != index]
        return sorted(have, key=lambda p: p.task.start)

    def add(self, r: ChunkResult) -> list[ChunkResult] | None:
        """An evaluated piece; its chunk's pieces when the chunk is whole with it."""
        self._got[r.task.index].append(r)
        if r.task.n:
            self._speed[0] = r.model_seconds / r.task.n
        self._unsaved.append(r)
        return self.whole(r.task.index)

    def due(self) -> list[ChunkResult]:
        """The pieces of unfinished chunks to checkpoint now: none in the first
        :data:`SAVE_AFTER_S` seconds, then every one not yet given."""
        if time.monotonic() - self._t0 < SAVE_AFTER_S:
            return []
        out, self._unsaved = self._unsaved, []
        return out


def _gaps(a: int, b: int, done: list[tuple[int, int]]) -> list[tuple[int, int]]:
    """The stretches of ``[a, b)`` outside the sorted, disjoint ranges ``done``."""
    out, at = [], a
    for lo, hi in done:
        if hi <= at or lo >= b:
            continue
        if lo > at:
            out.append((at, lo))
        at = max(at, hi)
    if at < b:
        out.append((at, b))
    return out
