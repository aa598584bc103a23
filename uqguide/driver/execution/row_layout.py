"""Where a chunk's per-run values go when its worker writes them in place: the description
that travels with every chunk (:mod:`uqguide.driver.execution.shared_rows` makes and uses it)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Slot:
    """One shared array: ``part`` (``scalars`` or ``summary``) and ``key`` name the value in a
    :class:`~uqguide.driver.execution.chunks.ChunkResult`; ``runs_axis`` is the axis along which the
    runs lie (0: a row per run; 1: lane-major, a column per good run)."""

    part: str
    key: str
    path: str
    shape: tuple[int, ...]
    dtype: str
    runs_axis: int

    def open(self) -> np.memmap:
        return np.memmap(self.path, dtype=np.dtype(self.dtype), mode="r+", shape=self.shape)


@dataclass(frozen=True)
class RowsLayout:
    """Where a chunk's per-run values go (picklable: it travels with every chunk)."""

    slots: tuple[Slot, ...]
