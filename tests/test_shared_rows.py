"""Per-run values written in place by pool workers (uqguide.driver.execution.shared_rows): the same
numbers as the pipe, what happens without room, and no file left behind."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.execution import ProcessExecutor, SerialExecutor
from uqguide.driver.execution import shared_rows
from uqguide.driver.execution.chunks import ChunkResult, Task
from uqguide.driver.execution.shared_rows import SharedRows, write_in_place
from uqguide.methods.monte_carlo import append_columns
from uqguide.driver.propagate import run

from .test_execution import FLAKY, _arrays, _assert_identical

pytestmark = pytest.mark.skipif(not shared_rows.SHM_DIR.is_dir(), reason="no /dev/shm")


def _per_run(key: str) -> bool:
    return key.startswith("q::")


def _chunk(i: int, m: int, failed: np.ndarray, rng: np.random.Generator) -> ChunkResult:
    good = int((~failed).sum())
    return ChunkResult(
        Task(i, i * m, (i + 1) * m), failed, np.full(m, "", dtype=object), np.arange(3.0),
        scalars={"y": rng.standard_normal((m, 2))},
        summary={"m:mean:y": rng.standard_normal(2), "q::path": rng.standard_normal((4, good))})


def _mine() -> list[str]:
    return [p.name for p in shared_rows.SHM_DIR.glob(f"{shared_rows._PREFIX}{os.getpid()}-*")]


def test_values_written_in_place_come_back_as_views_equal_to_what_was_sent():
    rng = np.random.default_rng(0)
    m, n_chunks = 50, 3
    fails = [np.zeros(m, bool), np.arange(m) % 7 == 0, np.zeros(m, bool)]
    chunks = [_chunk(i, m, f, rng) for i, f in enumerate(fails)]
    shared = SharedRows.for_result(chunks[0], m * n_chunks, _per_run)
    assert shared is not None and len(_mine()) == 2
    lanes: list[np.ndarray] = []
    for c in chunks:
        sent = write_in_place(shared.layout, c)
        # only the sums still travel
        assert set(sent.summary) == {"m:mean:y"} and not sent.scalars
        assert {(p, k) for p, k, _ in sent.in_place} == {("scalars", "y"), ("summary", "q::path")}
        got = shared.adopt(sent)
        np.testing.assert_array_equal(got.scalars["y"], c.scalars["y"])
        np.testing.assert_array_equal(got.summary["q::path"], c.summary["q::path"])
        assert np.shares_memory(got.scalars["y"], shared.scalar_array("y"))
        append_columns(lanes, got.summary["q::path"])
    # chunk 1 lost runs, so chunk 2 does not continue it: two blocks, the first one joined
    # from chunks 0 and 1
    assert [b.shape[1] for b in lanes] == [m + int((~fails[1]).sum()), m]
    np.testing.assert_array_equal(
        np.concatenate(lanes, axis=1),
        np.concatenate([c.summary["q::path"] for c in chunks], axis=1))
    shared.close()
    assert _mine() == []
    # the driver's views outlive the files
    np.testing.assert_array_equal(shared.scalar_array("y")[:m], chunks[0].scalars["y"])


def test_append_columns_joins_only_blocks_that_continue_each_other():
    a = np.arange(40.0).reshape(4, 10).copy()  # owns its data, as the shared arrays do
    lanes: list[np.ndarray] = []
    for sl in (slice(0, 3), slice(3, 6), slice(7, 10)):  # a gap before the last one
        append_columns(lanes, a[:, sl])
    assert [b.shape[1] for b in lanes] == [6, 3]
    np.testing.assert_array_equal(lanes[0], a[:, :6])
    other: list[np.ndarray] = [a[:, :3]]
    append_columns(other, a.copy()[:, 3:6])  # adjacent columns of another array
    assert len(other) == 2


def test_no_room_in_shared_memory_means_the_pipe_and_no_file_left(monkeypatch):
    def full(fd, offset, size):
        raise OSError(errno.ENOSPC, "No space left on device")

    rng = np.random.default_rng(1)
    monkeypatch.setattr(os, "posix_fallocate", full)
    assert SharedRows.for_result(_chunk(0, 20, np.zeros(20, bool), rng), 100, _per_run) is None
    assert _mine() == []


def test_a_value_whose_file_is_gone_travels_by_the_pipe():
    rng = np.random.default_rng(2)
    c = _chunk(0, 20, np.zeros(20, bool), rng)
    shared = SharedRows.for_result(c, 40, _per_run)
    assert shared is not None
    shared.close()
    sent = write_in_place(shared.layout, c)
    assert sent.in_place == () and "q::path" in sent.summary and "y" in sent.scalars


def test_files_of_a_killed_driver_are_swept_and_a_live_drivers_kept():
    import subprocess
    import sys

    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    dead = shared_rows.SHM_DIR / f"{shared_rows._PREFIX}{int(gone.stdout)}-abcd-0"
    live = shared_rows.SHM_DIR / f"{shared_rows._PREFIX}{os.getppid()}-abcd-0"
    dead.write_bytes(b"x")
    live.write_bytes(b"x")
    try:
        shared = SharedRows.for_result(_chunk(0, 10, np.zeros(10, bool),
                                              np.random.default_rng(3)), 10, _per_run)
        assert shared is not None
        shared.close()
        assert not dead.exists() and live.exists()
    finally:
        dead.unlink(missing_ok=True)
        live.unlink(missing_ok=True)


@pytest.mark.slow
def test_a_process_pool_writes_in_place_and_gives_the_serial_numbers(monkeypatch):
    """The pool's chunks after the first come back without their per-run values (written in
    place), the statistics, quantiles and per-run scalars are the serial run's bit for bit,
    and the files are gone at the end."""
    seen = []
    adopt = SharedRows.adopt

    def spy(self, r):
        seen.append(bool(r.in_place))
        return adopt(self, r)

    monkeypatch.setattr(SharedRows, "adopt", spy)
    cfg = validate_config(FLAKY)
    serial = _arrays(run(cfg, SerialExecutor()))
    assert not seen  # nothing is shared within one process
    pool = ProcessExecutor(2)
    try:
        _assert_identical(serial, _arrays(run(cfg, pool)))
    finally:
        pool.close()
    assert len(seen) == 7 and not seen[0] and sum(seen) >= 3
    assert _mine() == []
