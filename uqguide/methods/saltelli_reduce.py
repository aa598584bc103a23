"""The chunk reduction of a Saltelli pick-freeze design, run where the chunk ran.

A chunk is a block of ``b`` base rows with all of their runs, laid out block by block:
``A`` (``b`` rows), ``B`` (``b``), then ``A_B^u`` (``b``) for each of the ``m`` frozen sets.
So a chunk holds everything its base rows' estimates need, and the sums of chunks merge
exactly (:class:`~uqguide.stats.sobol_pick_freeze.PickFreezeSums`): the indices are the same
whatever the number of workers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core.types import ModelOutput
from ..stats.sobol_pick_freeze import PickFreezeSums
from .monte_carlo import MonteCarloReducer, ci_index, poisson1

#: Summary keys of the pick-freeze sums: ``"p:<field>:<output>"`` (the others are Monte
#: Carlo's, of the ``A`` and ``B`` rows).
PICK_FREEZE = "p:"


def lanes(y: np.ndarray, steps: np.ndarray | None) -> np.ndarray:
    """An output's values ``(n, L)`` at the lanes that get indices: every component of a
    scalar, every component at ``steps`` of a series."""
    if y.ndim == 3:
        y = y[:, steps] if steps is not None else y
    return y.reshape(y.shape[0], -1)


@dataclass(frozen=True)
class SaltelliReducer:
    """Reduces one chunk of a pick-freeze design (module docstring) to mergeable sums.

    Summary: Monte Carlo's sums of the ``A`` and ``B`` rows (``mc``, a valid ``2b``-run
    sample) and, per output, ``"p:<field>:<output>"`` (:class:`PickFreezeSums`). A base row
    counts only when none of its ``m + 2`` runs failed and every value is finite: the pairing
    of ``A``, ``B`` and ``A_B^u`` is what the estimators rest on.
    """

    n_sets: int
    bootstrap: int
    boot_seed: int
    report_times: tuple[float, ...] | None
    mc: MonteCarloReducer

    def __call__(self, out: ModelOutput, index: int) -> dict[str, np.ndarray]:
        m2 = self.n_sets + 2
        b = out.n // m2
        summary = self.mc(out.subset(np.arange(2 * b)), index)
        good = ~np.asarray(out.failed, dtype=bool).reshape(m2, b).any(axis=0)
        if not good.any():
            return summary
        steps = ci_index(out.time, self.report_times, "report") if out.series else None
        values = {name: lanes(y, steps).reshape(m2, b, -1)
                  for name, y in [*out.series.items(), *out.scalars.items()]}
        for v in values.values():
            good &= np.isfinite(v).all(axis=(0, 2))
        # Weights for every base row (the bad ones then dropped), so a row's weights do not
        # depend on which other rows failed; a stream apart from Monte Carlo's (same index).
        rng = np.random.default_rng([self.boot_seed, index])
        w = np.concatenate([np.ones((1, b)), poisson1(rng, (self.bootstrap, b))])[:, good]
        for name, v in values.items():
            v = v[:, good]
            s = PickFreezeSums.of(v[0], v[1], v[2:], w)
            for f, arr in s.arrays().items():
                summary[f"{PICK_FREEZE}{f}:{name}"] = arr
        return summary


def split(summary: dict[str, np.ndarray]) -> tuple[dict[str, PickFreezeSums],
                                                   dict[str, np.ndarray]]:
    """A chunk's summary as its pick-freeze sums by output and the rest (Monte Carlo's)."""
    mine: dict[str, dict[str, np.ndarray]] = {}
    rest = {}
    for key, v in summary.items():
        if key.startswith(PICK_FREEZE):
            _, f, name = key.split(":", 2)
            mine.setdefault(name, {})[f] = v
        else:
            rest[key] = v
    return {k: PickFreezeSums.from_arrays(a) for k, a in mine.items()}, rest
