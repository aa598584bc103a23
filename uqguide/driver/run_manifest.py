"""The manifest of a run folder: which run the folder belongs to, and which chunks it holds.

``manifest.jsonl`` is append-only, one JSON object a line, flushed and fsynced: line 1 is the
run's identity (resolved config, uqguide version, model name and a hash of its code, and
``run_id``, the SHA-256 of that identity); then one line per finished chunk (see
:mod:`uqguide.driver.chunk_store`), and one per sample found to crash or hang its process
(``kind: isolated``, with the design row and the reason), written as soon as it is found so
that a resume of a run stopped in the middle of that chunk fails it without running it
again. A torn last line (killed while appending) is ignored.

Here are the checks that keep two experiments apart: a resumed run must have the identity of
the run that started the folder (else a refusal naming what changed), and a folder is deleted
only when its manifest says it is a uqguide run folder. The model's code is the source of the
module defining its class (the whole package folder for a simulator package such as
``uqguide.models.ftcapn``) and, for a ``callable`` model, the user function's module, for a
``command`` model its program's file, for an ``fmu`` model the FMU file; a code change
elsewhere (a shared helper module) is not seen.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import importlib
import inspect
import json
import logging
import os
import re
import shutil
import threading
from pathlib import Path
from typing import Any

from .._version import __version__
from ..errors import ConfigError
from ..models.base import Model

log = logging.getLogger(__name__)

#: 2: a chunk's scalars, series and summary packed into one array (1: an npz entry each)
FORMAT = 2
MANIFEST = "manifest.jsonl"

#: A chunk line's key: the method's label, the design stage and the chunk index.
ChunkKey = tuple[str, int, int]


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
        model's program file, an fmu model's FMU file included: a recompiled simulator is
        another model).
    """
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
    identity = {"config": study_config(resolved_config), "uqguide": __version__,
                "model": model.name,
                "model_code": model_code_hash(model)}
    return {**identity, "run_id": identity_hash(identity)}


#: Settings of the model section that decide how its calls run, never their numbers: a run
#: may be resumed, or its result replaced, with them changed.
EXECUTION_ONLY = ("isolate",)


def study_config(resolved_config: dict[str, Any]) -> dict[str, Any]:
    """The resolved config less the settings that change only how the model runs
    (:data:`EXECUTION_ONLY`): what two runs must share to be the same study.

    Parameters
    ----------
    resolved_config : dict

    Returns
    -------
    dict
        A copy without ``model.isolate``.
    """
    model = resolved_config.get("model")
    if not isinstance(model, dict) or not any(k in model for k in EXECUTION_ONLY):
        return resolved_config
    return {**resolved_config,
            "model": {k: v for k, v in model.items() if k not in EXECUTION_ONLY}}


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
    for part in re.findall(r"[^.\[\]]+|\[\d+\]", path):
        try:
            d = d[int(part[1:-1])] if part.startswith("[") else d[part]
        except (KeyError, IndexError, TypeError):
            return "<absent>"
    return d


# ---------------------------------------------------------------------------- the manifest
class RunManifest:
    """The manifest of the run folder ``folder`` for the run ``identity`` (as
    :func:`run_identity` gives it, or without ``run_id``: it is then computed).

    Parameters
    ----------
    folder : Path
        The run folder.
    identity : dict
        The identity of this run.
    """

    def __init__(self, folder: Path, identity: dict[str, Any]) -> None:
        self.folder = folder
        if "run_id" not in identity:
            identity = {**identity, "run_id": identity_hash(identity)}
        self.identity = identity
        self.run_id: str = identity["run_id"]
        # the checkpoint writer's thread appends chunk lines, the driver isolated samples
        self._append_lock = threading.Lock()

    @property
    def file(self) -> Path:
        return self.folder / MANIFEST

    def read(self) -> tuple[dict[str, Any] | None, dict[ChunkKey, dict[str, Any]]]:
        """The header and the chunk lines on disk (see :func:`read_manifest`)."""
        return read_manifest(self.file)

    def isolated(self) -> dict[tuple[str, int], dict[int, str]]:
        """The samples of this run found to crash or hang their process, by (label, stage):
        design row -> reason."""
        out: dict[tuple[str, int], dict[int, str]] = {}
        if not self.file.is_file() or self.file.is_symlink():
            return out
        try:
            text = self.file.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError):
            return out
        for line in text.splitlines():
            try:
                obj = json.loads(line)
                if not isinstance(obj, dict) or obj.get("kind") != "isolated" or \
                        obj.get("run") != self.run_id:
                    continue
                key = (str(obj["label"]), int(obj["stage"]))
                out.setdefault(key, {})[int(obj["row"])] = str(obj["reason"])
            except (json.JSONDecodeError, KeyError, TypeError, ValueError):
                continue  # a torn line: that sample runs again, isolated again
        return out

    def record_isolated(self, label: str, stage: int, row: int, reason: str) -> None:
        """List a sample that crashed or hung its process (see the module docstring)."""
        self.append({"kind": "isolated", "run": self.run_id, "label": label, "stage": stage,
                     "row": row, "reason": reason})

    def n_chunks(self) -> int:
        """Chunk lines on disk: what a resume will find."""
        return len(self.read()[1])

    def start(self) -> None:
        """Write the header of a fresh run (the folder exists and is empty)."""
        self.append({"kind": "header", "format": FORMAT,
                     "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(
                         timespec="seconds"), **self.identity})

    def append(self, obj: dict[str, Any]) -> None:
        """Append one line, fsynced before returning: once listed, it survives a power cut."""
        with self._append_lock, open(self.file, "a", encoding="utf-8") as f:
            f.write(json.dumps(obj, sort_keys=True) + "\n")
            f.flush()
            os.fsync(f.fileno())

    def check_same_run(self, header: dict[str, Any]) -> None:
        """ConfigError naming what differs when ``header`` is not this run's: the stored chunks
        would mix two experiments.

        Parameters
        ----------
        header : dict
            The first line of the manifest on disk.
        """
        where = f"cannot resume {self.folder}"
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

    def clear(self, header: dict[str, Any] | None) -> None:
        """Delete the folder before a fresh run, but only one that a uqguide manifest
        identifies and that holds nothing but a run folder's files; an empty folder is removed
        too. ConfigError (nothing deleted) for anything else.

        Parameters
        ----------
        header : dict or None
            The header on disk (None: no readable manifest).
        """
        names = [p.name for p in self.folder.iterdir()]
        if not names:
            self.folder.rmdir()
            return
        foreign = [n for n in names if not _RUN_FILE.match(n)]
        anonymous = (header is None or "format" not in header) and any(
            n.endswith(".npz") for n in names)  # chunk files without a manifest saying whose
        if foreign or anonymous:
            what = f"it holds {foreign[0]!r}" if foreign else "it has no uqguide manifest"
            raise ConfigError(f"{self.folder} is not a uqguide run folder ({what}); refusing to "
                              f"delete it: move it, or give this run another --out or name",
                              field="out")
        shutil.rmtree(self.folder)

    def mark_complete(self) -> None:
        """Say that every chunk of the run is done: a folder left by an interrupt in the final
        write is then recognised as a finished run, not an unfinished one."""
        self.append({"kind": "complete", "run": self.run_id})

    def _ours(self, name: str, listed: set[str]) -> bool:
        """Whether ``name`` in the folder is a file this run wrote: a chunk the manifest lists,
        or a chunk (or its temporary file) named for one of this run's method labels, which a
        kill between the file and its manifest line leaves unlisted."""
        if name in listed:
            return True
        labels = [m.get("label") for m in self.identity.get("config", {}).get("methods", [])
                  if isinstance(m, dict) and isinstance(m.get("label"), str)]
        return any(re.fullmatch(rf"\.?{re.escape(str(lab))}\.s\d+\.c\d+\.npz(\.\d+\.tmp)?",
                                name) for lab in labels)

    def remove(self) -> list[str]:
        """Delete this run's files and then the folder, when its manifest says it is this run's
        (after the result file is written: it holds everything). Only files the run wrote are
        deleted; anything else (a user's notes, a sub-folder) is left where it is, named in a
        warning, and never stops the run. The manifest goes last, and stays while anything of
        the run's is left, so the folder still says whose it is.

        Returns
        -------
        list of str
            The names left in the folder (empty: the folder is gone).
        """
        if not self.folder.is_dir() or self.folder.is_symlink():
            return []
        header, entries = self.read()
        if header is None or header.get("run_id") != self.run_id:
            return []
        listed = {str(e.get("file")) for e in entries.values()}
        left: list[str] = []
        ours_left = False
        for p in sorted(self.folder.iterdir()):
            if p.name == MANIFEST:
                continue
            if self._ours(p.name, listed) and p.is_file() and not p.is_symlink():
                try:
                    p.unlink()
                    continue
                except OSError:
                    ours_left = True
            left.append(p.name)
        if not ours_left:
            self.file.unlink(missing_ok=True)
        if left:
            log.warning("%s: left in place, not written by this run: %s%s", self.folder,
                        ", ".join(left[:3]), f" and {len(left) - 3} more" if len(left) > 3
                        else "")
            return left
        try:
            self.folder.rmdir()
        except OSError:  # something appeared meanwhile: it is not ours to delete
            return [p.name for p in self.folder.iterdir()]
        return []


def read_manifest(path: Path) -> tuple[dict[str, Any] | None, dict[ChunkKey, dict[str, Any]]]:
    """The header (the first one) and the chunk lines of a manifest. A second header of another
    run makes the header ``{"run_id": "<mixed>"}``: such a folder is never resumed.

    Parameters
    ----------
    path : Path
        The manifest file.

    Returns
    -------
    header : dict or None
        None when there is no readable manifest.
    entries : dict
        Chunk lines by (label, stage, index); the last line of a chunk wins.
    """
    if not path.is_file() or path.is_symlink():
        return None, {}
    header = None
    entries: dict[ChunkKey, dict[str, Any]] = {}
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
        elif obj.get("kind") == "complete":
            if header is not None and obj.get("run") == header.get("run_id"):
                header = {**header, "complete": True}
        elif obj.get("kind") == "chunk":
            try:
                entries[(str(obj["label"]), int(obj["stage"]), int(obj["index"]))] = obj
            except (KeyError, TypeError, ValueError):
                continue
    return header, entries


#: What a run folder holds: anything else in it means it is not (only) ours.
_RUN_FILE = re.compile(r"^(manifest\.jsonl|[A-Za-z0-9_.\-]+\.s\d+\.c\d+\.npz|\..+\.\d+\.tmp)$")
