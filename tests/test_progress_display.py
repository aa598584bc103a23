"""The progress display of `uqguide run`: a bar redrawn in place on a terminal (with the compile
and the PCE fit phases), a few plain lines elsewhere, nothing with -q."""

from __future__ import annotations

import pytest
import io
import re
import subprocess
import sys
import time
from pathlib import Path

import yaml

from uqguide.models import kernels
from uqguide.driver.progress import BarProgress, PlainProgress, make_progress


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
    kernels.notice_sink("uqguide: compiled the ftcapn kernel in 21.3 CPU-s (65.1 s wall)", "")
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
    assert "uqguide: compiled the ftcapn kernel in 21.3 CPU-s (65.1 s wall)\n" in out
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


@pytest.mark.slow
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


@pytest.mark.slow
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
    bars = [f for f in frames if "chunks]" in f or "chunks, ETA" in f]
    assert any(f.startswith("apce: fitting y (1/1") for f in bars)
    assert any(f.startswith("apce: surrogate statistics of y") for f in bars)
    piped = subprocess.run([uq, "run", str(path), "--out", str(tmp_path)],
                           capture_output=True, text=True, timeout=300)
    assert "\r" not in piped.stderr and "chunks]" not in piped.stderr


def test_each_method_shows_its_own_counts_and_a_phase_instead_of_eta_after_its_runs():
    log = io.StringIO()
    p = PlainProgress(log, interval=0.0)
    p.plan(1, 1000, "mc")
    p.plan(3, 300, "apce")
    p.start("mc")
    p.advance(1000, 2)
    p.start("apce")
    p.advance(100, 0)
    p.advance(100, 1)
    p.advance(100, 0)
    p.phase("fitting y (1/1, 300 runs)")
    p.plan(1, 50)  # a refinement: more runs of the current method
    p.phase("")
    p.advance(50, 0)
    p.close()
    assert (p.chunks_total, p.runs_total, p.runs_done, p.runs_failed) == (5, 1350, 1350, 3)
    lines = log.getvalue().splitlines()
    assert re.fullmatch(r"progress: mc \(1/2\) 1/1 chunks  1,000/1,000 runs  2 failed  \d+s",
                        lines[1])
    assert re.fullmatch(r"progress: apce \(2/2\) 0/3 chunks  0/300 runs  0 failed  \d+s",
                        lines[2])
    assert re.fullmatch(r"progress: apce \(2/2\) 1/3 chunks  100/300 runs  0 failed  \d+s  "
                        r"ETA \d+s", lines[3])
    # its runs done, the method fits: the phase is shown, never an ETA of 0 s
    assert re.fullmatch(r"progress: apce \(2/2\) 3/3 chunks  300/300 runs  1 failed  \d+s",
                        lines[5])
    assert re.fullmatch(r"progress: apce \(2/2\) 3/3 chunks  300/300 runs  1 failed  \d+s  "
                        r"fitting y \(1/1, 300 runs\)", lines[6])
    # the refinement's runs are still to do: paced by runs again
    assert re.fullmatch(r"progress: apce \(2/2\) 3/4 chunks  300/350 runs  1 failed  \d+s  "
                        r"ETA \d+s", lines[7])
    assert lines[-1].startswith("progress: apce (2/2) 4/4 chunks  350/350 runs")
    assert not any("ETA" in ln for ln in lines if "1,000/1,000" in ln or "300/300" in ln)


def test_on_a_terminal_each_method_gets_its_own_bar_and_keeps_it():
    term = _Terminal()
    p = make_progress(term)
    p.plan(2, 2000, "mc")
    p.plan(3, 300, "apce")
    p.start("mc")
    p.advance(1000, 0)
    p.advance(1000, 0)
    p.start("apce")
    p.advance(100, 0)
    p.phase("compiling the gmm kernel")  # any phase name is shown as it is given
    p.close()
    out = term.getvalue()
    # the mc bar is left whole on its own line when apce starts; apce's bar is the next line
    mc_line, apce_line, rest = out.split("\n")
    assert rest == ""
    mc_final = mc_line.split("\r")[-1]
    assert mc_final.startswith("mc (1/2) |") and "2/2 chunks" in mc_final
    assert mc_final.endswith("2,000/2,000 runs, 0 failed, 2/2 chunks]")  # done: no ETA
    frames = [f for f in apce_line.split("\r") if f.startswith("apce")]
    assert frames and all(f.startswith("apce (2/2)") and "/3 chunks" in f for f in frames)
    assert any("100/300 runs, 0 failed" in f for f in frames)
    assert any(f.startswith("apce (2/2): compiling the gmm kernel |") and "ETA" not in f
               for f in frames)


def test_a_run_of_two_methods_counts_each_and_names_its_phases():
    """Through the driver: per-method counts, the fit's phases, no ETA once runs are done."""
    import uqguide
    from uqguide.driver.propagate import run

    cfg = uqguide.load_config({
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
                   {"name": "x2", "dist": "uniform", "low": 0.0, "high": 2.0}],
        "outputs": ["y"], "batch_size": 500,
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 1500},
                    {"name": "pce_adaptive", "label": "apce", "n_samples": 40,
                     "validation": {"n_samples": 20}}]})
    log = io.StringIO()
    run(cfg, progress=PlainProgress(log, interval=0.0))
    lines = log.getvalue().splitlines()
    mc = [ln for ln in lines if ln.startswith("progress: mc (1/2) ")]
    apce = [ln for ln in lines if ln.startswith("progress: apce (2/2) ")]
    assert mc and apce and len(mc) + len(apce) == len(lines)
    assert all(re.search(r" \d/\d chunks  [\d,]+/1,500 runs", ln) for ln in mc)
    # 40 fit runs, then 20 validation runs planned by the refinement
    assert any("1/1 chunks  40/40 runs" in ln and "fitting y" in ln for ln in apce)
    assert any("2/2 chunks  60/60 runs" in ln and "estimating" in ln for ln in apce)
    for ln in lines:
        done = re.search(r"([\d,]+)/([\d,]+) runs", ln)
        assert done is not None
        if done.group(1) == done.group(2):
            assert "ETA" not in ln, ln


def test_the_eta_paces_the_method_by_its_runs_not_by_its_phases(monkeypatch):
    """A fake clock: 100 runs in 10 s, then a 30-s fit, leave 100 runs for 10 s more, not 40."""
    from types import SimpleNamespace

    from uqguide.driver import progress as progress_module

    now = [1000.0]
    # the module's clock only, not the time module everyone shares
    monkeypatch.setattr(progress_module, "time", SimpleNamespace(monotonic=lambda: now[0]))
    p = progress_module.Progress(None)
    p.plan(1, 100, "mc")
    p.plan(1, 100, "apce")
    p.start("mc")
    now[0] += 50.0
    p.advance(100, 0)  # mc's speed is not apce's
    p.start("apce")
    p.plan(1, 100)  # a refinement of apce: 200 runs in all
    now[0] += 10.0
    p.advance(100, 0)
    assert p.eta_seconds() == 10.0
    p.phase("fitting y (1/1, 100 runs)")
    now[0] += 30.0
    assert p.eta_seconds() is None and p.status().endswith("  fitting y (1/1, 100 runs)")
    p.phase("")
    assert p.eta_seconds() == 10.0
    assert p.status() == "apce (2/2) 1/2 chunks  100/200 runs  0 failed  40s  ETA 10s"
    p.advance(100, 0)
    assert p.eta_seconds() is None  # its runs done: whatever follows is not paced by runs
