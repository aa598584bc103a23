"""A whole run as the command line makes it: budget check, a locked and resumable run folder,
every method, then the result file and the tables, each whole or absent.

``uqguide run`` is this plus printing; :func:`uqguide.run` with ``out=`` and
``scripts/reproduce_results.py`` call it too, so every way of running writes the same files.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ..config.budget import check_budget, estimate
from ..core.atomic import refuse_unwritable, usable_folder
from ..driver.run_folder import RunLock, RunStore, run_dir, run_identity, study_config
from ..config.run_config import RUN_NAME_RULE, RunConfig
from ..errors import ConfigError, MethodsFailed, ResultError
from ..driver.execution import Executor, SerialExecutor
from ..driver.execution.processes import refuse_nested_run
from ..driver.interrupts import deferred
from ..driver.progress import Progress
from ..driver.propagate import run
from ..report.tables import write_tables
from ..results.result import Result, read_config, write_hdf5


class WriteInterrupted(KeyboardInterrupt):
    """Ctrl-C or SIGTERM while the result files were written: the files written so far are
    whole, and the run folder stays, so the run resumes without re-running a model."""


@dataclass(frozen=True)
class Written:
    """A finished run, its ``<out>/<name>.h5`` and the CSV and Markdown tables beside it."""

    result: Result
    h5: Path
    tables: list[Path]


def canonical_config(config: dict[str, Any]) -> str:
    """A resolved config (or a part of one) as one comparable text: without the settings that
    change only how the model runs, through YAML as the result file keeps it (so a config
    read back compares equal), as JSON with sorted keys."""
    return json.dumps(yaml.safe_load(yaml.safe_dump(study_config(config))), sort_keys=True,
                      default=str)


def check_same_study(result_path: Path, config: RunConfig, force: bool = False) -> None:
    """Refuse (ConfigError naming both configs' digests) to replace, unless ``force``, a result
    of another config, seed included, that has the same name; a rerun may overwrite its own."""
    if force or not result_path.exists():
        return
    new = canonical_config(config.resolved())
    try:
        old = canonical_config(read_config(result_path))
    except ResultError as exc:
        raise ConfigError(f"--out: {result_path} exists and is not a readable uqguide result "
                          f"({exc}); move it away, or pass --force to replace it",
                          field="out") from None
    if old != new:
        digest = [hashlib.sha256(c.encode()).hexdigest()[:12] for c in (old, new)]
        raise ConfigError(
            f"--out: {result_path} holds the result of another config named "
            f"'{config.name}' (config {digest[0]}; this run's is {digest[1]}); give this run "
            f"another name or --out, or pass --force to replace it", field="out")


def check_result_name(config: RunConfig) -> None:
    """ConfigError for a mapping config without a ``name`` (a file's is named after it): it
    would be written as ``<out>/run.h5``, which the next unnamed config would overwrite."""
    if not config.raw.name and config.source == "<dict>":
        raise ConfigError(
            "name: a config given as a mapping needs a 'name' to be written to a folder (got "
            "none; it would be <out>/run.h5, overwritten by the next unnamed config): add "
            f"\"name\": \"my_study\" ({RUN_NAME_RULE}), or run without out= to keep the result "
            "in memory only", field="name")


def run_and_write(config: RunConfig, out_dir: str | Path, executor: Executor | None = None, *,
                  workers: int = 1, resume: bool = False, progress: Progress | None = None,
                  resume_hint: str = "", force: bool = False) -> Written:
    """Run every method of ``config`` and write ``<out_dir>/<name>.h5`` and its tables.

    The run folder ``<out_dir>/<name>.run`` checkpoints finished chunks meanwhile and is removed
    once every file is written, unless a method that made runs failed: it then stays, so
    ``--resume`` fits again without re-running a model. When no method produced statistics
    but runs succeeded, the files of those runs are written and MethodsFailed raised.
    ``executor`` (default this process) is closed on return;
    ``workers``: its processes, for the memory budget; ``resume``: continue the run folder of an
    interrupted run of the same config; ``resume_hint``: the command named in messages;
    ``force``: as :func:`check_same_study`.

    ConfigError before any folder is made (no name, a memory budget over ``max_memory``);
    RunInterrupted on Ctrl-C or SIGTERM during the runs; WriteInterrupted while writing.
    """
    refuse_nested_run()  # before the lock: a worker re-running an unguarded script stops here
    out_dir = Path(out_dir)
    executor = executor or SerialExecutor(config.raw.batch_size)
    try:
        usable_folder(out_dir)  # a dangling link, a file, /dev/null: refused before any work
        check_result_name(config)
        check_budget(estimate(config, workers))  # before anything is allocated
        folder = run_dir(out_dir, config.name)  # inside out_dir: the name is a plain file name
        # A link where the run folder or the result goes would send checkpoints or the result
        # outside out_dir, a folder where a file goes would stop the run after its work, at
        # the rename, and a FIFO would block the read of the result: each refused before
        # anything is written (the lock refuses its own, the run folder its names).
        outputs = [out_dir / f"{config.name}{tail}" for tail in
                   (".h5", "_stats.csv", "_cost.csv", "_summary.md", "_events.csv")]
        if folder.is_symlink():
            refuse_unwritable(folder)
        refuse_unwritable(*outputs, folder.with_name(folder.name + ".lock"))
        with RunLock(folder):
            check_same_study(out_dir / f"{config.name}.h5", config, force)
            store = RunStore.open(folder, run_identity(config.resolved(), config.model), resume,
                                  resume_hint)
            failed: MethodsFailed | None = None
            try:
                result = run(config, executor, store=store, progress=progress)
            except MethodsFailed as exc:  # no statistics, but runs: written, folder kept
                assert isinstance(exc.result, Result)
                result, failed = exc.result, exc
            finally:
                store.close()  # every chunk saved is on disk, whatever stopped the run
            kept = failed is not None or any(not r.success and r.n_runs for r in result.runs)
            if not kept:
                store.mark_complete()
            try:
                # Each file whole or absent; a signal here stops the run after the file being
                # written, and the run folder stays until every file is written (resumable).
                with deferred():
                    h5 = write_hdf5(result, out_dir / f"{config.name}.h5")
                with deferred():
                    tables = write_tables(result, out_dir, config.name)
            except KeyboardInterrupt:
                raise WriteInterrupted() from None
            written = Written(result, h5, list(tables))
            if failed is not None:
                failed.written = written
                raise failed
            if not kept:
                with deferred():
                    store.remove()  # the result file holds everything the chunks did
    finally:
        executor.close()
    return written


__all__ = ["WriteInterrupted", "Written", "canonical_config", "check_result_name",
           "run_and_write"]
