"""Limits a config may set on one run, and their units: the integration steps of one run
(``max_steps``, so that a ``dt`` of 1e-9 s is refused rather than run for ever) and sizes in
bytes (``max_memory``). Kept apart from :mod:`uqguide.config.budget`, which estimates a whole run
from a validated config, because the config's own validation uses them.
"""

from __future__ import annotations

import math
import os
import re
from typing import TYPE_CHECKING, Any

from ..errors import ConfigError

if TYPE_CHECKING:
    from ..models.base import Model

#: Integration steps one run may take unless the config says otherwise.
DEFAULT_MAX_STEPS = 10_000_000
#: Share of the machine's physical memory a run may plan to use unless the config says otherwise.
DEFAULT_MEMORY_SHARE = 0.5
#: The interpreter, numpy, scipy, chaospy and a compiled kernel, before any data [bytes].
BASE_BYTES = 250e6

_UNITS = {"": 1, "b": 1, "k": 1e3, "kb": 1e3, "m": 1e6, "mb": 1e6, "g": 1e9, "gb": 1e9,
          "t": 1e12, "tb": 1e12, "kib": 2**10, "mib": 2**20, "gib": 2**30, "tib": 2**40}

#: What a size may be (the units as :data:`_UNITS` reads them, any case).
SIZE_RULE = ("must be a number of bytes or a size like '4 GB' (units: B, kB, MB, GB, TB, KiB, "
             "MiB, GiB, TiB)")


def machine_memory() -> int:
    """Physical memory of this machine in bytes (8 GiB when it cannot be read)."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 8 * 2**30


def memory_limit(value: Any) -> int:
    """The ``max_memory`` [bytes] a config's value stands for: :func:`parse_bytes` of it, or
    :data:`DEFAULT_MEMORY_SHARE` of the machine's memory when the config sets none."""
    if value is None:
        return int(DEFAULT_MEMORY_SHARE * machine_memory())
    return parse_bytes(value)


def parse_bytes(value: Any) -> int:
    """``2e9``, ``"2 GB"``, ``"512MiB"`` -> bytes, at least 1e6 (units kB, MB, GB, TB, KiB, MiB,
    GiB, TiB); ValueError naming what is allowed (the caller names the value: a config's
    message says it once)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        v = float(value)
    elif isinstance(value, str):
        m = re.fullmatch(r"\s*([0-9]*\.?[0-9]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", value)
        unit = m.group(2).lower() if m else None
        if not m or unit not in _UNITS:
            raise ValueError(SIZE_RULE)
        v = float(m.group(1)) * _UNITS[unit]
    else:
        raise ValueError(SIZE_RULE)
    if not (math.isfinite(v) and v >= 1e6):
        raise ValueError("must be a finite size of at least 1 MB")
    return int(v)


def human(n: float) -> str:
    """A size in bytes for messages, e.g. ``"4.29 GB"``."""
    for unit, f in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if n >= f:
            return f"{n / f:.3g} {unit}"
    return f"{n:.0f} B"


def check_steps(model: Model, limit: float) -> None:
    """ConfigError when one run of ``model`` would take more than ``limit`` (the config's
    ``max_steps``) integration steps or output grid points."""
    count = model.step_count()
    if count is None:
        return
    for what, v in (("steps", count.steps), ("output grid points", count.grid)):
        if not math.isfinite(v) or v > limit:
            value = getattr(model.params, count.field, None)
            raise ConfigError(
                f"model.{count.field}: {value!r} gives {v:.3g} {what} per run "
                f"({count.formula}); allowed at most max_steps = {limit:.3g} (raise max_steps "
                f"to run it anyway)", field=f"model.{count.field}")
