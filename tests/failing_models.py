"""Small user functions for the execution, resume and failure tests (not collected)."""

from __future__ import annotations

import os
import signal
import time

import numpy as np


def mc_config(function: str, n: int, chunk: int, seed: int = 11, bootstrap: int = 0,
              **top: object) -> dict:
    """A Monte Carlo config over ``function(a, b)``, a ~ N(0, 1), b ~ U(0, 2), output ``y``:
    the shared study of the execution, resume and fault tests."""
    return {
        "model": {"name": "callable", "function": function, "inputs": ["a", "b"],
                  "outputs": ["y"]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "uniform", "low": 0.0, "high": 2.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": n, "chunk_size": chunk,
                     "bootstrap": bootstrap}],
        "seed": seed, **top,
    }


def flaky(x):
    """``y = a + b^2`` and a series ``a t``; fails on about 5% of samples, two ways:
    ``a > 1.96`` (2.5% of a standard normal) raises, ``a < -1.96`` gives NaN."""
    a, b = x[:, 0], x[:, 1]
    if (a > 1.96).any():
        raise ValueError("a above 1.96")
    t = np.linspace(0.0, 2.0, 9)
    y = a + b**2
    y = np.where(a < -1.96, np.nan, y)
    return {"time": t, "path": a[:, None] * t[None, :] + b[:, None], "y": y, "ab": x[:, :2]}


def clean(x):
    """:func:`flaky` without its failures (the statistics of the rest come from this)."""
    a, b = x[:, 0], x[:, 1]
    t = np.linspace(0.0, 2.0, 9)
    return {"time": t, "path": a[:, None] * t[None, :] + b[:, None], "y": a + b**2,
            "ab": x[:, :2]}


def crash_worker(x):
    """Kills its process (as a segfault would) when a sample has ``a > 2.5``; only for
    worker processes."""
    if (x[:, 0] > 2.5).any():
        os._exit(3)
    return x[:, 0] + x[:, 1]


def slow_sum(x):
    """``a + b`` after a pause (0.15 s a call), logging each call to $UQGUIDE_TEST_CALL_LOG."""
    log = os.environ.get("UQGUIDE_TEST_CALL_LOG")
    if log:
        with open(log, "a") as f:
            f.write(f"{x.shape[0]}\n")
    time.sleep(0.15)
    return x[:, 0] + x[:, 1]


_calls = {"n": 0}


def ctrl_c_on_third_call(x):
    """``a + b``; the third call (and every later one while armed) acts as a Ctrl-C."""
    _calls["n"] += 1
    if os.environ.get("UQGUIDE_TEST_ARM_CTRL_C") == "1" and _calls["n"] >= 3:
        raise KeyboardInterrupt
    return x[:, 0] + x[:, 1]


def clean_sum(x):
    """``a + b``."""
    return x[:, 0] + x[:, 1]


def linear_raises_above(x):
    """``y = a + 2 b``; raises when a sample has ``a > 1.5`` (the outer Gauss-Hermite node
    ``a = sqrt(3)`` of a 3-point rule)."""
    if (x[:, 0] > 1.5).any():
        raise RuntimeError("solver diverged")
    return x[:, 0] + 2 * x[:, 1]


def hang_above(x):
    """``a + b``; a call holding a sample with ``a > $UQGUIDE_TEST_HANG_ABOVE`` never returns
    (a solver stuck in a loop)."""
    if (x[:, 0] > float(os.environ.get("UQGUIDE_TEST_HANG_ABOVE", "inf"))).any():
        while True:
            time.sleep(60)
    return x[:, 0] + x[:, 1]


def crash_above(x):
    """``a + b``; a call holding a sample with ``a > $UQGUIDE_TEST_CRASH_ABOVE`` kills its
    process (as a segfault would)."""
    if (x[:, 0] > float(os.environ.get("UQGUIDE_TEST_CRASH_ABOVE", "inf"))).any():
        os._exit(3)
    return x[:, 0] + x[:, 1]


def sigint_as_on_a_terminal() -> None:
    """A shell starts a background job (``pytest ... &``, a CI runner) with SIGINT ignored,
    and Python, like uqguide on purpose, keeps an inherited SIG_IGN: the run would never see
    the Ctrl-C. Give it SIGINT's default, as a terminal's foreground command has it."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def segfault_above(x):
    """``a + b``; a call holding a sample with ``a > $UQGUIDE_TEST_SEGFAULT_ABOVE`` dies of a
    real segmentation fault (a NULL read through ctypes, as a broken C extension would)."""
    pause = float(os.environ.get("UQGUIDE_TEST_SLEEP_S", "0"))
    if pause:
        time.sleep(pause)
    bad = x[:, 0] > float(os.environ.get("UQGUIDE_TEST_SEGFAULT_ABOVE", "inf"))
    if bad.any():
        log = os.environ.get("UQGUIDE_TEST_CALL_LOG")
        if log and x.shape[0] == 1:  # a known crasher run again would show here
            with open(log, "a") as f:
                f.write(f"{x[0, 0]!r}\n")
        import ctypes
        import faulthandler

        faulthandler.disable()  # the signal's default action, no traceback on stderr
        ctypes.string_at(0)
    return x[:, 0] + x[:, 1]


def leak_above(x):
    """``a + b``; a call holding a sample with ``a > $UQGUIDE_TEST_LEAK_ABOVE`` allocates
    (and keeps) 4 GB, as a model leaking at every call soon would."""
    if (x[:, 0] > float(os.environ.get("UQGUIDE_TEST_LEAK_ABOVE", "inf"))).any():
        _kept.append(np.ones(4 << 27))
    return x[:, 0] + x[:, 1]


_kept: list = []


def swallows_a_sigterm(x):
    """``a + b``; on its first call a SIGTERM lands inside a bare ``except:`` of the user's
    (the handler runs as if the signal had arrived there), which drops the exception."""
    if not _swallowed:
        _swallowed.append(True)
        from uqguide.driver import interrupts

        try:
            interrupts._handler(signal.SIGTERM, None)
        except BaseException:  # noqa: BLE001 - the user's code, as users write it
            pass
    return x[:, 0] + x[:, 1]


_swallowed: list = []


def huge(x):
    """``y = a + b^2`` beside ``big = 1e300 y`` (the sums of its squares overflow double
    precision) and ``mid = 1e100 y`` (those of its 3rd and 4th powers do), and the series
    ``path = 1e300 a t``."""
    a, b = x[:, 0], x[:, 1]
    y = a + b**2
    t = np.linspace(0.0, 1.0, 3)
    return {"time": t, "y": y, "big": 1e300 * y, "mid": 1e100 * y,
            "path": 1e300 * a[:, None] * t[None, :]}


def counted_clean(x):
    """:func:`clean`, counting its calls in ``_calls``."""
    _calls["n"] += 1
    return clean(x)


def failing_region(x):
    """``y = 2 + a + 0.5 b^2 + 0.3 a c``, NaN where ``a + b > 2.9`` (2.0% of standard normal
    inputs): a model that fails on a region of its input space (issue 46, item 1)."""
    a, b, c = x[:, 0], x[:, 1], x[:, 2]
    y = 2.0 + a + 0.5 * b**2 + 0.3 * a * c
    return {"y": np.where(a + b > 2.9, np.nan, y)}


def sum_nan_above(x):
    """``y = a + b``, NaN where ``a > 1.5`` (6.7% of standard normal inputs): a model failing on
    a half-space, whose mean conditional on success is ``-phi(1.5) / Phi(1.5)``."""
    a, b = x[:, 0], x[:, 1]
    return {"y": np.where(a > 1.5, np.nan, a + b)}


def sum_fails_at_random(x):
    """``y = a + b``, NaN at about 10% of the inputs, scattered with no region (the digits of
    ``a``): nothing a classifier of the success region could learn."""
    a, b = x[:, 0], x[:, 1]
    scattered = np.modf(np.abs(a) * 1e4)[0] < 0.1
    return {"y": np.where(scattered, np.nan, a + b)}
