"""Files that are complete or absent, written only where uqguide may write: every file uqguide
writes goes through here.

A file is written to a temporary sibling, flushed and fsynced, then renamed over its final name:
whatever kills the writer and when, the final name holds the old file or the new one, whole.
A temporary name carries a random token and a tag only uqguide computes (:func:`temp_owner`),
so the clean-up of a killed writer's files (:func:`clean_stale_temps`) never takes a user's.

Every file opened for writing goes through :func:`open_writable`: never through a symbolic or
hard link, never into a FIFO or a device (a blocking open), and a name that holds one is refused
with one line (ConfigError, exit 2). A full disk (ENOSPC, EFBIG, EDQUOT) is :class:`DiskFull`,
raised once nothing is left half-written. Reasons and the layouts tried: docs/scale.md.
"""

from __future__ import annotations

import errno
import fcntl
import hashlib
import io
import logging
import os
import re
import secrets
import socket
import stat
from collections.abc import Callable, Iterator
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import IO, Any

from ..errors import ConfigError, DiskFull

log = logging.getLogger(__name__)

#: The errors of a write that found no room: the disk, the file size limit, the quota.
DISK_FULL = frozenset({errno.ENOSPC, errno.EFBIG, errno.EDQUOT})

_TEMP = re.compile(r"^\.(?P<name>.+)\.(?P<pid>\d+)\.(?P<token>[0-9a-f]{8})(?P<tag>[0-9a-f]{12})"
                   r"\.tmp$")


def _tag(name: str, pid: str, token: str) -> str:
    # The host is in the tag: a temporary file of another host sharing the folder is not ours
    # to judge (its PID means nothing here), so it never verifies and is left alone.
    text = f"uqguide temporary file\0{name}\0{pid}\0{token}\0{socket.gethostname()}"
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def temp_path(path: Path, pid: int | None = None) -> Path:
    """A fresh temporary sibling of ``path`` for the writer ``pid`` (default this process):
    ``.<name>.<pid>.<token><tag>.tmp``, a random token and a tag of name, PID, token and host
    that :func:`temp_owner` checks."""
    pid_, token = str(os.getpid() if pid is None else pid), secrets.token_hex(4)
    return path.with_name(f".{path.name}.{pid_}.{token}{_tag(path.name, pid_, token)}.tmp")


def temp_owner(name: str) -> int | None:
    """The PID of the uqguide process that made the temporary file ``name`` (no folder) on this
    host, or None when ``name`` is not one (a user's ``.thesis.20240101.tmp``)."""
    m = _TEMP.match(name)
    if m is None or _tag(m["name"], m["pid"], m["token"]) != m["tag"]:
        return None
    return int(m["pid"])


def temp_target(name: str) -> str | None:
    """The final name of the uqguide temporary file ``name`` (None: not one of ours)."""
    m = _TEMP.match(name)
    return m["name"] if m is not None and temp_owner(name) is not None else None


def not_regular(path: str | Path, hard_links: bool = True) -> str:
    """What is at ``path`` when it is not a regular file (of one name, with ``hard_links``),
    e.g. "a FIFO (named pipe)", "a hard link (2 names)"; '' when it is, or when nothing is
    there. Nothing is opened, links are not followed."""
    path = Path(path)
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return ""
    what = _what(st, path)
    return "" if what.startswith("a hard link") and not hard_links else what


def _what(st: os.stat_result, path: Path) -> str:
    """What ``st`` is, when it is not a regular file of one name ('' when it is)."""
    mode = st.st_mode
    if stat.S_ISLNK(mode):
        return f"a symbolic link (to {os.readlink(path)})"
    if stat.S_ISDIR(mode):
        return "a folder"
    if stat.S_ISFIFO(mode):
        return "a FIFO (named pipe)"
    if stat.S_ISSOCK(mode):
        return "a socket"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if not stat.S_ISREG(mode):
        return "not a regular file"
    if st.st_nlink > 1:
        return f"a hard link ({st.st_nlink} names)"
    return ""


def refusal(path: str | Path, what: str, field: str = "out", role: str = "") -> ConfigError:
    """The one-line ConfigError for a name that holds ``what`` (:func:`not_regular`); ``field``:
    the setting that chose the folder; ``role``: what uqguide puts there ("the run's manifest
    goes there")."""
    if what.startswith("a symbolic link"):
        why = "uqguide writes no file through a link and does not replace one"
    elif what == "a folder":
        why = "uqguide writes a file of that name there and does not replace a folder"
    elif what.startswith("a hard link"):
        why = "uqguide writes no file that has another name (it would change the other too)"
    elif what.startswith("not a uqguide"):
        why = "uqguide replaces only its own files"
    else:
        why = "uqguide reads and writes only regular files there (opening it could block)"
    return ConfigError(f"--{field}: {path} is {what}; {role + ' and ' if role else ''}{why}: "
                       f"move it or choose another --{field}", field=field)


def refuse_unwritable(*paths: str | Path, field: str = "out") -> None:
    """Raise ConfigError (naming the path, nothing written) for the first of ``paths`` that
    exists and is not a regular file: a symbolic link, a folder, a FIFO, a socket or a device.
    Nothing is opened (a FIFO's open would block).

    A hard link is not refused here: a file replaced by a rename keeps its other name intact.
    """
    for p in map(Path, paths):
        try:
            what = not_regular(p, hard_links=False)
        except OSError as exc:  # a path under a file, a name too long: not writable there
            raise ConfigError(f"--{field}: cannot write {p} ({exc.strerror})",
                              field=field) from None
        if what:
            raise refusal(p, what, field)


def open_writable(path: str | Path, flags: int, field: str = "out", mode: int = 0o644) -> int:
    """Open ``path`` for writing, only when it is (or is created as) a regular file of one
    name; the lock, the manifest and every temporary file are opened here.

    ``flags``: ``os.O_WRONLY`` or ``os.O_RDWR`` with ``O_CREAT``, ``O_EXCL``, ``O_APPEND`` as
    needed (no ``O_TRUNC``: truncate after the checks, with ``os.ftruncate``). Returns a
    blocking, close-on-exec descriptor. ConfigError for a symbolic link (never followed:
    O_NOFOLLOW), a folder, a FIFO or device (never opened blocking: O_NONBLOCK), or a file with
    another name (a hard link would carry the write outside the folder).
    """
    path = Path(path)
    if flags & os.O_TRUNC:
        raise ValueError("open_writable: truncate after the checks, not with O_TRUNC")
    refuse_unwritable(path, field=field)  # before any open: a FIFO's open would block
    try:
        fd = os.open(path, flags | os.O_NOFOLLOW | os.O_NONBLOCK | os.O_NOCTTY | os.O_CLOEXEC,
                     mode)
    except OSError as exc:
        if exc.errno in (errno.ELOOP, errno.EISDIR, errno.ENXIO, errno.EEXIST):
            refuse_unwritable(path, field=field)  # replaced since the check: say what by
        raise
    try:
        what = _what(os.fstat(fd), path)
        if what:
            raise refusal(path, what, field)
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)
    except BaseException:
        os.close(fd)
        raise
    return fd


def usable_folder(path: str | Path, field: str = "out") -> Path:
    """Check that files can be written in the folder ``path`` (made later when missing).

    ConfigError for a dangling symbolic link or a loop, something that is not a folder (a file,
    ``/dev/null``), a path under a file, or a folder not writable by this user.
    """
    path = Path(path)
    for p in [path, *path.parents]:
        try:
            st = os.stat(p)
        except (FileNotFoundError, NotADirectoryError):  # made later; under a file: see above
            if p.is_symlink():
                raise ConfigError(f"--{field}: {p} is a symbolic link to {os.readlink(p)}, "
                                  f"which does not exist: choose another --{field}",
                                  field=field) from None
            continue
        except OSError as exc:
            what = "a symbolic link loop" if exc.errno == errno.ELOOP else exc.strerror
            raise ConfigError(f"--{field}: {p} is {what}; give a folder", field=field) from None
        if not stat.S_ISDIR(st.st_mode):
            kind = "a file" if stat.S_ISREG(st.st_mode) else _what(st, p) or "not a folder"
            where = "" if p == path else f" (the folder {path} would be under it)"
            raise ConfigError(f"--{field}: {p} is {kind}, not a folder{where}; give a folder",
                              field=field)
        if not os.access(p, os.W_OK | os.X_OK):
            made = "" if p == path else f" (to make {path} in it)"
            raise ConfigError(f"--{field}: {p} is not writable by this user{made}; choose "
                              f"another --{field}", field=field)
        return path
    raise ConfigError(f"--{field}: {path}: no folder of it exists", field=field)  # unreachable


def make_folder(path: str | Path, field: str = "out") -> Path:
    """:func:`usable_folder`, then make it (a full disk is :class:`DiskFull`)."""
    path = usable_folder(path, field)
    with disk_full_as_error(path):
        try:
            path.mkdir(parents=True, exist_ok=True)
        except FileExistsError:
            raise refusal(path, "not a folder", field) from None
        except OSError as exc:
            if exc.errno in DISK_FULL:
                raise
            raise ConfigError(f"--{field}: cannot make {path} ({exc.strerror})",
                              field=field) from None
    return path


def is_disk_full(exc: BaseException | None) -> bool:
    """Whether ``exc``, or an exception it was raised from, is a write that found no room."""
    seen = 0
    while exc is not None and seen < 20:
        if isinstance(exc, DiskFull) or (isinstance(exc, OSError) and exc.errno in DISK_FULL):
            return True
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


@contextmanager
def disk_full_as_error(path: str | Path) -> Iterator[None]:
    """Turn a full disk met inside the block into :class:`DiskFull` naming ``path``."""
    try:
        yield
    except DiskFull:
        raise
    except Exception as exc:
        if is_disk_full(exc):
            raise DiskFull(Path(path)) from exc
        raise


def _fsync_dir(folder: Path) -> None:
    with suppress(OSError):  # a platform without directory fds
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)


def _create_temp(path: Path, field: str) -> tuple[Path, int]:
    """A new temporary file for ``path``, created exclusively (never over anything)."""
    flags = os.O_RDWR | os.O_CREAT | os.O_EXCL
    for _ in range(8):
        tmp = temp_path(path)
        try:
            return tmp, open_writable(tmp, flags, field)
        except (ConfigError, FileExistsError):
            if not os.path.lexists(tmp):
                raise
            # something sits at this random name (planted): leave it, take another name
    raise ConfigError(f"--{field}: cannot create a temporary file beside {path}",
                      field=field)  # pragma: no cover


@contextmanager
def atomic_file(path: str | Path, binary: bool = True, fsync: bool = True, clean: bool = True,
                field: str = "out") -> Iterator[IO[Any]]:
    """Yield an open file to write (through :func:`open_writable`); on success it is renamed to
    ``path``, whose folder is made (:func:`make_folder`).

    On any exception (Ctrl-C included) the temporary file is removed and ``path`` is left as
    it was; a full disk (or file size limit) is :class:`DiskFull` naming ``path``. ``binary``
    False: text, UTF-8, lines as written; ``fsync``: flush the file and the folder to disk
    before and after the rename; ``clean``: first remove stale temporary files of dead uqguide
    writers. ConfigError when ``path`` is a symbolic link, a folder, a FIFO or a device, or its
    folder is unusable.
    """
    path = Path(path)
    refuse_unwritable(path, field=field)
    make_folder(path.parent, field)
    if clean:
        clean_stale_temps(path.parent)
    with disk_full_as_error(path):
        tmp, fd = _create_temp(path, field)
        try:
            f: IO[Any] = os.fdopen(fd, "w+b") if binary else \
                os.fdopen(fd, "w+", encoding="utf-8", newline="")
            with f:
                yield f
                f.flush()
                if fsync:
                    os.fsync(f.fileno())
            refuse_unwritable(path, field=field)  # (a rename would replace a folder's link)
            os.replace(tmp, path)
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    if fsync:
        _fsync_dir(path.parent)


def write_text(path: str | Path, text: str, field: str = "out") -> Path:
    """Write ``text`` (UTF-8) to ``path`` atomically."""
    return write_with(path, lambda f: f.write(text), field=field)


def write_with(path: str | Path, writer: Callable[[IO[Any]], object], binary: bool = False,
               field: str = "out") -> Path:
    """Call ``writer(file)`` (writes a whole file: ``df.to_csv``, ``fig.savefig``) and rename
    its file to ``path`` atomically."""
    path = Path(path)
    with atomic_file(path, binary=binary, field=field) as f:
        writer(f)
    return path


class HeldErrorFile(io.RawIOBase):
    """A file for a C library that does not survive a failed write (HDF5 crashes the process
    at exit after one): the first error of a write is held, not raised, and raised by
    :meth:`close` (or the ``with`` block's end) once the library is done with the file.

    After the error, writes of metadata size are kept in memory, so that the library reads
    back what it wrote; larger ones are dropped (the file is deleted anyway). ``fd`` is left
    open.
    """

    _KEEP = 1 << 20  # a write kept after the error: HDF5's metadata blocks are far smaller
    _KEPT_MAX = 64 << 20

    def __init__(self, fd: int) -> None:
        super().__init__()
        self._fd = fd
        self._pos = 0
        self._size = os.fstat(fd).st_size
        self.error: OSError | None = None
        self._kept: list[tuple[int, bytes]] = []
        self._kept_bytes = 0

    def readable(self) -> bool:
        return True

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        base = {io.SEEK_SET: 0, io.SEEK_CUR: self._pos, io.SEEK_END: self._size}[whence]
        self._pos = base + offset
        return self._pos

    def readinto(self, b: Any) -> int:
        view = memoryview(b).cast("B")
        n = max(0, min(len(view), self._size - self._pos))
        got = os.pread(self._fd, n, self._pos) if n else b""
        view[:len(got)] = got
        view[len(got):n] = bytes(n - len(got))  # past the end on disk: unwritten, zeros
        for at, data in self._kept:  # later writes win
            lo, hi = max(at, self._pos), min(at + len(data), self._pos + n)
            if lo < hi:
                view[lo - self._pos:hi - self._pos] = data[lo - at:hi - at]
        self._pos += n
        return n

    def write(self, b: Any) -> int:
        view = memoryview(b).cast("B")
        n = len(view)
        if self.error is None:
            try:
                done = 0
                while done < n:
                    done += os.pwrite(self._fd, view[done:], self._pos + done)
            except OSError as exc:
                self.error = exc
        if self.error is not None and n <= self._KEEP and \
                self._kept_bytes + n <= self._KEPT_MAX:
            self._kept.append((self._pos, bytes(view)))
            self._kept_bytes += n
        self._pos += n
        self._size = max(self._size, self._pos)
        return n

    def truncate(self, size: int | None = None) -> int:
        size = self._pos if size is None else size
        if self.error is None:
            try:
                os.ftruncate(self._fd, size)
            except OSError as exc:
                self.error = exc
        self._size = size
        return size

    def flush(self) -> None:
        pass

    def close(self) -> None:
        if self.closed:
            return
        super().close()
        if self.error is not None:
            raise self.error


def pid_alive(pid: int) -> bool:
    """Whether a process ``pid`` exists on this host (permission denied counts as alive)."""
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
    """Remove the temporary files of dead uqguide writers in ``folder``; return them.

    Only names :func:`temp_owner` recognises (made by uqguide on this host) whose process is
    gone, and only regular files, are removed: a user's ``.notes.20240101.tmp`` stays.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except OSError:
        return removed
    for e in entries:
        pid = temp_owner(e.name)
        if pid is None or pid == os.getpid() or pid_alive(pid):
            continue
        with suppress(OSError):
            if e.is_file(follow_symlinks=False):
                os.unlink(e.path)
                removed.append(Path(e.path))
    if removed:
        log.info("removed %d stale temporary file(s) in %s", len(removed), folder)
    return removed
