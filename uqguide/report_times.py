"""The time steps the tables show: the config's report times on the model's grid.

Kept apart from :mod:`uqguide.report` (pandas) so that ``uqguide baseline`` and ``check`` start
without importing pandas' table machinery they do not need.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from .result import Result


def report_indices(result: Result, n_default: int = 5) -> np.ndarray:
    """Grid indices of the report times (nearest step) plus the last step."""
    t = result.time
    if t.size == 0:
        return np.zeros(0, dtype=int)
    if result.report_times:
        idx = [int(np.argmin(np.abs(t - rt))) for rt in result.report_times]
    else:
        idx = list(np.linspace(0, t.size - 1, n_default).round().astype(int))
    return np.unique(np.append(idx, t.size - 1))
