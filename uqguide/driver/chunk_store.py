"""The finished chunks of a run folder: one file each, listed in the manifest once on disk.

A chunk's file ``<label>.s<stage>.c<index>.npz`` holds its run id, label, stage and bounds, its
per-sample failure mask, reasons, and its scalar outputs with either its series or its method's
summary (Monte Carlo sums) packed into one byte array with a JSON index of names, dtypes,
shapes and offsets (no pickle anywhere). It is written to a temporary name, fsynced and renamed
into place; only then is it listed in the manifest, with the line
``{"kind": "chunk", "run", "label", "stage", "index", "start", "stop", "file", "n_failed"}``.

A chunk read back must be this run's: one that carries another run id (in its manifest line or
in its file), or another method or stage, is refused, never folded in.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.atomic import atomic_path
from ..errors import ConfigError
from .execution import ChunkResult, Task
from .run_manifest import ChunkKey

log = logging.getLogger(__name__)


class ChunkStore:
    """The chunks of the run ``run_id`` listed in the folder ``folder``.

    Parameters
    ----------
    folder : Path
        The run folder.
    run_id : str
        This run's id: a stored chunk of another run is refused.
    entries : dict, optional
        The chunk lines already in the manifest, by (label, stage, index).
    """

    def __init__(self, folder: Path, run_id: str,
                 entries: dict[ChunkKey, dict[str, Any]] | None = None) -> None:
        self.folder = folder
        self.run_id = run_id
        self._entries: dict[ChunkKey, dict[str, Any]] = dict(entries or {})

    def __len__(self) -> int:
        return len(self._entries)

    def entry(self, label: str, stage: int, result: ChunkResult) -> dict[str, Any]:
        """The manifest line of a chunk (its file is named after its label, stage and index).

        Parameters
        ----------
        label : str
            The method's label.
        stage : int
            Design stage (0: initial, then one per refinement).
        result : ChunkResult

        Returns
        -------
        dict
        """
        t = result.task
        return {"kind": "chunk", "run": self.run_id, "label": label, "stage": stage,
                "index": t.index, "start": t.start, "stop": t.stop,
                "file": f"{label}.s{stage}.c{t.index:06d}.npz", "n_failed": result.n_failed}

    def add(self, entry: dict[str, Any]) -> None:
        """List a chunk whose file is on disk and whose line is in the manifest."""
        self._entries[(entry["label"], entry["stage"], entry["index"])] = entry

    def load(self, label: str, stage: int, task: Task) -> ChunkResult | None:
        """The stored result of a chunk, or None when it is not (validly) stored.

        Parameters
        ----------
        label : str
            The method's label.
        stage : int
            Design stage (0: initial, then one per refinement).
        task : Task
            The chunk.

        Returns
        -------
        ChunkResult or None
            ConfigError when the stored chunk belongs to another run.
        """
        e = self._entries.get((label, stage, task.index))
        if e is None:
            return None
        if e.get("run") != self.run_id:
            raise ConfigError(
                f"cannot resume {self.folder}: chunk {task.index} of {label} ({e.get('file')}) "
                f"belongs to another run (run id {str(e.get('run'))[:12]}, this run "
                f"{self.run_id[:12]}); delete the folder to start over", field="resume")
        if (e["start"], e["stop"]) != (task.start, task.stop):
            log.warning("%s: chunk %d of %s has other bounds than stored; re-running it",
                        self.folder, task.index, label)
            return None
        try:
            r = read_chunk(self.folder / e["file"], task)
        except ForeignChunk as exc:
            raise ConfigError(f"cannot resume {self.folder}: {e['file']} {exc} (this run "
                              f"{self.run_id[:12]}, {label} stage {stage}); delete the "
                              f"folder to start over", field="resume") from None
        except (OSError, ValueError, KeyError) as exc:
            log.warning("%s: cannot read %s (%s); re-running the chunk", self.folder, e["file"],
                        exc)
            return None
        if r.run_id != self.run_id or r.label != label or r.stage != stage:
            raise ConfigError(
                f"cannot resume {self.folder}: {e['file']} belongs to another run or method "
                f"(run id {r.run_id[:12]}, {r.label} stage {r.stage}; this run "
                f"{self.run_id[:12]}, {label} stage {stage}); delete the folder to start over",
                field="resume")
        return r.result


# ---------------------------------------------------------------------------- chunk files
class ForeignChunk(ValueError):
    """A chunk file written by another run."""


@dataclass
class StoredChunk:
    """A chunk file read back: its result and whose it says it is."""

    result: ChunkResult
    run_id: str
    label: str
    stage: int


def write_chunk(path: Path, r: ChunkResult, run_id: str, label: str, stage: int) -> None:
    """Write one chunk's file at ``path``, whole or not at all, fsynced with its folder.

    Parameters
    ----------
    path : Path
    r : ChunkResult
    run_id : str
    label : str
    stage : int
    """
    # The scalars, series and summary go packed into one byte array with a JSON index: a
    # Monte Carlo chunk's summary is ~100 small arrays, and one zip entry each made the
    # checkpoints the driver's largest cost (2.5 s of a 1e6-run study, 20 ms a chunk).
    index, packed = _pack({**{f"scalar.{k}": v for k, v in r.scalars.items()},
                           **{f"series.{k}": v for k, v in r.series.items()},
                           **{f"summary.{k}": v for k, v in r.summary.items()}})
    # Any: np.savez's stub would match a dict of arrays against its allow_pickle flag
    arrays: dict[str, Any] = {
        "run_id": np.array(run_id), "label": np.array(label),
        "stage": np.array(stage, dtype=np.int64),
        "task": np.array([r.task.index, r.task.start, r.task.stop], dtype=np.int64),
        "model_seconds": np.array(r.model_seconds),
        "cpu_seconds": np.array(r.cpu_seconds),
        "failed": r.failed,
        "reasons": np.array([str(v) for v in r.reasons], dtype=str),
        "time": r.time,
        "index": np.array(index), "packed": packed,
    }
    # fsynced file and folder: the rename must survive a power cut before the manifest line
    with atomic_path(path, clean=False) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)


def read_chunk(path: Path, task: Task) -> StoredChunk:
    """Read back the chunk file of ``task``.

    Parameters
    ----------
    path : Path
    task : Task
        The chunk it must hold.

    Returns
    -------
    StoredChunk

    Raises
    ------
    ForeignChunk
        The file carries no run id.
    ValueError, KeyError, OSError
        The file is not the chunk's, or not readable.
    """
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    if "run_id" not in data:
        raise ForeignChunk("carries no run id (written by an older uqguide or another tool)")
    if tuple(int(v) for v in data["task"]) != (task.index, task.start, task.stop):
        raise ValueError("chunk file does not match its manifest entry")
    arrays = _unpack(str(data["index"]), data["packed"])
    pick = {p: {k[len(p) + 1:]: v for k, v in arrays.items() if k.startswith(p + ".")}
            for p in ("scalar", "series", "summary")}
    return StoredChunk(run_id=str(data["run_id"]), label=str(data["label"]),
                       stage=int(data["stage"]), result=ChunkResult(
        task=task, failed=data["failed"].astype(bool),
        reasons=np.array(data["reasons"].tolist(), dtype=object).reshape(-1),
        time=data["time"], scalars=pick["scalar"], series=pick["series"],
        summary=pick["summary"], model_seconds=float(data["model_seconds"]),
        # (a chunk written before CPU seconds were kept: 0)
        cpu_seconds=float(data.get("cpu_seconds", 0.0))))


def _pack(arrays: dict[str, np.ndarray]) -> tuple[str, np.ndarray]:
    """Numeric arrays as one byte array and a JSON index of (name, dtype, shape, offset)."""
    entries, parts, offset = [], [], 0
    for name, v in arrays.items():
        a = np.asarray(v)  # (np.ascontiguousarray would make a 0-d array 1-d)
        if a.dtype.hasobject or a.dtype.kind not in "biufc":
            raise TypeError(f"checkpoint: {name} has dtype {a.dtype}, not a numeric array")
        entries.append([name, a.dtype.str, list(a.shape), offset])
        parts.append(np.ascontiguousarray(a).reshape(-1).view(np.uint8))
        offset += a.nbytes
    packed = np.concatenate(parts) if parts else np.zeros(0, dtype=np.uint8)
    return json.dumps(entries), packed


def _unpack(index: str, packed: np.ndarray) -> dict[str, np.ndarray]:
    out = {}
    for name, dtype, shape, offset in json.loads(index):
        dt = np.dtype(dtype)
        if dt.hasobject or dt.kind not in "biufc":
            raise ValueError(f"packed array {name!r} has dtype {dtype}")
        count = int(np.prod(shape, dtype=np.int64))
        if offset < 0 or offset + count * dt.itemsize > packed.size:
            raise ValueError(f"packed array {name!r} runs past the end of the file")
        out[name] = packed[offset:offset + count * dt.itemsize].view(dt).reshape(shape).copy()
    return out
