"""Compiled kernels: where their machine code is cached, and saying when they compile.

Kernel modules decorate with :func:`njit` from here rather than ``numba.njit`` so that, before
the first decorator runs,

- the on-disk cache lives where it can be written: numba's default is the ``__pycache__`` folder
  beside the source, which a read-only ``site-packages`` does not allow; then the cache goes to
  ``$XDG_CACHE_HOME/uqguide/numba`` (``~/.cache/uqguide/numba``), and to a folder in the temporary
  directory when even that cannot be written (``NUMBA_CACHE_DIR`` set by the user always wins);
- a compile that misses the cache is a phase of its own, a line on stderr when it starts and
  one when it ends, its seconds booked as compile time, not model time (:func:`compile_seconds`).

The NumPy reference kernels are test oracles (``tests/oracles/``); ``kernel: numpy`` and
``UQGUIDE_KERNEL`` are deprecated and run the compiled kernel (:data:`KernelParam`).
"""

from __future__ import annotations

import logging
import os
import sys
import tempfile
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import AfterValidator, Field

log = logging.getLogger(__name__)

KERNEL_ENV = "UQGUIDE_KERNEL"
"""Deprecated environment variable that once forced the NumPy reference kernels."""

_PACKAGE_DIR = Path(__file__).resolve().parents[1]
_warned: set[str] = set()


def _deprecated(value: str) -> str:
    # one line per process: params are validated for every model built, in every worker
    notes = []
    if value == "numpy":
        notes.append("model.kernel: 'numpy' is deprecated and runs the compiled kernel (the "
                     "NumPy reference kernels are test oracles now); remove the key")
    if os.environ.get(KERNEL_ENV, "").strip():
        notes.append(f"environment variable {KERNEL_ENV} is deprecated and ignored: the "
                     "compiled kernel runs")
    for note in notes:
        if note not in _warned:
            _warned.add(note)
            log.warning("%s", note)
            warnings.warn(note, DeprecationWarning, stacklevel=2)
    return value


KernelParam = Annotated[Literal["auto", "numba", "numpy"], AfterValidator(_deprecated)]
"""A model's deprecated ``kernel`` parameter: every value runs the compiled kernel; ``numpy``
(and a set ``UQGUIDE_KERNEL``) say so once per process."""


def kernel_field(default: str = "auto") -> Any:
    """The ``kernel`` field of a simulator's parameters (:data:`KernelParam`), kept so that
    configs and stored results that name it still load."""
    return Field(default, validate_default=True,
                 description="deprecated: the compiled kernel always runs ('numpy' is accepted "
                             "with a warning)")


@contextmanager
def numba_threads(threads: int) -> Iterator[None]:
    """Let compiled kernels use ``threads`` threads (0: all numba may use) inside the block."""
    import numba

    before = numba.get_num_threads()
    most = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]  # set at import
    numba.set_num_threads(min(threads, most) if threads else most)
    try:
        yield
    finally:
        numba.set_num_threads(before)


# ---------------------------------------------------------------------------- the cache
def _writable(folder: Path) -> bool:
    # os.access answers for the real uid, and root passes it everywhere; creating a file is
    # the only test that also sees read-only mounts.
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError:
        return False
    return True


def cache_dir(package_dir: Path = _PACKAGE_DIR) -> Path | None:
    """Where compiled kernels are cached: ``NUMBA_CACHE_DIR`` if set; None (numba's default,
    beside the source) when the package folder is writable; else a writable user cache folder
    (None if there is none). ``package_dir`` is a parameter so that tests can make it read-only."""
    if os.environ.get("NUMBA_CACHE_DIR"):
        return Path(os.environ["NUMBA_CACHE_DIR"])
    if _writable(package_dir / "models" / "__pycache__"):
        return None
    xdg = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    for candidate in (Path(xdg) / "uqguide" / "numba",
                      Path(tempfile.gettempdir()) / f"uqguide-numba-{os.getuid()}"):
        if _writable(candidate):
            return candidate
    return None


# ---------------------------------------------------------------------------- compile phase
_announced: set[str] = set()
_lock = threading.Lock()
#: Where the compile notices go instead of plain lines on stderr: a progress bar on a terminal
#: sets it, to print them above the bar (not across it) and show the compile as its phase.
#: Called with the line and the phase text ("" when the compile is over).
notice_sink: Callable[[str, str], None] | None = None


def _kernel_family(module: str) -> str | None:
    """``uqguide.models.ftcapn.kernel_numba`` -> ``ftcapn``; None outside uqguide's models."""
    parts = module.split(".")
    if len(parts) >= 3 and parts[:2] == ["uqguide", "models"]:
        return parts[2]
    return None


class _CompileClock:
    """The compiles of uqguide's kernels in this process: how long they took, and their notices.

    A kernel's compile compiles the functions it calls (its helpers, the shared record writers)
    inside it, so only the outermost compile counts; numba compiles under one global lock, so
    no two run at once. A function found in the cache is loaded, not compiled, and never seen
    here (numba reports cache misses only).
    """

    def __init__(self) -> None:
        self.depth = 0
        self.family: str | None = None
        self.announced = False
        self.started = 0.0
        self.started_cpu = 0.0
        self.seconds = 0.0
        self.cpu_seconds = 0.0

    def start(self, event: Any) -> None:
        with _lock:
            self.depth += 1
            if self.depth > 1:
                return
            dispatcher = (event.data or {}).get("dispatcher")
            module = getattr(getattr(dispatcher, "py_func", None), "__module__", "")
            family = self.family = _kernel_family(module)
            self.started = time.perf_counter()
            # the compiling thread's own CPU: the docs' CPU-s, which a loaded machine's wall
            # clock overstates (a 20 CPU-s compile took 65 s wall at a load of 5)
            self.started_cpu = time.thread_time()
            self.announced = family is not None and family not in _announced
            if family is None or not self.announced:
                return
            _announced.add(family)
        _notice(f"uqguide: compiling the {family} kernel (once per install; later runs "
                "load it from the cache)", f"compiling the {family} kernel")

    def end(self, event: Any) -> None:
        with _lock:
            self.depth -= 1
            if self.depth > 0 or self.family is None:
                return
            took = time.perf_counter() - self.started
            took_cpu = time.thread_time() - self.started_cpu
            self.seconds += took
            self.cpu_seconds += took_cpu
        if self.announced:
            _notice(f"uqguide: compiled the {self.family} kernel in {took_cpu:.1f} CPU-s "
                    f"({took:.1f} s wall)", "")


_clock = _CompileClock()


def _notice(text: str, phase: str) -> None:
    sink = notice_sink
    if sink is not None:
        sink(text, phase)
    else:
        print(text, file=sys.stderr, flush=True)


def compile_seconds() -> float:
    """Wall seconds this process has spent compiling uqguide's kernels (cache misses only).

    The driver reads it around each chunk's model calls, so that a first-run compile is
    booked as compile time, not model time.
    """
    with _lock:
        return _clock.seconds


def compile_cpu_seconds() -> float:
    """CPU seconds of the same compiles (the compiling thread's): what the docs quote."""
    with _lock:
        return _clock.cpu_seconds


_configured = False


def njit(*args: Any, **kwargs: Any) -> Callable[..., Any]:
    """``numba.njit`` with uqguide's cache location and compile notice (module docstring): the
    compiled function, or a decorator when called with options only."""
    global _configured
    import numba

    if not _configured:
        from numba.core import event

        where = cache_dir()
        if where is not None:
            # numba fills its config module at run time: no declaration for a type checker to see
            config: Any = numba.config
            config.CACHE_DIR = str(where)

        class CompileListener(event.Listener):
            def on_start(self, ev: Any) -> None:
                _clock.start(ev)

            def on_end(self, ev: Any) -> None:
                _clock.end(ev)

        event.register("numba:compile", CompileListener())
        _configured = True
    return numba.njit(*args, **kwargs)
