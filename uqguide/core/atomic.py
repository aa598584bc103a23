"""Files that are complete or absent: every file uqguide writes goes through here.

A file is written to a temporary name in its own folder (``.<name>.<pid>.tmp``), flushed and
fsynced, then renamed over the final name: whatever kills the writer and when, a file with the
final name is whole (the old one or the new one), never a 0-byte or torn table. A temporary
file left by a killed writer is removed by the next write into that folder once its process
is gone (:func:`clean_stale_temps`).

No file is written through a symbolic link. A link at a final name is refused
(:func:`refuse_links`: ConfigError, exit 2, naming it) rather than replaced, since it is the
user's; the temporary file is created here, exclusively and without following a link
(``O_EXCL | O_NOFOLLOW``), before any writer opens it by name, so a link planted at its
predictable name cannot redirect the write outside the folder.
"""

from __future__ import annotations

import logging
import os
import re
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import ConfigError

log = logging.getLogger(__name__)

_TEMP = re.compile(r"^\..+\.(\d+)\.tmp$")


def temp_path(path: Path) -> Path:
    """The temporary sibling of ``path`` owned by this process.

    Parameters
    ----------
    path : Path

    Returns
    -------
    Path
        ``.<name>.<pid>.tmp`` in the same folder.
    """
    return path.with_name(f".{path.name}.{os.getpid()}.tmp")


def _fsync_dir(folder: Path) -> None:
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # pragma: no cover - a platform without directory fds
        return
    try:
        os.fsync(fd)
    except OSError:  # pragma: no cover
        pass
    finally:
        os.close(fd)


def refuse_links(*paths: str | Path, field: str = "out") -> None:
    """Raise ConfigError for the first of ``paths`` that is a symbolic link.

    Parameters
    ----------
    *paths : str or Path
        Where uqguide is about to create or replace a file or folder.
    field : str
        The setting that chose the folder (named in the message).

    Raises
    ------
    ConfigError
        Naming the link and where it points; nothing has been written.
    """
    for p in paths:
        p = Path(p)
        if p.is_symlink():
            raise ConfigError(
                f"--{field}: {p} is a symbolic link (to {os.readlink(p)}); uqguide writes no "
                f"file through a link and does not replace one: remove it or choose another "
                f"--{field}", field=field)


def refuse_folders(*paths: str | Path, field: str = "out") -> None:
    """Raise ConfigError for the first of ``paths`` that is a folder (not a link to one).

    Parameters
    ----------
    *paths : str or Path
        Where uqguide is about to write a file.
    field : str
        The setting that chose the folder (named in the message).

    Raises
    ------
    ConfigError
        Naming the folder; a rename over it would fail after the work was done, and a
        folder at a file's name is the user's.
    """
    for p in paths:
        p = Path(p)
        if p.is_dir() and not p.is_symlink():
            raise ConfigError(
                f"--{field}: {p} is a folder; uqguide writes a file of that name there and "
                f"does not replace a folder: move it or choose another --{field}", field=field)


def _create_temp(tmp: Path) -> None:
    """Create ``tmp`` empty and ours: exclusively, never through a link at its name."""
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
    for _ in range(2):
        try:
            os.close(os.open(tmp, flags, 0o644))
            return
        except FileExistsError:
            # The name holds this PID, so no live writer owns it: a leftover of an earlier
            # process with our PID, or something planted. Removing a link removes only the link.
            os.unlink(tmp)
    raise FileExistsError(tmp)  # pragma: no cover - recreated between unlink and open


@contextmanager
def atomic_path(path: str | Path, fsync: bool = True, clean: bool = True) -> Iterator[Path]:
    """Yield a temporary path to write; on success it is renamed to ``path``.

    On any exception (Ctrl-C included) the temporary file is removed and ``path`` is left as
    it was. Writers that open files by name (HDF5, matplotlib, pandas) write to the yielded
    path.

    Parameters
    ----------
    path : str or Path
        The final file; its folder is created.
    fsync : bool
        Flush the file and the folder to disk before and after the rename.
    clean : bool
        First remove stale temporary files of dead writers in the folder.

    Yields
    ------
    Path
        The temporary file to write (created empty, a regular file of this process).

    Raises
    ------
    ConfigError
        ``path`` is a symbolic link or a folder.
    """
    path = Path(path)
    refuse_links(path)
    refuse_folders(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    if clean:
        clean_stale_temps(path.parent)
    tmp = temp_path(path)
    _create_temp(tmp)
    try:
        yield tmp
        if fsync:
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    if fsync:
        _fsync_dir(path.parent)


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
    text : str

    Returns
    -------
    Path
    """
    path = Path(path)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return path


def write_with(path: str | Path, writer: Callable[[Path], object]) -> Path:
    """Call ``writer(tmp_path)`` and rename its file to ``path`` atomically.

    Parameters
    ----------
    path : str or Path
    writer : callable
        Writes a whole file to the path it is given.

    Returns
    -------
    Path
    """
    path = Path(path)
    with atomic_path(path) as tmp:
        writer(tmp)
    return path


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this host (permission denied counts as alive).

    Parameters
    ----------
    pid : int

    Returns
    -------
    bool
    """
    if pid <= 0:
        return False
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def clean_stale_temps(folder: str | Path) -> list[Path]:
    """Remove ``.<name>.<pid>.tmp`` files in ``folder`` whose process is gone; return them.

    Only this naming pattern is touched, and only when its PID is not a live process here.

    Parameters
    ----------
    folder : str or Path

    Returns
    -------
    list of Path
        The files removed.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        m = _TEMP.match(e.name)
        if not m or int(m.group(1)) == os.getpid() or pid_alive(int(m.group(1))):
            continue
        try:
            if e.is_file(follow_symlinks=False):
                os.unlink(e.path)
                removed.append(Path(e.path))
        except OSError:
            continue
    if removed:
        log.info("removed %d stale temporary file(s) in %s", len(removed), folder)
    return removed
