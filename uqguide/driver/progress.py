"""Progress of a run, method by method: counting it, and showing it.

:class:`Progress` counts (chunks planned per method, restored from a checkpoint, evaluated;
the phase a method is in when it runs no chunks: a kernel compile, a fit) and paces the ETA by
the runs this method evaluated in this session; the library passes no stream (count only).
``uqguide run`` shows it through :func:`make_progress`: a tqdm bar per method on a terminal
(:class:`BarProgress`), a plain line at most every ``interval`` seconds elsewhere
(:class:`PlainProgress`), nothing with ``-q``.

What is shown, and why the ETA skips phases: docs/scale.md, "Progress".
"""

from __future__ import annotations

import os
import threading
import time
from dataclasses import dataclass
from typing import Any, TextIO


def hms(seconds: float) -> str:
    """``seconds`` as ``42s``, ``1m02s`` or ``2h05m``."""
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


@dataclass
class MethodCount:
    """One method's share of a run (``label`` "" for work planned before a method is named).

    The counts include restored chunks; ``runs_evaluated`` (this session's) and the time
    ``started`` less ``in_phases`` (compiling, fitting) give the ETA's speed.
    """

    label: str
    chunks_total: int = 0
    chunks_done: int = 0
    runs_total: int = 0
    runs_done: int = 0
    runs_failed: int = 0
    runs_evaluated: int = 0
    started: float | None = None
    in_phases: float = 0.0


class Progress:
    """Counters of a whole run and of each of its methods, optionally shown on ``stream``.

    ``tty`` defaults to ``stream.isatty()``; ``interval``: seconds between plain lines off a
    terminal; ``refresh``: seconds between redraws on one.
    """

    def __init__(self, stream: TextIO | None = None, tty: bool | None = None,
                 interval: float = 10.0, refresh: float = 0.2) -> None:
        self.stream = stream
        self.tty = bool(stream is not None and (stream.isatty() if tty is None else tty))
        self.interval = interval
        self.refresh = refresh
        self.chunks_total = 0
        self.chunks_done = 0
        self.runs_total = 0
        self.runs_done = 0
        self.runs_failed = 0
        self.methods: list[MethodCount] = []
        self._current: MethodCount | None = None
        #: What the current method does besides chunks (compiling, fitting); "" while it runs them.
        self.phase_text = ""
        self._phase_since: float | None = None
        self._t0 = time.monotonic()
        self._last_show = self._t0
        self._shown = False

    # -------------------------------------------------------------- counting
    @property
    def current(self) -> MethodCount:
        """The method whose chunks arrive now (before any is started: the work planned so
        far without a label)."""
        if self._current is None:
            self._current = self._unlabelled()
        return self._current

    def _unlabelled(self) -> MethodCount:
        for m in self.methods:
            if not m.label and m.started is None:
                return m
        m = MethodCount("")
        self.methods.append(m)
        return m

    def plan(self, n_chunks: int, n_runs: int, label: str | None = None) -> None:
        """Add chunks / runs to do to the method ``label`` (default: the current one, or before
        any started, the next)."""
        self.chunks_total += n_chunks
        self.runs_total += n_runs
        if label is None:
            m = self._current or self._unlabelled()
        else:
            m = next((c for c in self.methods if c.label == label), None) or MethodCount(label)
            if m not in self.methods:
                self.methods.append(m)
        m.chunks_total += n_chunks
        m.runs_total += n_runs

    def start(self, label: str) -> None:
        """The method whose chunks follow (its counts are shown from now on)."""
        m = next((c for c in self.methods if c.label == label and c.started is None), None)
        if m is None:  # planned without a label (or not at all): the work is this method's
            m = self._unlabelled()
            m.label = label
        m.started = time.monotonic()
        self._current = m
        self.phase_text, self._phase_since = "", None
        self._show(force=self.tty)

    def phase(self, text: str) -> None:
        """What the run does now besides chunks (``"fitting zem (2/7)"``; "": back to chunks)."""
        self._set_phase(text)
        self._show()

    def _set_phase(self, text: str) -> None:
        # time in a phase is not time running chunks: it is kept out of the ETA's speed
        now = time.monotonic()
        if text and self._phase_since is None:
            self._phase_since = now
        elif not text and self._phase_since is not None:
            self.current.in_phases += now - self._phase_since
            self._phase_since = None
        self.phase_text = text

    def restored(self, n_runs: int, n_failed: int, chunks: int = 1) -> None:
        """Runs taken from the checkpoint: a chunk (``chunks=0``: a piece of one)."""
        self._count(n_runs, n_failed, chunks)

    def advance(self, n_runs: int, n_failed: int, chunks: int = 1) -> None:
        """Runs evaluated: a chunk, or a model call's piece of one that completes ``chunks``
        (0 or 1) chunks."""
        self._set_phase("")  # runs came back: whatever preceded them (a compile) is over
        self._count(n_runs, n_failed, chunks)
        self.current.runs_evaluated += n_runs
        self._show()

    def _count(self, n_runs: int, n_failed: int, chunks: int) -> None:
        m = self.current
        m.chunks_done += chunks
        m.runs_done += n_runs
        m.runs_failed += n_failed
        self.chunks_done += chunks
        self.runs_done += n_runs
        self.runs_failed += n_failed

    # -------------------------------------------------------------- showing
    def eta_seconds(self) -> float | None:
        """Seconds until the current method's runs are done, at its speed so far; None
        during a phase, once its runs are done, or before one was evaluated."""
        m = self.current
        left = m.runs_total - m.runs_done
        if self.phase_text or left <= 0 or m.runs_evaluated == 0:
            return None
        running = self.elapsed_seconds() - m.in_phases
        return left * running / m.runs_evaluated if running > 0 else None

    def elapsed_seconds(self) -> float:
        """Seconds since the current method started (since the run started before one)."""
        m = self.current
        return time.monotonic() - (self._t0 if m.started is None else m.started)

    def title(self) -> str:
        """The current method's label, with its place among several (``apce (2/3)``)."""
        m = self.current
        named = [c for c in self.methods if c.label or c.runs_total]
        if len(named) < 2 or m not in named:
            return m.label
        return f"{m.label} ({named.index(m) + 1}/{len(named)})"

    def status(self) -> str:
        """The status text (without the bar)."""
        m, eta = self.current, self.eta_seconds()
        return (f"{self.title()} {m.chunks_done}/{m.chunks_total} chunks  "
                f"{m.runs_done:,}/{m.runs_total:,} runs  {m.runs_failed:,} failed  "
                f"{hms(self.elapsed_seconds())}"
                + (f"  ETA {hms(eta)}" if eta is not None else "")
                + (f"  {self.phase_text}" if self.phase_text else ""))

    def _show(self, force: bool = False) -> None:
        if self.stream is None:
            return
        now = time.monotonic()
        wait = self.refresh if self.tty else self.interval
        if not force and now - self._last_show < wait:
            return
        self._last_show = now
        if self.tty:
            m = self.current
            frac = min(m.runs_done / m.runs_total, 1.0) if m.runs_total else 0.0
            bar = "#" * int(20 * frac) + "-" * (20 - int(20 * frac))
            self.stream.write(f"\r[{bar}] {self.status()}\x1b[K")
        else:
            self.stream.write(f"progress: {self.status()}\n")
        self.stream.flush()
        self._shown = True

    def close(self) -> None:
        """End the display: a final line (terminal: the bar's line is kept)."""
        if self.stream is None or not self._shown:
            return
        self._show(force=True)
        if self.tty:
            self.stream.write("\n")
            self.stream.flush()
        self._shown = False


# ---------------------------------------------------------------------------- showing
class PlainProgress(Progress):
    """Off a terminal: occasional plain lines, never the same counts twice."""

    def __init__(self, stream: TextIO, interval: float = 10.0) -> None:
        super().__init__(stream, tty=False, interval=interval)
        self._last_counts: tuple[Any, ...] | None = None

    def _counts(self) -> tuple[Any, ...]:
        m = self.current
        return (self.title(), m.chunks_done, m.chunks_total, m.runs_done, m.runs_failed,
                self.phase_text)

    def _show(self, force: bool = False) -> None:
        if self._counts() == self._last_counts:
            return
        before = self._last_show
        super()._show(force)
        if self._last_show != before:
            self._last_counts = self._counts()

    def close(self) -> None:
        if self._shown and self._counts() != self._last_counts:
            super().close()
        self._shown = False


class BarProgress(Progress):
    """On a terminal: a tqdm bar of the runs with the current method and phase."""

    def __init__(self, stream: TextIO, refresh: float = 0.5) -> None:
        super().__init__(stream, tty=True, refresh=refresh)
        self._bar: Any = None
        self._bar_of: MethodCount | None = None
        self._stop = threading.Event()
        self._ticker: threading.Thread | None = None
        self._draw_lock = threading.Lock()

    def _new_bar(self) -> Any:
        from tqdm import tqdm

        # A terminal that reports no width (a pseudo-terminal without a size) would get an
        # empty bar from tqdm: give it a fixed width instead.
        try:
            sized = (self.stream is not None
                     and os.get_terminal_size(self.stream.fileno()).columns > 0)
        except (AttributeError, OSError, ValueError):
            sized = False
        self._bar_of = self.current
        # desc from the start: tqdm draws the bar once as it is made
        return tqdm(total=self.current.runs_total or None, desc=self.title(),
                    file=self.stream, unit="run",
                    dynamic_ncols=sized, ncols=None if sized else 100,
                    nrows=None if sized else 24, leave=True,
                    mininterval=0, postfix=self._counts_text(),
                    bar_format="{desc} |{bar}| [{elapsed}{postfix}]")

    def _open(self) -> None:
        from ..models import kernels

        self._bar = self._new_bar()
        kernels.notice_sink = self._notice
        # log lines (warnings during a fit) go above the bar too
        from tqdm.contrib.logging import logging_redirect_tqdm

        self._logging = logging_redirect_tqdm()
        self._logging.__enter__()
        self._ticker = threading.Thread(target=self._tick, name="uqguide-progress",
                                        daemon=True)
        self._ticker.start()

    def _tick(self) -> None:
        while not self._stop.wait(self.refresh):
            self._draw()

    def _notice(self, text: str, phase: str) -> None:
        from tqdm import tqdm

        with self._draw_lock:
            tqdm.write(text, file=self.stream)
        self.phase(phase)

    def _draw(self) -> None:
        with self._draw_lock:
            b = self._bar
            if b is None:
                return
            if self._bar_of is not self.current:
                # the next method started: its predecessor's bar stays, final, on its line
                b.close()
                self._bar = b = self._new_bar()
            m = self.current
            b.total = m.runs_total or None
            b.n = m.runs_done
            desc = self.title() + (f": {self.phase_text}" if self.phase_text else "")
            b.set_description_str(desc, refresh=False)
            b.set_postfix_str(self._counts_text(), refresh=False)
            b.refresh()

    def _counts_text(self) -> str:
        m, eta = self.current, self.eta_seconds()
        return (f"{m.runs_done:,}/{m.runs_total:,} runs, {m.runs_failed:,} failed, "
                f"{m.chunks_done}/{m.chunks_total} chunks"
                + (f", ETA {hms(eta)}" if eta is not None else ""))

    def _show(self, force: bool = False) -> None:
        if self._bar is None:
            self._open()
        self._shown = True
        self._draw()

    def close(self) -> None:
        if self._bar is None:
            return
        from ..models import kernels

        self._stop.set()
        if self._ticker is not None:
            self._ticker.join()
        self.phase_text = ""
        self._draw()
        with self._draw_lock:
            self._bar.close()
            self._bar = None
        if kernels.notice_sink == self._notice:
            kernels.notice_sink = None
        self._logging.__exit__(None, None, None)
        self._shown = False


def make_progress(stream: TextIO | None, quiet: bool = False) -> Progress:
    """A bar on a terminal ``stream``, plain lines elsewhere, none if ``quiet`` or None."""
    if quiet or stream is None:
        return Progress(None)
    isatty = getattr(stream, "isatty", None)
    if isatty is not None and isatty():
        return BarProgress(stream)
    return PlainProgress(stream)
