"""How ``uqguide run`` shows its progress: a tqdm bar on a terminal, a few plain lines elsewhere.

- On a terminal: one bar per method, redrawn in place, ``apce (2/3): fitting zem (2/7, 300
  runs) |####| 3/3 chunks [00:41, 300/300 runs, 0 failed]``: the method's own chunks, runs
  and elapsed time, and its phase (any text :meth:`Progress.phase` was given: a kernel
  compile, a PCE fit) in place of an ETA. When the next method starts, the finished bar stays
  on its line and a new one opens below. A ticker redraws every ``refresh`` seconds so the
  elapsed time moves during a compile or a PCE fit, where no chunk finishes; the kernels'
  compile notices (its start, then its duration) are printed above the bar (not across it) and
  the compile is shown as the phase while it lasts.
- Elsewhere (a pipe, a CI log): a plain line at most every ``interval`` seconds, and a closing
  line only if it says something the last one did not.
- ``-q``: nothing.

The counting is :class:`uqguide.driver.progress.Progress`; this module only draws.
"""

from __future__ import annotations

import os
import threading
from typing import Any, TextIO

from .progress import MethodCount, Progress, hms


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
    """On a terminal: a tqdm bar of the chunks with the current method and phase."""

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
        return tqdm(total=self.current.chunks_total or None, desc=self.title(),
                    file=self.stream, unit="chunk",
                    dynamic_ncols=sized, ncols=None if sized else 100,
                    nrows=None if sized else 24, leave=True,
                    mininterval=0,
                    bar_format="{desc} |{bar}| {n_fmt}/{total_fmt} chunks "
                               "[{elapsed}{postfix}]")

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
            b.total = m.chunks_total or None
            b.n = m.chunks_done
            desc = self.title() + (f": {self.phase_text}" if self.phase_text else "")
            b.set_description_str(desc, refresh=False)
            eta = self.eta_seconds()
            b.set_postfix_str(f"{m.runs_done:,}/{m.runs_total:,} runs, "
                              f"{m.runs_failed:,} failed"
                              + (f", ETA {hms(eta)}" if eta is not None else ""),
                              refresh=False)
            b.refresh()

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
    """The display for ``stream``: a bar on a terminal, plain lines elsewhere, none if quiet.

    Parameters
    ----------
    stream : text stream or None
        Where progress goes (stderr); None shows nothing.
    quiet : bool
        Show nothing.

    Returns
    -------
    Progress
    """
    if quiet or stream is None:
        return Progress(None)
    isatty = getattr(stream, "isatty", None)
    if isatty is not None and isatty():
        return BarProgress(stream)
    return PlainProgress(stream)
