"""The progress display of `uqguide run`: a bar redrawn in place on a terminal (with the compile
and the PCE fit phases), a few plain lines elsewhere, nothing with -q."""

from __future__ import annotations

import io
import subprocess
import sys
import time
from pathlib import Path

import yaml

from uqguide.models import kernels
from uqguide.driver.progress_display import BarProgress, PlainProgress, make_progress


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_on_a_terminal_one_bar_is_redrawn_in_place_with_the_phase():
    term = _Terminal()
    p = make_progress(term)
    assert isinstance(p, BarProgress)
    p.plan(4, 400)
    p.start("apce")
    kernels.notice_sink("uqguide: compiling the ftcapn kernel (once per install; ...)",
                        "compiling the ftcapn kernel")
    time.sleep(2.5 * p.refresh)  # the ticker redraws the phase while the compile lasts
    kernels.notice_sink("uqguide: compiled the ftcapn kernel in 21.3 s", "")
    p.advance(100, 1)
    p.phase("fitting zem (2/7, 300 runs)")
    time.sleep(2.5 * p.refresh)  # the ticker redraws while nothing else happens
    p.close()
    out = term.getvalue()
    assert kernels.notice_sink is None  # the compile notice goes back to stderr afterwards
    before_close = out[:out.rindex("\r")]
    # the compile lines are printed whole above the bar; the bar itself never starts a new line
    assert before_close.count("\n") == 2
    assert "uqguide: compiling the ftcapn kernel (once per install; ...)\n" in out
    assert "uqguide: compiled the ftcapn kernel in 21.3 s\n" in out
    frames = [f for f in out.split("\r") if "chunks" in f]
    compiling = [f for f in frames if f.startswith("apce: compiling the ftcapn kernel |")]
    assert len(compiling) >= 2  # a live phase: redrawn while it lasts
    assert not any(f.startswith("apce: compiled") for f in frames)  # over: not a phase
    fitting = [f for f in frames if f.startswith("apce: fitting zem (2/7, 300 runs) |")]
    assert len(fitting) >= 2  # redrawn by the ticker during the fit
    assert all("1/4 chunks" in f and "100/400 runs, 1 failed" in f for f in fitting)
    assert out.endswith("\n")


def test_off_a_terminal_few_plain_lines_and_no_repeated_last_line():
    log = io.StringIO()
    p = make_progress(log)
    assert isinstance(p, PlainProgress)
    p.interval = 0.0
    p.plan(2, 200)
    p.start("mc")
    p.advance(100, 0)
    p.advance(100, 0)
    p.close()  # the last line already says 2/2 chunks: not printed again
    lines = log.getvalue().splitlines()
    assert all(ln.startswith("progress: mc ") for ln in lines)
    assert lines[-1].startswith("progress: mc 2/2 chunks")
    assert sum("2/2 chunks" in ln for ln in lines) == 1
    slow = io.StringIO()
    q = make_progress(slow)  # the default 10 s interval: a short run prints nothing
    q.plan(1, 10)
    q.start("mc")
    q.advance(10, 0)
    q.close()
    assert slow.getvalue() == ""


def test_quiet_shows_nothing(tmp_path):
    cfg = {"model": {"name": "linear_gaussian"},
           "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}],
           "methods": [{"name": "pce_tensor", "label": "t", "m": 2}]}
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    uq = str(Path(sys.executable).parent / "uqguide")
    p = subprocess.run([uq, "run", str(path), "--out", str(tmp_path), "-q"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    assert p.stderr == ""


def test_in_a_pseudo_terminal_the_pce_fit_shows_its_phases(tmp_path):
    import shutil

    import pytest

    if shutil.which("script") is None:
        pytest.skip("util-linux `script` (a pseudo-terminal) is not installed")
    cfg = {"model": {"name": "ishigami"},
           "inputs": [{"name": f"x{i}", "dist": "uniform", "low": -3.14159, "high": 3.14159}
                      for i in (1, 2, 3)],
           "methods": [{"name": "pce_adaptive", "label": "apce", "n_samples": 60,
                        "max_runs": 120, "degree_max": 6, "surrogate_draws": 100000}]}
    path = tmp_path / "c.yaml"
    path.write_text(yaml.safe_dump(cfg))
    uq = str(Path(sys.executable).parent / "uqguide")
    log = tmp_path / "tty.log"
    subprocess.run(["script", "-qc", f"{uq} run {path} --out {tmp_path}", str(log)],
                   capture_output=True, timeout=300, check=True)
    frames = log.read_bytes().decode("utf-8", "replace").split("\r")
    bars = [f for f in frames if "chunks [" in f]
    assert any(f.startswith("apce: fitting y (1/1") for f in bars)
    assert any(f.startswith("apce: surrogate statistics of y") for f in bars)
    piped = subprocess.run([uq, "run", str(path), "--out", str(tmp_path)],
                           capture_output=True, text=True, timeout=300)
    assert "\r" not in piped.stderr and "chunks [" not in piped.stderr
