"""Checkpoints: a run folder that survives a crash, a kill or Ctrl-C, and ``--resume``.

Layout, next to the result file (``<out>/<name>.run/``)::

    manifest.jsonl          append-only, one JSON object a line, flushed and fsynced:
                            line 1 the run's identity (resolved config, uqguide version, model
                            name and a hash of its code) and ``run_id``, the SHA-256 of that
                            identity; then one line per finished chunk
                            {"kind": "chunk", "run", "label", "stage", "index", "start",
                             "stop", "file", "n_failed"}
    <label>.s<stage>.c<index>.npz
                            one chunk's run id, label, stage and bounds, its per-sample failure
                            mask, reasons, and its scalar outputs with either its series or
                            its method's summary (Monte Carlo sums) packed into one byte
                            array with a JSON index of names, dtypes, shapes and offsets
                            (no pickle anywhere); written to a temporary name,
                            fsynced, renamed into place, and only then listed in the manifest

So a chunk listed in the manifest is complete on disk, whatever killed the run and when; a
torn last manifest line (killed while appending) is ignored and its chunk re-run. Chunks are
pure functions of the resolved config (their seeds come from the config's seed and the method
label), so a resumed run gives the statistics of an uninterrupted one bit for bit.

``--resume`` refuses (ConfigError, exit 2) when the config, the uqguide version or the model's
code differ from the run's: the stored chunks would mix two different experiments. Each chunk
carries the run id (in its manifest line and in its file): a chunk of another run (another
seed, config or code) is refused, never folded in. The folder is used under the run's lock
(:mod:`uqguide.driver.runlock`), and is deleted only when its manifest identifies it as a uqguide
run
folder: a folder of anything else at that path is refused, not removed. The model's
code is the source of the module defining its class (the whole package folder for a simulator
package such as ``uqguide.models.ftcapn``) and, for a ``callable`` model, the user function's
module, for a ``command`` model its program's file (a recompiled simulator); a code change
elsewhere (a shared helper module, a script an interpreter runs) is not seen.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import importlib
import inspect
import json
import logging
import os
import queue
import re
import shutil
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._version import __version__
from ..core.atomic import atomic_path, clean_stale_temps
from ..errors import ConfigError
from .execution import ChunkResult, Task
from .interrupts import deferred
from ..models.base import Model

log = logging.getLogger(__name__)

#: 2: a chunk's scalars, series and summary packed into one array (1: an npz entry each)
FORMAT = 2
MANIFEST = "manifest.jsonl"


class RunInterrupted(KeyboardInterrupt):
    """The run was stopped (Ctrl-C) after ``n_done`` of ``n_total`` chunks; the chunks done are
    checkpointed when the run has a run folder. A KeyboardInterrupt, so that nothing catching
    ``Exception`` swallows it."""

    def __init__(self, n_done: int, n_total: int) -> None:
        super().__init__(f"interrupted: {n_done} of {n_total} chunks done")
        self.n_done = n_done
        self.n_total = n_total


# ---------------------------------------------------------------------------- identity
def model_code_hash(model: Model) -> str:
    """SHA-256 of the source that defines ``model`` (see the module docstring).

    Parameters
    ----------
    model : Model

    Returns
    -------
    str
        Hex digest of its version and source files (a callable model's module, a command
        model's program file included).
    """
    files = _source_files(type(model))
    function = getattr(model.params, "function", None)
    if model.name == "callable" and isinstance(function, str):
        try:
            files += [Path(inspect.getfile(importlib.import_module(function.partition(":")[0])))]
        except (ImportError, TypeError, OSError):
            pass
    program = getattr(model.params, "program_file", None)
    if model.name == "command" and callable(program):
        found = program()
        if found is not None:
            files.append(found)
    h = hashlib.sha256(str(getattr(model, "version", "")).encode())
    for f in sorted(set(files)):
        h.update(f.name.encode())
        try:
            h.update(f.read_bytes())
        except OSError:
            h.update(b"<unreadable>")
    return h.hexdigest()


def _source_files(cls: type) -> list[Path]:
    try:
        path = Path(inspect.getfile(cls))
    except (TypeError, OSError):
        return []
    module = cls.__module__
    # A simulator package (uqguide.models.<pkg>.<module>) is hashed whole; a module directly
    # in uqguide.models (the benchmarks) alone, so editing one model leaves the others' runs.
    parts = module.split(".")
    if len(parts) >= 4 and parts[:2] == ["uqguide", "models"] and path.parent.name == parts[2]:
        return sorted(path.parent.glob("*.py"))
    if path.name == "__init__.py":
        return sorted(path.parent.glob("*.py"))
    return [path]


def run_identity(resolved_config: dict[str, Any], model: Model) -> dict[str, Any]:
    """What must not change between a run and its resumption, with its hash ``run_id``.

    Parameters
    ----------
    resolved_config : dict
        The config with every default filled in.
    model : Model

    Returns
    -------
    dict
        ``config``, ``uqguide`` (version), ``model``, ``model_code`` (hash) and ``run_id``.
    """
    identity = {"config": resolved_config, "uqguide": __version__, "model": model.name,
                "model_code": model_code_hash(model)}
    return {**identity, "run_id": identity_hash(identity)}


def identity_hash(identity: dict[str, Any]) -> str:
    """SHA-256 of a run identity (its canonical JSON, without a ``run_id`` key).

    Parameters
    ----------
    identity : dict

    Returns
    -------
    str
        Hex digest.
    """
    core = {k: v for k, v in identity.items() if k != "run_id"}
    text = json.dumps(core, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def run_dir(out_dir: str | Path, name: str) -> Path:
    """The run folder of the result ``<out_dir>/<name>.h5`` (ConfigError for a name that is
    not a plain file name: the folder must lie inside ``out_dir``).

    Parameters
    ----------
    out_dir : str or Path
    name : str
        The run's name.

    Returns
    -------
    Path
        ``<out_dir>/<name>.run``.
    """
    from ..config.run_config import check_run_name

    return Path(out_dir) / f"{check_run_name(name)}.run"


def _first_difference(a: Any, b: Any, path: str = "") -> str | None:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            sub = f"{path}.{k}" if path else str(k)
            if k not in a or k not in b:
                return sub
            d = _first_difference(a[k], b[k], sub)
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip(a, b)):
            d = _first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None if len(a) == len(b) else path
    return None if a == b else path


def _lookup(d: Any, path: str) -> Any:
    import re

    for part in re.findall(r"[^.\[\]]+|\[\d+\]", path):
        try:
            d = d[int(part[1:-1])] if part.startswith("[") else d[part]
        except (KeyError, IndexError, TypeError):
            return "<absent>"
    return d


# ---------------------------------------------------------------------------- the store
class RunStore:
    """A run folder (see the module docstring). Only the driver process writes it."""

    def __init__(self, path: Path, identity: dict[str, Any]) -> None:
        self.path = path
        if "run_id" not in identity:
            identity = {**identity, "run_id": identity_hash(identity)}
        self.identity = identity
        self.run_id: str = identity["run_id"]
        self._entries: dict[tuple[str, int, int], dict[str, Any]] = {}
        # bounded: a writer slower than the workers holds back the driver, not its memory
        self._queue: queue.Queue[tuple[str, int, ChunkResult] | None] = queue.Queue(maxsize=16)
        self._writer: threading.Thread | None = None
        self._error: BaseException | None = None

    # -------------------------------------------------------------- opening
    @classmethod
    def open(cls, path: str | Path, identity: dict[str, Any], resume: bool,
             resume_hint: str = "uqguide run CONFIG --resume") -> RunStore:
        """Open the run folder ``path`` for a fresh run or (``resume``) to continue it. The
        caller holds the folder's :class:`~uqguide.driver.runlock.RunLock` (``uqguide run`` does).

        Parameters
        ----------
        path : str or Path
            The run folder.
        identity : dict
            As :func:`run_identity` gives it.
        resume : bool
            Continue the run stored there.
        resume_hint : str
            The command to suggest in messages.

        Returns
        -------
        RunStore

        Raises
        ------
        ConfigError
            ``resume`` and the folder belongs to another config / code version; or not
            ``resume`` and the folder holds finished chunks (they are not thrown away silently);
            or the path is something other than a uqguide run folder (it is not deleted).
        """
        path = Path(path)
        store = cls(path, identity)
        if path.is_symlink() or (path.exists() and not path.is_dir()):
            raise ConfigError(f"{path} exists and is not a uqguide run folder; refusing to "
                              f"replace it (move it, or give this run another --out or name)",
                              field="out")
        header, entries = _read_manifest(path / MANIFEST)
        if header is not None and resume:
            store._check_same_run(header)
            store._entries = entries
            clean_stale_temps(path)
            log.info("resuming %s: %d chunks already done", path, len(entries))
            return store
        if entries and not resume:
            raise ConfigError(
                f"{path} holds an unfinished run ({len(entries)} chunks done); continue it "
                f"with `{resume_hint}`, or delete the folder to start over", field="resume")
        if resume:
            log.info("nothing to resume at %s: starting a fresh run", path)
        if path.exists():
            _remove_run_folder(path, header)
        path.mkdir(parents=True)
        store._append({"kind": "header", "format": FORMAT,
                       "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(
                           timespec="seconds"), **store.identity})
        return store

    def _check_same_run(self, header: dict[str, Any]) -> None:
        where = f"cannot resume {self.path}"
        tail = "; start over with another --out, or delete the folder"
        if header.get("format") != FORMAT:
            raise ConfigError(f"{where}: written by an incompatible uqguide (run folder "
                              f"format {header.get('format')!r}){tail}", field="resume")
        old, new = header.get("config", {}), self.identity["config"]
        diff = _first_difference(old, new)
        if diff is not None:
            raise ConfigError(
                f"{where}: the config changed since the run started ({diff}: "
                f"{_lookup(old, diff)!r} -> {_lookup(new, diff)!r}){tail}", field=diff)
        if header.get("uqguide") != self.identity["uqguide"]:
            raise ConfigError(
                f"{where}: it was started by uqguide {header.get('uqguide')}, this is "
                f"{self.identity['uqguide']}{tail}", field="resume")
        if header.get("model_code") != self.identity["model_code"]:
            raise ConfigError(
                f"{where}: the code of model '{self.identity['model']}' changed since the run "
                f"started{tail}", field="model.name")
        if header.get("run_id") != self.run_id:
            raise ConfigError(f"{where}: its run id {str(header.get('run_id'))[:12]} is not "
                              f"this run's ({self.run_id[:12]}){tail}", field="resume")

    # -------------------------------------------------------------- chunks
    @property
    def n_done(self) -> int:
        """Chunks listed in the manifest on disk: what a resume will find. Read from the file,
        not the in-memory list, because an interrupt can land between a chunk's manifest line
        and its bookkeeping here."""
        return len(_read_manifest(self.path / MANIFEST)[1])

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
                f"cannot resume {self.path}: chunk {task.index} of {label} ({e.get('file')}) "
                f"belongs to another run (run id {str(e.get('run'))[:12]}, this run "
                f"{self.run_id[:12]}); delete the folder to start over", field="resume")
        if (e["start"], e["stop"]) != (task.start, task.stop):
            log.warning("%s: chunk %d of %s has other bounds than stored; re-running it",
                        self.path, task.index, label)
            return None
        try:
            r = _read_chunk(self.path / e["file"], task)
        except ForeignChunk as exc:
            raise ConfigError(f"cannot resume {self.path}: {e['file']} {exc} (this run "
                              f"{self.run_id[:12]}, {label} stage {stage}); delete the "
                              f"folder to start over", field="resume") from None
        except (OSError, ValueError, KeyError) as exc:
            log.warning("%s: cannot read %s (%s); re-running the chunk", self.path, e["file"], exc)
            return None
        if r.run_id != self.run_id or r.label != label or r.stage != stage:
            raise ConfigError(
                f"cannot resume {self.path}: {e['file']} belongs to another run or method "
                f"(run id {r.run_id[:12]}, {r.label} stage {r.stage}; this run "
                f"{self.run_id[:12]}, {label} stage {stage}); delete the folder to start over",
                field="resume")
        return r.result

    def save(self, label: str, stage: int, result: ChunkResult) -> None:
        """Queue one chunk: a writer thread writes it atomically, then lists it in the
        manifest, chunk after chunk in the order given.

        The driver folds the next chunk while this one is fsynced (three fsyncs a chunk: 1.3 s
        of a 1e6-run study's wall time when they were in line). A chunk still queued when the
        process is killed is simply not listed, so a resume re-runs it; an error of the writer
        (a full disk) is raised by the next ``save`` or by :meth:`flush`.

        Parameters
        ----------
        label : str
        stage : int
        result : ChunkResult
        """
        self._raise_writer_error()
        if self._writer is None:
            self._writer = threading.Thread(target=self._write_loop, name="uqguide-checkpoint",
                                            daemon=True)
            self._writer.start()
        self._queue.put((label, stage, result))

    def flush(self) -> None:
        """Wait until every queued chunk is on disk and listed; raise the writer's error."""
        self.drain()
        self._raise_writer_error()

    def drain(self) -> None:
        """Wait until the writer is done with every queued chunk, raising nothing of its own
        (for a run that is stopping with an error or an interrupt). A Ctrl-C or SIGTERM while
        it waits is held until the writer is done (a few chunk writes at most): the process
        must not exit with the writer half-way through a file."""
        if self._writer is not None:
            with deferred():
                self._queue.join()

    def close(self) -> None:
        """:meth:`flush`, then end the writer thread."""
        try:
            self.flush()
        finally:
            if self._writer is not None:
                with deferred():
                    self._queue.put(None)
                    self._writer.join()
                self._writer = None

    def _raise_writer_error(self) -> None:
        if self._error is not None:
            err, self._error = self._error, None
            raise err

    def _write_loop(self) -> None:
        while True:
            item = self._queue.get()
            try:
                if item is None:
                    return
                if self._error is None:  # after a failure, nothing more: the chunks re-run
                    self._save_now(*item)
            except BaseException as exc:  # noqa: BLE001 - handed to the driver's thread
                self._error = exc
            finally:
                self._queue.task_done()

    def _save_now(self, label: str, stage: int, result: ChunkResult) -> None:
        t = result.task
        name = f"{label}.s{stage}.c{t.index:06d}.npz"
        _write_chunk(self.path / name, result, self.run_id, label, stage)
        entry = {"kind": "chunk", "run": self.run_id, "label": label, "stage": stage,
                 "index": t.index,
                 "start": t.start, "stop": t.stop, "file": name, "n_failed": result.n_failed}
        self._append(entry)
        self._entries[(label, stage, t.index)] = entry

    def remove(self) -> None:
        """Delete the folder (after the result file is written: it holds everything)."""
        self.close()
        if self.path.is_dir() and not self.path.is_symlink():
            header, _ = _read_manifest(self.path / MANIFEST)
            if header is not None and header.get("run_id") == self.run_id:
                # The manifest last: a removal cut short leaves a folder that still says whose
                # it is (its missing chunks are re-run), never anonymous chunk files.
                for p in self.path.iterdir():
                    if p.name != MANIFEST:
                        p.unlink(missing_ok=True)
                (self.path / MANIFEST).unlink(missing_ok=True)
                shutil.rmtree(self.path, ignore_errors=True)

    def _append(self, obj: dict[str, Any]) -> None:
        with open(self.path / MANIFEST, "a", encoding="utf-8") as f:
            f.write(json.dumps(obj, sort_keys=True) + "\n")
            f.flush()
            os.fsync(f.fileno())


def _read_manifest(path: Path) -> tuple[dict[str, Any] | None, dict[tuple[str, int, int], Any]]:
    """The header (the first one) and the chunk lines of a manifest. A second header of another
    run makes the header ``{"run_id": "<mixed>"}``: such a folder is never resumed."""
    if not path.is_file() or path.is_symlink():
        return None, {}
    header = None
    entries: dict[tuple[str, int, int], dict[str, Any]] = {}
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return None, {}
    for line in text.splitlines():
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            continue  # a line torn by a kill while it was appended: its chunk is re-run
        if not isinstance(obj, dict):
            continue
        if obj.get("kind") == "header":
            if header is None:
                header = obj
            elif obj.get("run_id") != header.get("run_id"):
                header = {**header, "run_id": "<mixed>", "format": header.get("format")}
        elif obj.get("kind") == "chunk":
            try:
                entries[(str(obj["label"]), int(obj["stage"]), int(obj["index"]))] = obj
            except (KeyError, TypeError, ValueError):
                continue
    return header, entries


#: What a run folder holds: anything else in it means it is not (only) ours.
_RUN_FILE = re.compile(r"^(manifest\.jsonl|[A-Za-z0-9_.\-]+\.s\d+\.c\d+\.npz|\..+\.\d+\.tmp)$")


def _remove_run_folder(path: Path, header: dict[str, Any] | None) -> None:
    """Delete a run folder, but only one that uqguide's manifest identifies and that holds
    nothing but a run folder's files; an empty folder is removed too."""
    names = [p.name for p in path.iterdir()]
    if not names:
        path.rmdir()
        return
    foreign = [n for n in names if not _RUN_FILE.match(n)]
    anonymous = (header is None or "format" not in header) and any(
        n.endswith(".npz") for n in names)  # chunk files without a manifest saying whose
    if foreign or anonymous:
        what = f"it holds {foreign[0]!r}" if foreign else "it has no uqguide manifest"
        raise ConfigError(f"{path} is not a uqguide run folder ({what}); refusing to delete "
                          f"it: move it, or give this run another --out or name", field="out")
    shutil.rmtree(path)


# ---------------------------------------------------------------------------- chunk files
class ForeignChunk(ValueError):
    """A chunk file written by another run."""


@dataclass
class _StoredChunk:
    result: ChunkResult
    run_id: str
    label: str
    stage: int


def _write_chunk(path: Path, r: ChunkResult, run_id: str, label: str, stage: int) -> None:
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
        "failed": r.failed,
        "reasons": np.array([str(v) for v in r.reasons], dtype=str),
        "time": r.time,
        "index": np.array(index), "packed": packed,
    }
    # fsynced file and folder: the rename must survive a power cut before the manifest line
    with atomic_path(path, clean=False) as tmp:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)


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


def _read_chunk(path: Path, task: Task) -> _StoredChunk:
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    if "run_id" not in data:
        raise ForeignChunk("carries no run id (written by an older uqguide or another tool)")
    if tuple(int(v) for v in data["task"]) != (task.index, task.start, task.stop):
        raise ValueError("chunk file does not match its manifest entry")
    arrays = _unpack(str(data["index"]), data["packed"])
    pick = {p: {k[len(p) + 1:]: v for k, v in arrays.items() if k.startswith(p + ".")}
            for p in ("scalar", "series", "summary")}
    return _StoredChunk(run_id=str(data["run_id"]), label=str(data["label"]),
                        stage=int(data["stage"]), result=ChunkResult(
        task=task, failed=data["failed"].astype(bool),
        reasons=np.array(data["reasons"].tolist(), dtype=object).reshape(-1),
        time=data["time"], scalars=pick["scalar"], series=pick["series"],
        summary=pick["summary"], model_seconds=float(data["model_seconds"])))
