"""Progress of a run, method by method: chunks and runs done, failed, elapsed time and ETA,
or the phase a method is in when it is not running chunks (compiling a kernel, fitting).

The driver counts (chunks planned per method, restored from a checkpoint, evaluated); what is
shown is the current method's own counts, so a fast Monte Carlo of 1e5 runs and a PCE of 300
slow ones are not summed into one bar. What is shown depends on where it goes:

- a terminal: one status line redrawn in place at most every ``refresh`` seconds, e.g.
  ``[##########----------] mc 61/123 chunks  499,712/1,000,000 runs  3 failed  1m02s  ETA 1m03s``
  (``apce (2/3) ...`` when the run has several methods);
- anything else (a CI log, a file): a plain line every ``interval`` seconds (10 by default),
  and a closing line if any was printed, so logs stay short.

The ETA extrapolates the runs this method evaluated in this session, over the time it spent
running them (chunks restored from a checkpoint do not count as speed, time in a phase does
not count as time), to its runs still to do. It is not shown during a phase, nor
once the method's runs are all done: what follows them (a fit) is not paced by runs, and an
"ETA 0s" through a 30-s fit would mislead; the phase is shown instead. The stream is chosen by
the command line; the library passes ``None`` (count only, show nothing).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import TextIO


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
    """One method's share of a run.

    Attributes
    ----------
    label : str
        The method's label ("" for work planned before a method is named).
    chunks_total, chunks_done, runs_total, runs_done, runs_failed : int
        Its planned and finished chunks and runs (restored ones included).
    runs_evaluated : int
        Runs evaluated in this session (the ETA's speed).
    started : float or None
        ``time.monotonic()`` when the method started; None before.
    in_phases : float
        Seconds it spent in phases (compiling, fitting), left out of its speed.
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

    Parameters
    ----------
    stream : text stream, optional
        Where to show progress (``None``: nowhere).
    tty : bool, optional
        Whether ``stream`` is a terminal (default: ``stream.isatty()``).
    interval : float
        Seconds between plain lines off a terminal.
    refresh : float
        Seconds between redraws on a terminal.

    Attributes
    ----------
    chunks_total, chunks_done, runs_total, runs_done, runs_failed : int
        The whole run's counts (all methods).
    methods : list of MethodCount
        Each method's counts, in the order they were planned.
    phase_text : str
        What the current method does besides chunks ("" while it runs them).
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
        #: What runs besides chunks (compiling a kernel, fitting a PCE), shown in the status.
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

    @property
    def label(self) -> str:
        return self.current.label

    def _unlabelled(self) -> MethodCount:
        for m in self.methods:
            if not m.label and m.started is None:
                return m
        m = MethodCount("")
        self.methods.append(m)
        return m

    def plan(self, n_chunks: int, n_runs: int, label: str | None = None) -> None:
        """Add chunks / runs to do (a design or a refinement).

        Parameters
        ----------
        n_chunks, n_runs : int
        label : str, optional
            The method they belong to; default the current one (a refinement), or, before any
            method started, the next one to start.
        """
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
        """What the run does now besides evaluating chunks (empty: back to chunks).

        Parameters
        ----------
        text : str
            Shown as it is (``"compiling the ftcapn kernel"``, ``"fitting zem (2/7)"``).
        """
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

    def restored(self, n_runs: int, n_failed: int) -> None:
        """One chunk taken from the checkpoint."""
        self._count(n_runs, n_failed)

    def advance(self, n_runs: int, n_failed: int) -> None:
        """One chunk evaluated."""
        self._set_phase("")  # a chunk came back: whatever preceded it (a compile) is over
        self._count(n_runs, n_failed)
        self.current.runs_evaluated += n_runs
        self._show()

    def _count(self, n_runs: int, n_failed: int) -> None:
        m = self.current
        m.chunks_done += 1
        m.runs_done += n_runs
        m.runs_failed += n_failed
        self.chunks_done += 1
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
        """The current method's label, with its place when the run has several
        (``apce (2/3)``)."""
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
            frac = m.chunks_done / m.chunks_total if m.chunks_total else 0.0
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
        if self.tty:
            self._last_show = 0.0
            self._show(force=True)
            self.stream.write("\n")
        else:
            self.stream.write(f"progress: {self.status()}\n")
        self.stream.flush()
        self._shown = False
