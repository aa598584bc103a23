"""Progress of a run: chunks and runs done, failed, elapsed time and ETA.

The driver counts (chunks planned, restored from a checkpoint, evaluated); what is shown
depends on where it goes:

- a terminal: one status line redrawn in place at most every ``refresh`` seconds, e.g.
  ``[##########----------] mc 61/123 chunks  499,712/1,000,000 runs  3 failed  1m02s  ETA 1m03s``
- anything else (a CI log, a file): a plain line every ``interval`` seconds (10 by default),
  and a closing line if any was printed, so logs stay short.

The ETA extrapolates the runs evaluated in this session (chunks restored from a checkpoint do
not count as speed). The stream is chosen by the command line; the library passes ``None``
(count only, show nothing).
"""

from __future__ import annotations

import time
from typing import TextIO


def _hms(seconds: float) -> str:
    s = int(round(seconds))
    if s < 60:
        return f"{s}s"
    if s < 3600:
        return f"{s // 60}m{s % 60:02d}s"
    return f"{s // 3600}h{s % 3600 // 60:02d}m"


class Progress:
    """Counters of a whole run, optionally shown on ``stream``.

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
    """

    def __init__(self, stream: TextIO | None = None, tty: bool | None = None,
                 interval: float = 10.0, refresh: float = 0.2) -> None:
        self.stream = stream
        self.tty = bool(stream is not None and (stream.isatty() if tty is None else tty))
        self.interval = interval
        self.refresh = refresh
        self.label = ""
        self.chunks_total = 0
        self.chunks_done = 0
        self.runs_total = 0
        self.runs_done = 0
        self.runs_failed = 0
        self._runs_evaluated = 0
        #: What runs besides chunks (compiling a kernel, fitting a PCE), shown in the status.
        self.phase_text = ""
        self._t0 = time.monotonic()
        self._last_show = self._t0
        self._shown = False

    # -------------------------------------------------------------- counting
    def plan(self, n_chunks: int, n_runs: int) -> None:
        """Add chunks / runs to do (a design or a refinement)."""
        self.chunks_total += n_chunks
        self.runs_total += n_runs

    def start(self, label: str) -> None:
        """The method whose chunks follow (shown in the status)."""
        self.label = label
        self.phase_text = ""
        self._show(force=self.tty)

    def phase(self, text: str) -> None:
        """What the run does now besides evaluating chunks (empty: back to chunks)."""
        self.phase_text = text
        self._show()

    def restored(self, n_runs: int, n_failed: int) -> None:
        """One chunk taken from the checkpoint."""
        self.chunks_done += 1
        self.runs_done += n_runs
        self.runs_failed += n_failed

    def advance(self, n_runs: int, n_failed: int) -> None:
        """One chunk evaluated."""
        self.phase_text = ""  # a chunk came back: whatever preceded it (a compile) is over
        self.chunks_done += 1
        self.runs_done += n_runs
        self.runs_failed += n_failed
        self._runs_evaluated += n_runs
        self._show()

    # -------------------------------------------------------------- showing
    def eta_seconds(self) -> float | None:
        elapsed = time.monotonic() - self._t0
        if self._runs_evaluated == 0 or elapsed <= 0:
            return None
        rate = self._runs_evaluated / elapsed
        return max(self.runs_total - self.runs_done, 0) / rate

    def status(self) -> str:
        """The status text (without the bar)."""
        eta = None if self.phase_text else self.eta_seconds()
        return (f"{self.label} {self.chunks_done}/{self.chunks_total} chunks  "
                f"{self.runs_done:,}/{self.runs_total:,} runs  {self.runs_failed:,} failed  "
                f"{_hms(time.monotonic() - self._t0)}"
                + (f"  ETA {_hms(eta)}" if eta is not None else "")
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
            frac = self.chunks_done / self.chunks_total if self.chunks_total else 0.0
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
