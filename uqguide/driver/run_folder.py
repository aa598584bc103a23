"""The run folder: a run that survives a crash, a kill or Ctrl-C, and ``--resume``.

``<out>/<name>.run/`` holds ``manifest.jsonl`` (append-only and fsynced: the run's identity,
then one line per finished chunk, piece of an unfinished chunk or isolated sample) and one
``.npz`` per finished chunk or piece, written whole and renamed before its manifest line;
``<out>/<name>.run.lock`` gives the folder one owner. :class:`RunStore` is what the driver
holds: the chunks' files, the
:class:`RunManifest` (whose run the folder is, resume checks, refusals) and the
:class:`CheckpointWriter` (the background thread that writes them). :class:`RunLock` is taken
by the command before the folder is read.

Layout, guarantees and refusals: docs/scale.md, "Checkpoints and --resume".
"""

from __future__ import annotations

import datetime as _dt
import fcntl
import hashlib
import importlib
import inspect
import json
import logging
import os
import queue
import re
import socket
import threading
import zipfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, Generic, TypeVar

import numpy as np

from .._version import __version__
from ..core.atomic import (atomic_file, clean_stale_temps, disk_full_as_error, make_folder,
                           not_regular, open_writable, pid_alive, refusal, temp_owner)
from ..errors import ConfigError
from ..models.base import Model
from .execution import ChunkResult, Task
from .interrupts import deferred

log = logging.getLogger(__name__)


# ---------------------------------------------------------------------------- the lock
class RunLock:
    """The exclusive lock of the run folder ``<out>/<name>.run``; a context manager."""

    def __init__(self, run_folder: str | Path) -> None:
        self.run_folder = Path(run_folder)
        self.path = self.run_folder.with_name(self.run_folder.name + ".lock")
        self._fd: int | None = None

    def acquire(self) -> RunLock:
        """Take the lock or raise ConfigError naming its owner."""
        make_folder(self.path.parent)
        for _ in range(20):
            # A link at the lock's name must not be written through (a write outside --out),
            # nor a FIFO opened blocking: open_writable refuses both, nothing written.
            fd = open_writable(self.path, os.O_RDWR | os.O_CREAT)
            try:
                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                owner = _read_owner(fd)
                os.close(fd)
                raise ConfigError(
                    f"--out: {self.run_folder} is in use by another uqguide run ({owner}); "
                    f"wait for it to finish, or give this run another --out or name",
                    field="out") from None
            # The file may have been unlinked by its previous owner between our open and our
            # lock: then we hold a lock nobody else sees. Retry on the file now at the path.
            try:
                same = os.path.samestat(os.fstat(fd), os.stat(self.path))
            except FileNotFoundError:
                same = False
            if not same:
                os.close(fd)
                continue
            previous = _read_owner(fd)
            if previous != "owner unknown" and not _OWNER.fullmatch(previous):
                os.close(fd)  # a file of the user's at the lock's name: nothing written to it
                raise refusal(self.path, "not a uqguide lock file",
                              role="the run's lock file goes there")
            if previous != "owner unknown":
                log.warning("%s: taking over the lock of a run that is gone (%s)",
                            self.run_folder, previous)
            try:
                with disk_full_as_error(self.path):
                    os.ftruncate(fd, 0)
                    os.write(fd, f"pid {os.getpid()} on host {socket.gethostname()}\n".encode())
                    os.fsync(fd)
            except BaseException:
                self.path.unlink(missing_ok=True)  # still locked: no one holds this inode
                os.close(fd)
                raise
            self._fd = fd
            return self
        raise ConfigError(f"--out: cannot lock {self.run_folder} (the lock file keeps "
                          f"changing)", field="out")  # pragma: no cover

    def release(self) -> None:
        if self._fd is None:
            return
        try:
            self.path.unlink(missing_ok=True)  # while still locked: no one holds the old inode
        finally:
            os.close(self._fd)
            self._fd = None

    def __enter__(self) -> RunLock:
        return self.acquire()

    def __exit__(self, *exc: object) -> None:
        self.release()


#: What a lock file holds (:meth:`RunLock.acquire` writes it): anything else is not one.
_OWNER = re.compile(r"pid \d+ on host \S*")


def _read_owner(fd: int) -> str:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        text = os.read(fd, 4096).decode("utf-8", "replace").strip()
    except OSError:
        text = ""
    return text or "owner unknown"


# ---------------------------------------------------------------- the run's identity
#: 2: a chunk's scalars, series and summary packed into one array (1: an npz entry each)
FORMAT = 2
MANIFEST = "manifest.jsonl"

#: A chunk line's key: the method's label, the design stage and the chunk index.
ChunkKey = tuple[str, int, int]
#: The lines of the pieces of a chunk (:mod:`uqguide.driver.chunk_pieces`) by their first row.
PieceLines = dict[int, dict[str, Any]]


def model_code_hash(model: Model) -> str:
    """SHA-256 hex digest of the version and the source that defines ``model``: its class's
    module (a simulator package's whole folder), a ``callable``'s module, a ``command``'s program
    or the ``fmu`` file. A change in a shared helper module elsewhere is not seen."""
    files = _source_files(type(model))
    function = getattr(model.params, "function", None)
    if model.name == "callable" and isinstance(function, str):
        try:
            files += [Path(inspect.getfile(importlib.import_module(function.partition(":")[0])))]
        except (ImportError, TypeError, OSError):
            pass
    program = getattr(model.params, "program_file", None)
    if model.name in ("command", "fmu") and callable(program):
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
    # A simulator package (uqguide.models.<pkg>.<module>) is hashed whole; a module directly
    # in uqguide.models (the benchmarks) alone, so editing one model leaves the others' runs.
    parts = cls.__module__.split(".")
    package = len(parts) >= 4 and parts[:2] == ["uqguide", "models"] and \
        path.parent.name == parts[2]
    return sorted(path.parent.glob("*.py")) if package or path.name == "__init__.py" else [path]


def run_identity(resolved_config: dict[str, Any], model: Model) -> dict[str, Any]:
    """What must not change between a run and its resumption: ``config`` (every default filled
    in), ``uqguide`` (version), ``model``, ``model_code`` (hash) and its hash ``run_id``."""
    identity = {"config": study_config(resolved_config), "uqguide": __version__,
                "model": model.name,
                "model_code": model_code_hash(model)}
    return {**identity, "run_id": identity_hash(identity)}


#: Settings of the model section that decide how its calls run, never their numbers: a run
#: may be resumed, or its result replaced, with them changed.
EXECUTION_ONLY = ("isolate",)


def study_config(resolved_config: dict[str, Any]) -> dict[str, Any]:
    """The resolved config less :data:`EXECUTION_ONLY`: what two runs of one study share."""
    model = resolved_config.get("model")
    if not isinstance(model, dict) or not any(k in model for k in EXECUTION_ONLY):
        return resolved_config
    return {**resolved_config,
            "model": {k: v for k, v in model.items() if k not in EXECUTION_ONLY}}


def identity_hash(identity: dict[str, Any]) -> str:
    """SHA-256 hex digest of a run identity (its canonical JSON, without a ``run_id`` key)."""
    core = {k: v for k, v in identity.items() if k != "run_id"}
    text = json.dumps(core, sort_keys=True, default=str, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()


def _first_difference(a: Any, b: Any, path: str = "") -> tuple[str, Any, Any] | None:
    """Where ``a`` and ``b`` first differ: the path and the two values there."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in list(a) + [k for k in b if k not in a]:
            d = _first_difference(a.get(k, "<absent>"), b.get(k, "<absent>"),
                                  f"{path}.{k}" if path else str(k))
            if d:
                return d
        return None
    if isinstance(a, list) and isinstance(b, list):
        for i, (x, y) in enumerate(zip(a, b)):
            d = _first_difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None if len(a) == len(b) else (path, a, b)
    return None if a == b else (path, a, b)


# ---------------------------------------------------------------------------- the manifest
class RunManifest:
    """The manifest of the run folder ``folder`` for the run ``identity`` (as
    :func:`run_identity` gives it, or without ``run_id``: it is then computed)."""

    def __init__(self, folder: Path, identity: dict[str, Any]) -> None:
        self.folder = folder
        if "run_id" not in identity:
            identity = {**identity, "run_id": identity_hash(identity)}
        self.identity = identity
        self.run_id: str = identity["run_id"]
        # the checkpoint writer's thread appends chunk lines, the driver isolated samples
        self._append_lock = threading.Lock()
        self._chunk_re: re.Pattern[str] | None = None

    @property
    def file(self) -> Path:
        return self.folder / MANIFEST

    def read(self) -> tuple[dict[str, Any] | None, dict[ChunkKey, dict[str, Any]]]:
        """The first header on disk (None without one) and the chunk lines by (label, stage,
        index), the last winning; a second header of another run makes the run id
        ``"<mixed>"`` (never resumed)."""
        header = None
        entries: dict[ChunkKey, dict[str, Any]] = {}
        for obj in _manifest_objects(self.file):
            if obj.get("kind") == "header":
                if header is None:
                    header = obj
                elif obj.get("run_id") != header.get("run_id"):
                    header = {**header, "run_id": "<mixed>", "format": header.get("format")}
            elif obj.get("kind") == "complete":
                if header is not None and obj.get("run") == header.get("run_id"):
                    header = {**header, "complete": True}
            elif obj.get("kind") == "chunk":
                try:
                    entries[(str(obj["label"]), int(obj["stage"]), int(obj["index"]))] = obj
                except (KeyError, TypeError, ValueError):
                    continue
        return header, entries

    def pieces(self) -> dict[ChunkKey, PieceLines]:
        """This run's pieces of chunks by (label, stage, chunk index), the last line of a piece
        winning (those of chunks since finished included)."""
        out: dict[ChunkKey, PieceLines] = {}
        for obj in _manifest_objects(self.file):
            if obj.get("kind") != "piece" or obj.get("run") != self.run_id:
                continue
            try:
                key = (str(obj["label"]), int(obj["stage"]), int(obj["index"]))
                start, stop = int(obj["start"]), int(obj["stop"])
            except (KeyError, TypeError, ValueError):
                continue  # a malformed line: its rows run again
            if start < stop:
                out.setdefault(key, {})[start] = obj
        return out

    def listed_files(self) -> set[str]:
        """The files the manifest lists: chunks' and pieces'."""
        return {str(e.get("file")) for e in self.read()[1].values()} | \
            {str(e.get("file")) for lines in self.pieces().values() for e in lines.values()}

    def isolated(self) -> dict[tuple[str, int], dict[int, str]]:
        """This run's samples found to crash or hang, by (label, stage): row -> reason."""
        out: dict[tuple[str, int], dict[int, str]] = {}
        for obj in _manifest_objects(self.file):
            if obj.get("kind") != "isolated" or obj.get("run") != self.run_id:
                continue
            try:
                key = (str(obj["label"]), int(obj["stage"]))
                out.setdefault(key, {})[int(obj["row"])] = str(obj["reason"])
            except (KeyError, TypeError, ValueError):
                continue  # a malformed line: that sample runs again, isolated again
        return out

    def record_isolated(self, label: str, stage: int, row: int, reason: str) -> None:
        """List a sample that crashed or hung its process, with its design row and reason."""
        self.append({"kind": "isolated", "run": self.run_id, "label": label, "stage": stage,
                     "row": row, "reason": reason})

    def start(self) -> None:
        """Write the header of a fresh run (the folder exists and is empty)."""
        self.append({"kind": "header", "format": FORMAT,
                     "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(
                         timespec="seconds"), **self.identity})

    def append(self, obj: dict[str, Any]) -> None:
        """Append one line, fsynced before returning: once listed, it survives a power cut.

        A line the disk had no room for is taken back whole (the file keeps its lines, and
        the next one does not join a torn one); the error is :class:`DiskFull`."""
        line = (json.dumps(obj, sort_keys=True) + "\n").encode("utf-8")
        with self._append_lock, disk_full_as_error(self.file):
            fd = open_writable(self.file, os.O_WRONLY | os.O_CREAT | os.O_APPEND)
            try:
                end = os.lseek(fd, 0, os.SEEK_END)
                try:
                    done = 0
                    while done < len(line):
                        done += os.write(fd, line[done:])
                    os.fsync(fd)
                except OSError:
                    os.ftruncate(fd, end)
                    raise
            finally:
                os.close(fd)

    def check_same_run(self, header: dict[str, Any]) -> None:
        """ConfigError naming what differs when ``header`` (the manifest's first line on disk) is
        not this run's: the stored chunks would mix two experiments."""
        where = f"cannot resume {self.folder}"
        tail = "; start over with another --out, or delete the folder"
        if header.get("format") != FORMAT:
            raise ConfigError(f"{where}: written by an incompatible uqguide (run folder "
                              f"format {header.get('format')!r}){tail}", field="resume")
        diff = _first_difference(header.get("config", {}), self.identity["config"])
        if diff is not None:
            path, old, new = diff
            raise ConfigError(f"{where}: the config changed since the run started ({path}: "
                              f"{old!r} -> {new!r}){tail}", field=path)
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

    def check_names(self, resume: bool) -> None:
        """ConfigError, before the folder is read, for a name the run uses that is not a regular
        file (a FIFO or device would block, a link or folder be written through), a file named
        like a chunk that is not one, and on ``resume`` a hard-linked manifest (the appended
        lines would reach the other name too)."""
        what = not_regular(self.file, hard_links=resume)
        if what:
            raise refusal(self.file, what, role="the run's manifest goes there")
        listed = self.listed_files()
        for name in sorted(os.listdir(self.folder)):
            if name not in listed and not self._chunk_name(name):
                continue
            p = self.folder / name
            what = not_regular(p, hard_links=False)
            if not what and name not in listed and not _is_chunk_file(p):
                what = "not a uqguide chunk file"
            if what:
                raise refusal(p, what, role="a chunk file of this run goes there")

    def _chunk_name(self, name: str) -> bool:
        """Whether ``name`` is the name of a chunk file of one of this run's methods."""
        if self._chunk_re is None:
            labels = [m.get("label") for m in self.identity.get("config", {}).get("methods", [])
                      if isinstance(m, dict) and isinstance(m.get("label"), str)]
            self._chunk_re = re.compile("|".join(
                rf"{re.escape(str(lab))}\.s\d+\.c\d{{6,}}(\.r\d+)?\.npz" for lab in labels)
                or "(?!)")
        return self._chunk_re.fullmatch(name) is not None

    def clear(self, header: dict[str, Any] | None, known: bool = False) -> list[str]:
        """Before a fresh run: delete what uqguide left in the folder (:meth:`_ours`), leave and
        return the rest, named in a warning. A folder without a uqguide ``header`` is a run
        folder only when it holds nothing else or is ``known`` (this run's, its files removed a
        moment ago): else ConfigError, nothing deleted."""
        names = sorted(p.name for p in self.folder.iterdir())
        listed = self.listed_files()
        ours = [n for n in names if n != MANIFEST and self._ours(self.folder / n, listed)]
        left = [n for n in names if n != MANIFEST and n not in ours]
        identified = known or (header is not None and "format" in header)
        if not identified:
            anonymous = [n for n in ours if temp_owner(n) is None]  # chunks without a manifest
            foreign = left + ([] if self._torn_manifest() else [MANIFEST])
            if foreign or anonymous:
                what = f"it holds {foreign[0]!r}" if foreign else "it has no uqguide manifest"
                raise ConfigError(f"{self.folder} is not a uqguide run folder ({what}); refusing "
                                  f"to delete it: move it, or give this run another --out or "
                                  f"name", field="out")
        for n in ours:
            (self.folder / n).unlink(missing_ok=True)
        self.file.unlink(missing_ok=True)
        if left:
            _warn_left(self.folder, left)
        else:
            self.folder.rmdir()
        return left

    def _torn_manifest(self) -> bool:
        """Whether the manifest on disk is absent, empty or the start of a uqguide header (a
        kill while it was first written), i.e. uqguide's own."""
        try:
            with open(self.file, "rb") as f:
                head = f.read(len(_HEADER_START))
        except FileNotFoundError:
            return True
        except OSError:
            return False
        return _HEADER_START.startswith(head)

    def _ours(self, path: Path, listed: set[str]) -> bool:
        """Whether ``path`` is uqguide's to delete: a regular file the manifest lists, a
        temporary file of a writer that is gone, or a chunk file of this run that says so inside
        (a kill between the file and its manifest line leaves it unlisted)."""
        if not path.exists() or not_regular(path, hard_links=False):
            return False
        if path.name in listed:
            return True
        pid = temp_owner(path.name)
        if pid is not None:
            return pid == os.getpid() or not pid_alive(pid)
        return self._chunk_name(path.name) and _is_chunk_file(path)

    def remove(self) -> list[str]:
        """Delete this run's files, then the folder, when its manifest says it is this run's;
        anything else is left, named in a warning, and returned. The manifest goes last, and
        stays while anything of the run's is left, so the folder still says whose it is."""
        if not self.folder.is_dir() or self.folder.is_symlink():
            return []
        header, entries = self.read()
        if header is None or header.get("run_id") != self.run_id:
            return []
        listed = self.listed_files()
        left: list[str] = []
        ours_left = False
        for p in sorted(self.folder.iterdir()):
            if p.name == MANIFEST:
                continue
            if self._ours(p, listed):
                try:
                    p.unlink()
                    continue
                except OSError:
                    ours_left = True
            left.append(p.name)
        if not ours_left:
            self.file.unlink(missing_ok=True)
        if left:
            _warn_left(self.folder, left)
            return left
        try:
            self.folder.rmdir()
        except OSError:  # something appeared meanwhile: it is not ours to delete
            return [p.name for p in self.folder.iterdir()]
        return []


def _warn_left(folder: Path, left: list[str]) -> None:
    log.warning("%s: left in place, not written by this run: %s%s", folder, ", ".join(left[:3]),
                f" and {len(left) - 3} more" if len(left) > 3 else "")


#: How every manifest begins (its header, keys sorted): a file starting otherwise is not one.
_HEADER_START = b'{"config": '


def _is_chunk_file(path: Path) -> bool:
    """Whether ``path`` (a regular file) is a chunk file of uqguide's: an npz with a run id."""
    try:
        with zipfile.ZipFile(path) as z:
            return {"run_id.npy", "packed.npy", "index.npy"} <= set(z.namelist())
    except (OSError, zipfile.BadZipFile, ValueError):
        return False


def _manifest_objects(path: Path) -> Iterator[dict[str, Any]]:
    """The manifest's lines that are JSON objects, none from a file that cannot be read; a line
    torn by a kill while it was appended is skipped (what it listed runs again)."""
    if not path.is_file() or path.is_symlink():
        return
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return
    for line in text.splitlines():
        try:
            obj = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(obj, dict):
            yield obj


# ---------------------------------------------------------------------------- chunk files
class ForeignChunk(ValueError):
    """A chunk file written by another run."""


def write_chunk(path: Path, r: ChunkResult, run_id: str, label: str, stage: int) -> None:
    """Write one chunk's file at ``path``, whole or not at all, fsynced with its folder."""
    # The scalars, series and summary go packed into one byte array with a JSON index: one zip
    # entry per small array was the driver's largest cost (docs/scale.md).
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
    with atomic_file(path, clean=False) as f:
        np.savez(f, **arrays)


def read_chunk(path: Path, task: Task) -> tuple[tuple[str, str, int], ChunkResult]:
    """Read back the chunk file of ``task``: whose it says it is (run id, label, stage) and its
    result. ForeignChunk when it carries no run id; ValueError, KeyError or OSError when it is
    not the chunk's or not readable."""
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    if "run_id" not in data:
        raise ForeignChunk("carries no run id (written by an older uqguide or another tool)")
    if tuple(int(v) for v in data["task"]) != (task.index, task.start, task.stop):
        raise ValueError("chunk file does not match its manifest entry")
    arrays = _unpack(str(data["index"]), data["packed"])
    pick = {p: {k[len(p) + 1:]: v for k, v in arrays.items() if k.startswith(p + ".")}
            for p in ("scalar", "series", "summary")}
    whose = (str(data["run_id"]), str(data["label"]), int(data["stage"]))
    return whose, ChunkResult(
        task=task, failed=data["failed"].astype(bool),
        reasons=np.array(data["reasons"].tolist(), dtype=object).reshape(-1),
        time=data["time"], scalars=pick["scalar"], series=pick["series"],
        summary=pick["summary"], model_seconds=float(data["model_seconds"]),
        # (a chunk written before CPU seconds were kept: 0)
        cpu_seconds=float(data.get("cpu_seconds", 0.0)))


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


# ---------------------------------------------------------------------------- the writer thread
Item = TypeVar("Item")


class CheckpointWriter(Generic[Item]):
    """Calls ``write(item)`` on a thread of its own for each item :meth:`put`, one after the
    other in the order given.

    The first error of ``write`` (a full disk) is raised by the next :meth:`put` or by
    :meth:`flush`; the items queued after it are dropped (their chunks re-run on resume).
    ``maxsize`` items are queued at most: a writer slower than the workers holds back the
    driver, not its memory.
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
        """Wait until every queued item is written, raising nothing of the writer's (for a run
        that is stopping); a signal meanwhile is held: the process must not exit half-way
        through a file."""
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


# ---------------------------------------------------------------------------- the store
class RunInterrupted(KeyboardInterrupt):
    """The run was stopped (Ctrl-C) after ``n_done`` of ``n_total`` chunks, ``in_pieces`` runs
    of unfinished chunks kept besides; a KeyboardInterrupt, so that nothing catching
    ``Exception`` swallows it."""

    def __init__(self, n_done: int, n_total: int, in_pieces: int = 0) -> None:
        super().__init__(f"interrupted: {kept_text(n_done, n_total, in_pieces)}")
        self.n_done = n_done
        self.n_total = n_total
        self.in_pieces = in_pieces


def kept_text(n_done: int, n_total: int | None, in_pieces: int = 0) -> str:
    """``2 of 10 chunks done``, with ``and 500 runs of unfinished chunks`` when pieces of
    chunks are kept too."""
    of = f" of {n_total}" if n_total is not None else ""
    more = f" and {in_pieces:,} runs of unfinished chunks" if in_pieces else ""
    return f"{n_done}{of} chunks done{more}"


def _runs_in_pieces(pieces: dict[ChunkKey, PieceLines],
                    chunks: dict[ChunkKey, dict[str, Any]]) -> int:
    """Runs held by the pieces of chunks not listed as done."""
    return sum(int(e["stop"]) - int(e["start"]) for key, lines in pieces.items()
               if key not in chunks for e in lines.values())


def run_dir(out_dir: str | Path, name: str) -> Path:
    """The run folder ``<out_dir>/<name>.run`` of ``<out_dir>/<name>.h5`` (ConfigError for a
    name that is not a plain file name)."""
    from ..config.run_config import check_run_name

    return Path(out_dir) / f"{check_run_name(name)}.run"


class RunStore:
    """A run folder with the run's identity (:func:`run_identity`); only the driver writes it.
    A stored chunk of another run is refused."""

    def __init__(self, path: Path, identity: dict[str, Any]) -> None:
        self.path = path
        self.manifest = RunManifest(path, identity)
        self.run_id = self.manifest.run_id
        #: The manifest's chunk lines by (label, stage, index).
        self.entries: dict[ChunkKey, dict[str, Any]] = {}
        self.writer: CheckpointWriter[tuple[str, int, ChunkResult, bool]] = \
            CheckpointWriter(self._save_now)
        #: Samples found to crash or hang their process, by (label, stage): row -> reason.
        self.isolated: dict[tuple[str, int], dict[int, str]] = {}
        #: The manifest's piece lines of chunks not listed as done.
        self.pieces: dict[ChunkKey, PieceLines] = {}

    @classmethod
    def open(cls, path: str | Path, identity: dict[str, Any], resume: bool,
             resume_hint: str = "uqguide run CONFIG --resume") -> RunStore:
        """Open the run folder ``path`` (the caller holds its :class:`RunLock`) for a fresh run
        or to ``resume`` it; ``resume_hint``: the command suggested in messages. ConfigError
        for a folder of another run on resume, finished chunks without resume, or a path that
        is not a uqguide run folder (it is not deleted)."""
        path = Path(path)
        store = cls(path, identity)
        if path.is_symlink() or (path.exists() and not path.is_dir()):
            raise ConfigError(f"{path} exists and is not a uqguide run folder; refusing to "
                              f"replace it (move it, or give this run another --out or name)",
                              field="out")
        if path.is_dir():
            store.manifest.check_names(resume)
        header, entries = store.manifest.read()
        if header is not None and resume:
            store.manifest.check_same_run(header)
            store.entries = dict(entries)
            store.pieces = {k: v for k, v in store.manifest.pieces().items()
                            if k not in entries}
            store.isolated = store.manifest.isolated()
            clean_stale_temps(path)
            log.info("resuming %s: %d chunks already done", path, len(entries))
            return store
        if header is not None and header.get("complete") and not resume \
                and header.get("run_id") == store.run_id:
            # This very run finished its chunks and was stopped while writing its result:
            # start it afresh (same numbers) rather than call it unfinished.
            log.info("%s: a finished run of this config, stopped while writing; running it "
                     "again", path)
            store.manifest.remove()
            known = True
            header, entries = store.manifest.read()
        else:
            known = False
        in_pieces = _runs_in_pieces(store.manifest.pieces(), entries) if header else 0
        if (entries or in_pieces) and not resume:
            raise ConfigError(
                f"{path} holds an unfinished run ({kept_text(len(entries), None, in_pieces)}); "
                f"continue it "
                f"with `{resume_hint}`, or delete the folder to start over", field="resume")
        if resume:
            log.info("nothing to resume at %s: starting a fresh run", path)
        if path.exists():
            store.manifest.clear(header, known)
        make_folder(path)
        store.manifest.start()
        return store

    @property
    def n_done(self) -> int:
        """Chunks listed in the manifest on disk: what a resume will find. Read from the file,
        not the in-memory list, because an interrupt can land between a chunk's manifest line
        and its bookkeeping here."""
        return len(self.manifest.read()[1])

    @property
    def n_in_pieces(self) -> int:
        """Runs of unfinished chunks listed in the manifest on disk (as :attr:`n_done`)."""
        return _runs_in_pieces(self.manifest.pieces(), self.manifest.read()[1])

    def known_isolated(self, label: str, stage: int) -> dict[int, str]:
        """Design rows of a stage known to crash or hang their process, with the reason."""
        return dict(self.isolated.get((label, stage), {}))

    def record_isolated(self, label: str, stage: int, row: int, reason: str) -> None:
        """List at once a sample (its ``row`` in the stage's design) that crashed or hung its
        process: a resume fails it with ``reason`` instead of running it again."""
        self.isolated.setdefault((label, stage), {})[row] = reason
        self.manifest.record_isolated(label, stage, row, reason)

    def load(self, label: str, stage: int, task: Task) -> ChunkResult | None:
        """The stored result of a chunk, or None; ConfigError for a chunk of another run."""
        e = self.entries.get((label, stage, task.index))
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
        return self._read(label, stage, task, e)

    def _read(self, label: str, stage: int, task: Task, e: dict[str, Any]
              ) -> ChunkResult | None:
        """The chunk or piece file of the manifest line ``e``, or None when unreadable."""
        try:
            (run_id, stored_label, stored_stage), r = read_chunk(self.path / e["file"], task)
        except ForeignChunk as exc:
            raise ConfigError(f"cannot resume {self.path}: {e['file']} {exc} (this run "
                              f"{self.run_id[:12]}, {label} stage {stage}); delete the "
                              f"folder to start over", field="resume") from None
        except (OSError, ValueError, KeyError) as exc:
            log.warning("%s: cannot read %s (%s); re-running its runs", self.path, e["file"],
                        exc)
            return None
        if (run_id, stored_label, stored_stage) != (self.run_id, label, stage):
            raise ConfigError(
                f"cannot resume {self.path}: {e['file']} belongs to another run or method "
                f"(run id {run_id[:12]}, {stored_label} stage {stored_stage}; this run "
                f"{self.run_id[:12]}, {label} stage {stage}); delete the folder to start over",
                field="resume")
        return r

    def load_pieces(self, label: str, stage: int, task: Task) -> list[ChunkResult]:
        """The stored pieces of the unfinished chunk ``task`` (those readable, in row order);
        ConfigError for a piece of another run."""
        out = []
        for start, e in sorted(self.pieces.get((label, stage, task.index), {}).items()):
            piece = Task(task.index, start, int(e["stop"]))
            if not task.start <= piece.start < piece.stop <= task.stop:
                continue  # (bounds of another split: those rows run again)
            r = self._read(label, stage, piece, e)
            if r is not None:
                out.append(r)
        return out

    def save(self, label: str, stage: int, result: ChunkResult, piece: bool = False) -> None:
        """Queue one chunk (or ``piece`` of one) for the writer thread
        (:class:`CheckpointWriter`): its file, then its manifest line; a chunk's pieces are
        deleted once it is listed."""
        self.writer.put((label, stage, result, piece))

    def close(self) -> None:
        self.writer.close()

    def mark_complete(self) -> None:
        """Say that every chunk of the run is done: a folder left by an interrupt in the final
        write is then recognised as a finished run, not an unfinished one."""
        self.close()
        self.manifest.append({"kind": "complete", "run": self.run_id})

    def remove(self) -> list[str]:
        """Delete the run's files and the folder once the result file holds everything."""
        self.close()
        return self.manifest.remove()

    def _save_now(self, item: tuple[str, int, ChunkResult, bool]) -> None:
        # The file first, then its line: a chunk listed in the manifest is whole on disk.
        label, stage, result, piece = item
        t = result.task
        key = (label, stage, t.index)
        # named after its label, stage (0: the initial design, then one per refinement), index
        # (and a piece after its first row)
        file = f"{label}.s{stage}.c{t.index:06d}" + (f".r{t.start:09d}" if piece else "") + \
            ".npz"
        entry = {"kind": "piece" if piece else "chunk", "run": self.run_id, "label": label,
                 "stage": stage, "index": t.index, "start": t.start, "stop": t.stop,
                 "file": file, "n_failed": result.n_failed}
        write_chunk(self.path / file, result, self.run_id, label, stage)
        self.manifest.append(entry)
        if piece:
            self.pieces.setdefault(key, {})[t.start] = entry
            return
        self.entries[key] = entry
        # its pieces are not needed any more (a kill before this leaves them listed: a resume
        # takes the chunk, the cleanup deletes them)
        for e in self.pieces.pop(key, {}).values():
            (self.path / str(e["file"])).unlink(missing_ok=True)
