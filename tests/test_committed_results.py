"""The committed results/ agree with today's code: one Monte Carlo sample of every committed
result file is rerun and must give its stored scalars to round-off (``uqguide replay``'s check:
bit for bit on the machine that wrote them, within 1e-9 relative on another CPU, whose kernels
may move the last bits; :data:`uqguide.commands.replay.ROUNDOFF`).

A failure here means the committed results are stale (older than the code or a dependency):
regenerate them with ``python scripts/reproduce_results.py``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from uqguide.commands.replay import ROUNDOFF, replay
from uqguide.results.result import read_hdf5

RESULTS = Path(__file__).resolve().parents[1] / "results"
FILES = sorted(RESULTS.glob("*/*.h5"))


def first_good_mc_sample(path: Path) -> tuple[str, int] | None:
    """The label of the result's first Monte Carlo method and its first sample that did not
    fail, or None when the file holds no Monte Carlo samples."""
    result = read_hdf5(path)
    for run in result.runs:
        if run.estimate.method != "monte_carlo" or run.x.shape[0] == 0:
            continue
        ok = np.flatnonzero(~np.asarray(run.failed, dtype=bool))
        if ok.size:
            return run.label, int(ok[0])
    return None


def replay_mismatches(path: Path) -> list[str]:
    """Scalar outputs whose replay differs from the stored value (empty: agrees)."""
    chosen = first_good_mc_sample(path)
    assert chosen is not None, f"{path}: no Monte Carlo sample to replay"
    label, index = chosen
    rep, _ = replay(read_hdf5(path), label, sample=index, worst=None, lowest=False, event=None)
    return rep.mismatches(ROUNDOFF)


def test_there_are_committed_results_to_check():
    assert len(FILES) >= 5, f"expected committed result files under {RESULTS}"


@pytest.mark.parametrize("path", FILES, ids=[p.parent.name for p in FILES])
def test_a_committed_result_replays_to_round_off(path):
    bad = replay_mismatches(path)
    assert not bad, (f"{path.relative_to(RESULTS.parent)}: replayed scalars differ from the "
                     f"stored ones ({', '.join(bad)}); the committed result is older than the "
                     f"code: regenerate it with `python scripts/reproduce_results.py "
                     f"{path.parent.name}`")
