"""The config's report times against the model's time grid, checked once when a config is
validated (:func:`uqguide.config.run_config.validate_config`)."""

from __future__ import annotations

from typing import Any

import numpy as np


def check_report_times(report_times: list[float] | tuple[float, ...] | None,
                       grid: np.ndarray) -> None:
    """ConfigError naming ``report_times[i]`` when a report time lies outside the time grid
    (more than half a step beyond either end): it would silently show the nearest step."""
    from ..errors import ConfigError

    if not report_times:
        return
    for i, t in enumerate(report_times):
        if (span := outside_grid(t, grid)) is not None:
            lo, hi = span
            raise ConfigError(
                f"report_times[{i}]: {t:g} s is outside the model's time grid "
                f"[{lo:g}, {hi:g}] s; give times within it", field=f"report_times[{i}]")


def outside_grid(t: float, grid: np.ndarray) -> tuple[float, float] | None:
    """The grid's span ``(first, last)`` when ``t`` lies more than half a step beyond either
    end (the nearest step would silently stand for it), else None (also for no grid)."""
    if grid.size == 0:
        return None
    half = 0.5 * float(np.min(np.diff(grid))) if grid.size > 1 else 0.0
    lo, hi = float(grid[0]), float(grid[-1])
    return (lo, hi) if t < lo - half or t > hi + half else None


def model_time_grid(model: Any, outputs: tuple[str, ...]) -> np.ndarray:
    """The time grid of the model's nominal run (empty when it has no series or the run fails)."""
    series = tuple(o for o in outputs if model.output_info(o).kind == "series")
    if not series:
        return np.zeros(0)
    try:
        # A model that knows its grid without a run says so (FTCAPN: a full nominal run would
        # load its compiled kernel into a driver that may never simulate, 0.6 s).
        grid = getattr(model, "time_grid", None)
        if callable(grid):
            return np.asarray(grid(), dtype=float)
        return np.asarray(model.evaluate(np.zeros((1, 0)), [], series).time, dtype=float)
    except Exception:  # noqa: BLE001 - no grid known: the runs themselves will say what fails
        return np.zeros(0)
