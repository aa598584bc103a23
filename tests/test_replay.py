"""uqguide replay: a stored sample rerun reproduces its scalars bit for bit and writes its
histories and figures; the sample is chosen by number, as the worst of an output or as the
first in an event."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.config.run_config import validate_config
from uqguide.driver.propagate import run
from uqguide.results.result import read_hdf5, write_hdf5

TABLE4 = {
    "model": {"name": "ftcapn", "gravity": "none", "t_final": 95.0},
    "inputs": [{"name": n, "dist": "normal", "mean": 0.0, "std": s} for n, s in (
        ("dx", 15.0), ("dy", 15.0), ("dz", 15.0), ("dvx", 3.0), ("dvy", 3.0), ("dvz", 3.0),
        ("b_w", 1e-5), ("b_R", 5.0), ("at_theta", 0.1))],
    "outputs": ["zem", "t_stop", "dv_total", "omega_s"],
    "events": [{"name": "wide", "output": "zem", "above": 15.0}],
    # several chunks and model calls: the replayed sample ran inside a big batch
    "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 600, "chunk_size": 256,
                 "bootstrap": 0}],
    "batch_size": 100,
    "seed": 7,
    "name": "t4",
}


def _result(tmp_path: Path, **model) -> Path:
    cfg = {**TABLE4, "model": {**TABLE4["model"], **model}}
    return write_hdf5(run(validate_config(cfg)), tmp_path / "t4.h5")


@pytest.fixture
def no_figures(monkeypatch):
    """Replay without drawing (~2.5 CPU-s a replay): the tests of the choice and of the
    comparison; the figures are checked by the worst-zem test."""
    import uqguide.papers
    from uqguide.commands import replay

    monkeypatch.setattr(replay, "history_figure", lambda out, title, path: path)
    monkeypatch.setattr(uqguide.papers, "sample_figures", lambda *args: [])


@pytest.mark.slow
@pytest.mark.parametrize("kernel", ["numba", "numpy"])
def test_worst_zem_replays_bit_for_bit_with_histories_and_figures(tmp_path, kernel, request):
    if kernel == "numpy":  # the study and its replay on the NumPy oracle (tests/oracles)
        request.getfixturevalue("oracle_kernels")
    h5 = _result(tmp_path)
    res = read_hdf5(h5).run("mc")
    worst = int(np.nanargmax(res.scalars["zem"][:, 0]))
    out = CliRunner().invoke(main, ["replay", str(h5), "--label", "mc", "--worst", "zem",
                                    "--out", str(tmp_path / "rp")])
    assert out.exit_code == 0, out.output
    assert f"mc sample {worst}: largest zem" in out.output
    assert "bit for bit" in out.output and "DIFFER" not in out.output
    stem = tmp_path / "rp" / f"t4_mc_{worst}"
    for suffix in ("_history.csv", "_history.png", "_trajectory.png"):
        assert Path(f"{stem}{suffix}").stat().st_size > 0
    hist = np.genfromtxt(f"{stem}_history.csv", delimiter=",", names=True)
    # the history ends at the grid's end; the range there is the stop range (50 m)
    assert hist["time"][-1] == pytest.approx(95.0)
    assert hist["R"][-1] == pytest.approx(50.0, abs=1e-6)


def test_event_picks_the_first_sample_in_the_event(tmp_path, no_figures):
    h5 = _result(tmp_path)
    zem = read_hdf5(h5).run("mc").scalars["zem"][:, 0]
    first = int(np.flatnonzero(zem > 15.0)[0])
    out = CliRunner().invoke(main, ["replay", str(h5), "--label", "mc", "--event", "wide",
                                    "--out", str(tmp_path / "rp")])
    assert out.exit_code == 0, out.output
    assert f"mc sample {first}: first of the {int((zem > 15.0).sum())} samples" in out.output


def _changed(h5: Path, factor: float) -> None:
    """Sample 3's stored t_stop moved by one ulp (factor 0) or by ``factor`` relative."""
    with h5py.File(h5, "r+") as f:
        d = f["methods/mc/samples/scalars/t_stop"]
        v = d[()]
        v[3, 0] = np.nextafter(v[3, 0], np.inf) if factor == 0 else v[3, 0] * (1 + factor)
        d[...] = v


def test_a_changed_stored_scalar_is_reported_and_exits_1(tmp_path, no_figures):
    h5 = _result(tmp_path)
    _changed(h5, 1e-6)  # a change of the code moves a scalar by this and more
    out = CliRunner().invoke(main, ["replay", str(h5), "--label", "mc", "--sample", "3",
                                    "--out", str(tmp_path / "rp")])
    assert out.exit_code == 1
    assert "DIFFER (1.0e-06)" in out.output and "t_stop" in out.output


def test_a_one_ulp_difference_is_round_off_unless_exact(tmp_path, no_figures):
    """Another CPU moves the last bits: one ulp is round-off (exit 0, and it says so), and
    --exact, the check on the machine that wrote the result, refuses it."""
    h5 = _result(tmp_path)
    _changed(h5, 0.0)
    args = ["replay", str(h5), "--label", "mc", "--sample", "3", "--out", str(tmp_path / "rp")]
    out = CliRunner().invoke(main, args)
    assert out.exit_code == 0, out.output
    assert "round-off (" in out.output and "equal the stored ones to round-off" in out.output
    exact = CliRunner().invoke(main, args + ["--exact"])
    assert exact.exit_code == 1 and "t_stop" in exact.output


@pytest.mark.parametrize("args, words", [
    (["--sample", "600"], "--sample: 600 is out of range"),
    (["--sample", "1", "--worst", "zem"], "exactly one of"),
    (["--event", "nope"], "--event: 'nope' is not an event"),
    (["--worst", "omega_s"], "--worst: 'omega_s' is not a stored scalar"),
])
def test_bad_choices_exit_2_with_one_line(tmp_path, args, words):
    h5 = _result(tmp_path)
    out = CliRunner().invoke(main, ["replay", str(h5), "--label", "mc", *args])
    assert out.exit_code == 2
    assert words in out.output and "Traceback" not in out.output


@pytest.mark.slow
def test_without_out_the_replay_writes_under_the_current_folder_never_beside_the_result(
        tmp_path, monkeypatch):
    stored = tmp_path / "stored"
    stored.mkdir()
    h5 = _result(stored)
    before = sorted(p.name for p in stored.iterdir())
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    out = CliRunner().invoke(main, ["replay", str(h5), "--label", "mc", "--sample", "0"])
    assert out.exit_code == 0, out.output
    assert sorted(p.name for p in stored.iterdir()) == before  # nothing beside the result
    written = sorted(p.name for p in (work / "replay").iterdir())
    assert "t4_mc_0_history.csv" in written
    assert f"wrote {Path('replay') / 't4_mc_0_history.csv'}" in out.output
