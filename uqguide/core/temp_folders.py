"""Folders uqguide makes in the system's temporary folder, each marked as its own, and the
sweep that removes those whose process was killed before it could.

A folder is ``<prefix>[<pid>-]<random>`` holding a mark file: JSON naming its process and the
folder itself (a copy or a rename does not match). :func:`sweep` removes only such folders: of
this user, not a link, with a kind's prefix and mark, whose process is gone; a user's folder
named like one, a live process's and another kind's stay. Two kinds: an FMU's unzipped files
(:mod:`uqguide.models.fmu.archive`) and multiprocessing's own temporary folder, where its fork
server's socket lives (:func:`multiprocessing_folder`; unmarked, a killed run left it as
``pymp-*``). Why and the campaign that found it: ``docs/scale.md#failures``.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .atomic import pid_alive


@dataclass(frozen=True)
class Kind:
    """A kind of marked folder: its name's prefix (then its process's ID when ``with_pid``,
    then :func:`tempfile.mkdtemp`'s 8 random letters) and its mark file's name."""

    prefix: str
    mark: str
    with_pid: bool = True


#: An FMU's unzipped files.
FMU = Kind("uqguide-fmu-", ".uqguide-fmu")
#: multiprocessing's temporary folder (the fork server's socket, its shared-memory arenas):
#: a name no longer than its own ``pymp-`` and 8 letters, so a socket's path in it is no
#: longer than multiprocessing's (at most 107 bytes on Linux, and a deep ``TMPDIR`` is near).
MULTIPROCESSING = Kind("uqmp-", ".uqguide-mp", with_pid=False)
KINDS = (FMU, MULTIPROCESSING)


def make(kind: Kind, **extra: Any) -> Path:
    """A fresh marked folder of ``kind`` for this process, ``extra`` written in its mark;
    OSError when the folder or its mark cannot be written (nothing is left)."""
    pid = f"{os.getpid()}-" if kind.with_pid else ""
    folder = Path(tempfile.mkdtemp(prefix=f"{kind.prefix}{pid}"))
    try:
        (folder / kind.mark).write_text(json.dumps({"pid": os.getpid(), "folder": folder.name,
                                                    **extra}))
    except OSError:
        shutil.rmtree(folder, ignore_errors=True)
        raise
    return folder


def mark_of(folder: Path, kind: Kind) -> dict[str, Any] | None:
    """The mark uqguide wrote in ``folder``, or None when it is not one of ``kind``."""
    try:
        if folder.is_symlink() or not folder.is_dir():
            return None
        mark = folder / kind.mark
        if mark.is_symlink():
            return None
        found = json.loads(mark.read_text())
    except (OSError, ValueError):
        return None
    ok = isinstance(found, dict) and found.get("folder") == folder.name and \
        isinstance(found.get("pid"), int)
    return found if ok else None


def sweep(kinds: tuple[Kind, ...] = KINDS) -> int:
    """Remove the marked folders of ``kinds`` whose process is gone (module docstring); returns
    how many."""
    removed = 0
    try:
        entries = list(os.scandir(tempfile.gettempdir()))
    except OSError:
        return 0
    for entry in entries:
        kind = next((k for k in kinds if entry.name.startswith(k.prefix)), None)
        try:
            if kind is None or entry.stat(follow_symlinks=False).st_uid != os.getuid():
                continue
        except OSError:
            continue
        mark = mark_of(Path(entry.path), kind)
        if mark is None or mark["pid"] == os.getpid() or pid_alive(mark["pid"]):
            continue
        shutil.rmtree(entry.path, ignore_errors=True)
        removed += 1
    return removed


def remove(folder: str, owner: int) -> None:
    """Remove ``folder`` if this is its ``owner`` process (a forked child that inherited the
    exit handler is not)."""
    if os.getpid() == owner:
        shutil.rmtree(folder, ignore_errors=True)


def multiprocessing_folder() -> str | None:
    """Make multiprocessing's temporary folder a marked one, before a context starts anything.

    The folder this process has (made here before, inherited from the parent that started it,
    or multiprocessing's own) is kept. Otherwise the dead processes' folders are swept and a
    marked one is made and given to multiprocessing (``pymp-*`` otherwise), removed at exit
    after this process's children, as multiprocessing removes its own. Returns the folder
    multiprocessing uses, None when it has none yet.
    """
    from multiprocessing import util

    config = _multiprocessing_config()
    if config.get("tempdir") is not None:
        return str(config["tempdir"])
    sweep((MULTIPROCESSING,))
    try:
        folder = str(make(MULTIPROCESSING))
    except OSError:
        return None  # multiprocessing makes its own, or says why it cannot
    util.Finalize(None, _forget, args=(folder, os.getpid()), exitpriority=-100)
    config["tempdir"] = folder
    return folder


def _multiprocessing_config() -> dict[str, Any]:
    """This process's multiprocessing settings, where ``util.get_temp_dir()`` finds its folder
    (a private dict of every Python since 3.4; a stand-in if it goes: nothing is then set)."""
    from multiprocessing import process

    config = getattr(process.current_process(), "_config", None)
    return config if isinstance(config, dict) else {}


def _forget(folder: str, owner: int) -> None:
    # as multiprocessing's own finalizer: the folder is gone, a late user makes another
    remove(folder, owner)
    config = _multiprocessing_config()
    if config.get("tempdir") == folder:
        config["tempdir"] = None
