"""One owner per run folder: an exclusive lock beside ``<out>/<name>.run``.

The lock is ``<out>/<name>.run.lock``, held with ``fcntl.flock`` for the whole of a
``uqguide run`` (checkpoints, the result file, the tables) and holding the owner's PID and
host. The kernel releases a ``flock`` when its process dies, however it dies, so a lock file
left by a killed run is free to take: the next run takes it over and says whose it was. A
second run into the same folder while the first is alive is refused (ConfigError, exit 2)
naming the owner.

``flock`` is advisory and local: two hosts writing one folder over NFS are not serialised by
it (the PID and host in the file then at least name the other owner).
"""

from __future__ import annotations

import errno
import fcntl
import logging
import os
import socket
import stat
from pathlib import Path

from ..core.atomic import refuse_links
from ..errors import ConfigError

log = logging.getLogger(__name__)


class RunLock:
    """The exclusive lock of one run folder; a context manager.

    Parameters
    ----------
    run_folder : path
        The run folder ``<out>/<name>.run`` (it need not exist yet).
    """

    def __init__(self, run_folder: str | Path) -> None:
        self.run_folder = Path(run_folder)
        self.path = self.run_folder.with_name(self.run_folder.name + ".lock")
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def acquire(self) -> RunLock:
        """Take the lock or raise ConfigError naming its owner."""
        self.path.parent.mkdir(parents=True, exist_ok=True)
        for _ in range(20):
            try:
                # O_NOFOLLOW: a link planted at the lock's name must not be truncated and
                # written through (a write outside --out), nor its missing target created.
                fd = os.open(self.path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0),
                             0o644)
            except OSError as e:
                if e.errno == errno.EISDIR:
                    raise ConfigError(
                        f"--out: {self.path} is a folder; the run's lock file goes there and "
                        f"uqguide does not replace a folder: move it, or give this run another "
                        f"--out or name", field="out") from None
                if e.errno != errno.ELOOP:
                    raise
                refuse_links(self.path)
                raise
            _refuse_shared(fd, self.path)
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
            if previous != "owner unknown":
                log.warning("%s: taking over the lock of a run that is gone (%s)",
                            self.run_folder, previous)
            os.ftruncate(fd, 0)
            os.write(fd, f"pid {os.getpid()} on host {socket.gethostname()}\n".encode())
            os.fsync(fd)
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


def _refuse_shared(fd: int, path: Path) -> None:
    """ConfigError (the descriptor closed) unless ``fd`` is a regular file with one name.

    O_NOFOLLOW keeps a symbolic link from redirecting the lock's write, not a hard link: a
    second name of a file outside --out at the lock's name would be truncated and written.
    Nothing has been written when this refuses (the lock is opened without O_TRUNC)."""
    st = os.fstat(fd)
    if stat.S_ISREG(st.st_mode) and st.st_nlink == 1:
        return
    os.close(fd)
    what = f"a hard link ({st.st_nlink} names)" if stat.S_ISREG(st.st_mode) else \
        "not a regular file"
    raise ConfigError(f"--out: {path} is {what}; the run's lock file goes there and uqguide "
                      f"writes no file that has another name: remove it, or give this run "
                      f"another --out or name", field="out")


def _read_owner(fd: int) -> str:
    try:
        os.lseek(fd, 0, os.SEEK_SET)
        text = os.read(fd, 4096).decode("utf-8", "replace").strip()
    except OSError:
        text = ""
    return text or "owner unknown"
