"""A small run in pieces: a stage of one chunk (8,192 runs or fewer) is evaluated in model calls
that each move the progress and are checkpointed, and Ctrl-C keeps them; the numbers are those
of the chunk evaluated whole, and a resume gives them bit for bit.

``PIECE_SECONDS = 0`` stands for a slow model (every piece a 16th of a chunk) and
``SAVE_AFTER_S = 0`` for a run long enough to checkpoint its pieces.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.driver import chunk_pieces, stage
from uqguide.driver.chunk_pieces import Pieces, piece_rows
from uqguide.driver.execution import ChunkResult, Task
from uqguide.driver.progress import Progress
from uqguide.driver.propagate import run
from uqguide.driver.run_folder import RunInterrupted, RunStore, run_identity

from . import failing_models
from .failing_models import mc_config
from .test_execution import FLAKY, _arrays, _assert_identical
from .test_resume import _assert_same, _stats, run_to_ctrl_c

#: One chunk (the default chunk_size, 8,192) and the default batch size (above the chunk): its
#: pieces are calls of ceil(1500 / 16) = 94 samples.
SMALL = {**FLAKY, "batch_size": 10_000,
         "methods": [{**FLAKY["methods"][0], "n_samples": 1500, "chunk_size": 8192}]}


class _Counted(Progress):
    """Progress that records (runs done, chunks done) after every count, and stands for a
    Ctrl-C in the driver after ``stop_after`` evaluated pieces."""

    def __init__(self, stop_after: int | None = None) -> None:
        super().__init__(None)
        self.seen: list[tuple[int, int]] = []
        self.stop_after = stop_after

    def advance(self, n_runs: int, n_failed: int, chunks: int = 1) -> None:
        super().advance(n_runs, n_failed, chunks)
        self.seen.append((self.runs_done, self.chunks_done))
        if self.stop_after is not None and len(self.seen) >= self.stop_after:
            raise KeyboardInterrupt


@pytest.fixture
def slow_model(monkeypatch):
    monkeypatch.setattr(chunk_pieces, "PIECE_SECONDS", 0.0)
    monkeypatch.setattr(chunk_pieces, "SAVE_AFTER_S", 0.0)


def test_progress_moves_with_each_model_call_of_a_single_chunk_and_the_numbers_stay(
        slow_model):
    cfg = validate_config(SMALL)
    p = _Counted()
    in_pieces = run(cfg, progress=p)
    steps = [runs for runs, _ in p.seen]
    assert len(steps) == 16 and steps[-1] == 1500
    assert set(np.diff([0, *steps])) == {94, 1500 - 15 * 94}
    assert [chunks for _, chunks in p.seen] == [0] * 15 + [1]
    with pytest.MonkeyPatch.context() as mp:  # the chunk whole, as before pieces
        mp.setattr(stage, "goes_in_pieces", lambda n, executor: False)
        whole = run(validate_config(SMALL))
    _assert_identical(_arrays(whole), _arrays(in_pieces))


def test_a_fast_model_runs_the_rest_of_its_chunk_in_one_call():
    """After two pieces, pieces of PIECE_SECONDS at the second one's speed (the first may
    include starting the guard process): the flaky model runs 1,500 samples in well under 2 s,
    so the rest goes in one call, and a second method's chunk of the same model goes so from
    its first call."""
    two = {**SMALL, "methods": [SMALL["methods"][0], {**SMALL["methods"][0], "label": "mc2"}]}
    p = _Counted()
    run(validate_config(two), progress=p)
    steps = np.diff([0] + [runs for runs, _ in p.seen]).tolist()
    assert steps == [94, 94, 1312, 1500]


def test_a_batch_size_a_user_chose_below_the_chunk_is_the_call_size(slow_model):
    """A command program's start-up or a licence per call: the user's batch_size (300) sets
    the pieces, as it sets a whole chunk's calls, however slow the model."""
    p = _Counted()
    run(validate_config({**SMALL, "batch_size": 300}), progress=p)
    assert np.diff([0] + [runs for runs, _ in p.seen]).tolist() == [300] * 5


def test_pieces_left_to_run_are_the_gaps_between_those_kept():
    t = Task(0, 0, 100)
    pieces = Pieces([t], batch_size=1000)
    assert piece_rows(100, 1000) == 7 and piece_rows(100, 5) == 5 and piece_rows(3, 10) == 1

    def kept(a: int, b: int) -> ChunkResult:
        return ChunkResult(Task(0, a, b), np.zeros(b - a, bool), np.full(b - a, ""),
                           np.zeros(0), {})

    assert pieces.restore(kept(7, 14)) and pieces.restore(kept(20, 30))
    assert not pieces.restore(kept(25, 35))  # overlaps one kept (another session's split)
    todo = [(p.start, p.stop) for p in pieces.todo()]
    assert todo[:4] == [(0, 7), (14, 20), (30, 35), (35, 42)] and todo[-1] == (98, 100)
    covered = sorted([(7, 14), (20, 30), *todo])
    assert all(a[1] == b[0] for a, b in zip(covered, covered[1:]))
    assert covered[0][0] == 0 and covered[-1][1] == 100
    for a, b in todo[:-1]:
        assert pieces.add(kept(a, b)) is None
    whole = pieces.add(kept(*todo[-1]))
    assert whole is not None and [p.task.start for p in whole] == [c[0] for c in covered]


@pytest.fixture
def ctrl_c_small(tmp_path, monkeypatch, slow_model):
    """A 1,000-run Monte Carlo (one chunk, pieces of 63 runs) stopped by Ctrl-C on its third
    model call."""
    raw = mc_config("tests.failing_models:ctrl_c_on_third_call", 1000, 8192, bootstrap=40)
    return run_to_ctrl_c(raw, tmp_path, monkeypatch)


def test_ctrl_c_in_a_single_chunk_keeps_its_pieces_and_resume_gives_the_same_numbers(
        ctrl_c_small, tmp_path):
    cfg, out, res = ctrl_c_small
    assert res.exit_code == 130
    assert res.stderr.strip().splitlines()[-1] == (
        f"interrupted: 0 of 1 chunks done and 126 runs of unfinished chunks; resume with "
        f"`uqguide run {cfg} --resume --out {out}`")
    lines = [json.loads(x) for x in (out / "cc.run" / "manifest.jsonl").read_text()
             .splitlines()][1:]
    assert [(e["kind"], e["start"], e["stop"], e["file"]) for e in lines] == [
        ("piece", 0, 63, "mc.s0.c000000.r000000000.npz"),
        ("piece", 63, 126, "mc.s0.c000000.r000000063.npz")]
    # without --resume the pieces are not thrown away silently
    again = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out)])
    assert again.exit_code == 2
    assert "holds an unfinished run (0 chunks done and 126 runs of unfinished chunks)" in \
        again.stderr
    failing_models._calls["n"] = 0
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "--resume"])
    assert res.exit_code == 0, res.output
    assert failing_models._calls["n"] == 16 - 2  # only the pieces not kept ran
    assert not (out / "cc.run").exists()  # the result holds everything: the folder is gone
    ref = tmp_path / "ref.yaml"
    ref.write_text(yaml.safe_dump(mc_config("tests.failing_models:clean_sum", 1000, 8192,
                                            bootstrap=40)))
    assert CliRunner().invoke(main, ["run", str(ref), "--out", str(tmp_path)]).exit_code == 0
    _assert_same(_stats(tmp_path / "ref.h5"), _stats(out / "cc.h5"))


def _interrupt_then_resume(tmp_path, executor_of) -> None:
    """The small FLAKY study stopped after 5 pieces, resumed, against an uninterrupted run."""
    cfg = validate_config(SMALL)
    folder = tmp_path / "s.run"
    identity = run_identity(cfg.resolved(), cfg.model)
    store = RunStore.open(folder, identity, resume=False)
    executor = executor_of()
    try:
        with pytest.raises(RunInterrupted) as stop:
            run(cfg, executor, store=store, progress=_Counted(stop_after=5))
    finally:
        executor.close()
        store.close()
    assert (stop.value.n_done, stop.value.n_total) == (0, 1)
    assert stop.value.in_pieces == 5 * 94  # each piece is queued before it is counted
    store = RunStore.open(folder, identity, resume=True)
    p = _Counted()
    executor = executor_of()
    try:
        resumed = run(cfg, executor, store=store, progress=p)
    finally:
        executor.close()
        store.close()
    assert p.runs_done == 1500 and p.chunks_done == 1
    assert p.methods[0].runs_evaluated == 1500 - 5 * 94  # only the pieces not kept ran
    _assert_identical(_arrays(run(validate_config(SMALL))), _arrays(resumed))


def test_an_interrupted_small_run_resumes_to_the_same_numbers_in_this_process(
        tmp_path, slow_model):
    from uqguide.driver.execution import SerialExecutor

    _interrupt_then_resume(tmp_path, SerialExecutor)


@pytest.mark.slow  # two worker processes start (imports: a few CPU-s)
def test_an_interrupted_small_run_resumes_to_the_same_numbers_with_two_workers(
        tmp_path, slow_model):
    from uqguide.driver.execution import ProcessExecutor

    _interrupt_then_resume(tmp_path, lambda: ProcessExecutor(2))
