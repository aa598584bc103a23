"""Checkpoints: a run folder that survives a crash, a kill or Ctrl-C, and ``--resume``.

Layout, next to the result file (``<out>/<name>.run/``)::

    manifest.jsonl          append-only, one JSON object a line, flushed and fsynced: line 1
                            the run's identity and ``run_id``; then one line per finished
                            chunk (:mod:`uqguide.driver.run_manifest`)
    <label>.s<stage>.c<index>.npz
                            one chunk's runs or summary, written to a temporary name,
                            fsynced, renamed into place, and only then listed in the manifest
                            (:mod:`uqguide.driver.chunk_store`)

So a chunk listed in the manifest is complete on disk, whatever killed the run and when; a
torn last manifest line (killed while appending) is ignored and its chunk re-run. Chunks are
pure functions of the resolved config (their seeds come from the config's seed and the method
label), so a resumed run gives the statistics of an uninterrupted one bit for bit.

``--resume`` refuses (ConfigError, exit 2) when the config, the uqguide version or the model's
code differ from the run's: the stored chunks would mix two different experiments. Each chunk
carries the run id (in its manifest line and in its file): a chunk of another run (another
seed, config or code) is refused, never folded in. The folder is used under the run's lock
(:mod:`uqguide.driver.runlock`), and is deleted only when its manifest identifies it as a
uqguide run folder: a folder of anything else at that path is refused, not removed.

:class:`RunStore` is what the driver holds: the folder's :class:`RunManifest`, its
:class:`ChunkStore` and the :class:`CheckpointWriter` that writes chunks in the background.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

from ..core.atomic import clean_stale_temps
from ..errors import ConfigError
from .checkpoint_writer import CheckpointWriter
from .chunk_store import ChunkStore
# the writer calls it by this module's name, where a test stands in a full disk
from .chunk_store import write_chunk as _write_chunk
from .execution import ChunkResult, Task
from .run_manifest import RunManifest, identity_hash, model_code_hash, run_identity

__all__ = ["RunInterrupted", "RunStore", "identity_hash", "model_code_hash", "run_dir",
           "run_identity"]

log = logging.getLogger(__name__)


class RunInterrupted(KeyboardInterrupt):
    """The run was stopped (Ctrl-C) after ``n_done`` of ``n_total`` chunks; the chunks done are
    checkpointed when the run has a run folder. A KeyboardInterrupt, so that nothing catching
    ``Exception`` swallows it."""

    def __init__(self, n_done: int, n_total: int) -> None:
        super().__init__(f"interrupted: {n_done} of {n_total} chunks done")
        self.n_done = n_done
        self.n_total = n_total


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


class RunStore:
    """A run folder (see the module docstring). Only the driver process writes it.

    Parameters
    ----------
    path : Path
        The run folder.
    identity : dict
        The run's identity (:func:`run_identity`).
    """

    def __init__(self, path: Path, identity: dict[str, Any]) -> None:
        self.path = path
        self.manifest = RunManifest(path, identity)
        self.identity = self.manifest.identity
        self.run_id = self.manifest.run_id
        self.chunks = ChunkStore(path, self.run_id)
        self.writer: CheckpointWriter[tuple[str, int, ChunkResult]] = \
            CheckpointWriter(self._save_now)
        #: Samples found to crash or hang their process, by (label, stage): row -> reason.
        self.isolated: dict[tuple[str, int], dict[int, str]] = {}

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
        header, entries = store.manifest.read()
        if header is not None and resume:
            store.manifest.check_same_run(header)
            store.chunks = ChunkStore(path, store.run_id, entries)
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
            header, entries = store.manifest.read()
        if entries and not resume:
            raise ConfigError(
                f"{path} holds an unfinished run ({len(entries)} chunks done); continue it "
                f"with `{resume_hint}`, or delete the folder to start over", field="resume")
        if resume:
            log.info("nothing to resume at %s: starting a fresh run", path)
        if path.exists():
            store.manifest.clear(header)
        path.mkdir(parents=True)
        store.manifest.start()
        return store

    @property
    def n_done(self) -> int:
        """Chunks listed in the manifest on disk: what a resume will find. Read from the file,
        not the in-memory list, because an interrupt can land between a chunk's manifest line
        and its bookkeeping here."""
        return self.manifest.n_chunks()

    def known_isolated(self, label: str, stage: int) -> dict[int, str]:
        """Design rows of a stage known to crash or hang their process, with the reason."""
        return dict(self.isolated.get((label, stage), {}))

    def record_isolated(self, label: str, stage: int, row: int, reason: str) -> None:
        """List at once a sample that crashed or hung its process: a resume fails it with
        ``reason`` instead of running it again.

        Parameters
        ----------
        label : str
        stage : int
        row : int
            Its row in the stage's design.
        reason : str
        """
        self.isolated.setdefault((label, stage), {})[row] = reason
        self.manifest.record_isolated(label, stage, row, reason)

    def load(self, label: str, stage: int, task: Task) -> ChunkResult | None:
        """The stored result of a chunk, or None (see :meth:`ChunkStore.load`)."""
        return self.chunks.load(label, stage, task)

    def save(self, label: str, stage: int, result: ChunkResult) -> None:
        """Queue one chunk: the writer thread writes it atomically, then lists it in the
        manifest, chunk after chunk in the order given; an error of the writer (a full disk)
        is raised by the next ``save`` or by :meth:`flush`.

        Parameters
        ----------
        label : str
        stage : int
        result : ChunkResult
        """
        self.writer.put((label, stage, result))

    def flush(self) -> None:
        """Wait until every queued chunk is on disk and listed; raise the writer's error."""
        self.writer.flush()

    def drain(self) -> None:
        """Wait until every queued chunk is written, raising nothing of the writer's (for a
        run that is stopping with an error or an interrupt)."""
        self.writer.drain()

    def close(self) -> None:
        """:meth:`flush`, then end the writer thread."""
        self.writer.close()

    def mark_complete(self) -> None:
        """Every chunk is done (see :meth:`RunManifest.mark_complete`)."""
        self.close()
        self.manifest.mark_complete()

    def remove(self) -> list[str]:
        """Delete the run's files and the folder (after the result file is written: it holds
        everything); return what was left, not the run's (see :meth:`RunManifest.remove`)."""
        self.close()
        return self.manifest.remove()

    def _save_now(self, item: tuple[str, int, ChunkResult]) -> None:
        # The file first, then its line: a chunk listed in the manifest is whole on disk.
        label, stage, result = item
        entry = self.chunks.entry(label, stage, result)
        _write_chunk(self.path / entry["file"], result, self.run_id, label, stage)
        self.manifest.append(entry)
        self.chunks.add(entry)
