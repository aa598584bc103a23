"""Run a batch of FT-AS closed loops through the compiled kernel and collect the results.

:func:`run_batch` is the one entry point used by the model, the report and the tests: it packs
the constants, allocates the recording and metric arrays, calls the compiled kernel
(``kernel_numba.simulate_numba``) and returns a :class:`RunResult` with named arrays.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..kernels import numba_threads
from .layout import GROUP_INDEX, RECORD_GROUPS, SETTLE_QUANTITIES
from .setup import Batch, Gains, Plant

log = logging.getLogger(__name__)


def _compiled() -> Callable[..., None]:
    # imported on first use (compiles or loads the cache); tests/oracles substitutes NumPy here
    from .kernel_numba import simulate_numba

    return simulate_numba


SETTLE_TOLERANCES: dict[str, tuple[float, ...]] = {
    "r_e": (1.0, 1e-2, 5e-3, 1e-3, 2e-4),  # m
    "v_e": (1e-3, 1e-4, 1e-5),  # m/s; 1e-3 is claim C3's, the finer ones added
    "sigma_e": (1e-2, 2e-3, 1e-3, 1e-4),
    "omega_e": (1e-3, 1e-4, 2e-5, 2e-7),  # rad/s
    "eps1": (1e-2, 1e-3, 1e-4),
    "s_trans": (1e-3,),  # claim C6
    "s_rot": (1e-3,),
}
assert tuple(SETTLE_TOLERANCES) == SETTLE_QUANTITIES
FINAL_QUANTITIES = ("r_e", "v_e", "sigma_e", "omega_e")  # rows of the kernel's final_max


@dataclass(frozen=True)
class Timing:
    """Integration settings (A15, A16), in seconds: the RK4 / zero-order-hold ``step``, the horizon
    ``duration``, the recorded grid's ``output_interval`` (a multiple of ``step``), the
    final-accuracy window ``[duration - final_window, duration]`` and the start ``late_time`` of the
    "late" input-peak window (claim C5: Case 1 within limits after it)."""

    step: float = 0.01
    duration: float = 3000.0
    output_interval: float = 10.0
    final_window: float = 200.0
    late_time: float = 300.0

    @property
    def n_steps(self) -> int:
        return int(round(self.duration / self.step))

    @property
    def record_every(self) -> int:
        return int(round(self.output_interval / self.step))

    def first_step_at(self, t: float) -> int:
        return int(np.ceil(t / self.step - 1e-9))


@dataclass
class RunResult:
    """Recorded histories and per-step metrics of a batch of ``n`` runs.

    ``records`` holds the asked-for groups of ``layout.RECORD_GROUPS`` ``(n, T, k)`` on the
    grid ``time (T,)`` [s]; ``settle`` ``(n, n_tol)`` the last time [s] each norm exceeded each
    tolerance of ``SETTLE_TOLERANCES`` (the horizon where not settled); ``final_max`` ``(n, 3)``
    ``max |x_k|`` over the final window of ``r_e, v_e, sigma_e, omega_e``; ``peak_applied``,
    ``peak_command``, ``peak_late`` (after ``late_time``) ``(n, 6)`` the peaks of ``|u_k|`` [N,
    N m]; ``impulse (n, 6)`` ``integral |u_k| dt`` [N s, N m s]; ``wall_time`` the seconds in
    the kernel (compilation excluded).
    """

    time: np.ndarray
    records: dict[str, np.ndarray]
    settle: dict[str, np.ndarray]
    final_max: dict[str, np.ndarray]
    peak_applied: np.ndarray
    peak_command: np.ndarray
    peak_late: np.ndarray
    impulse: np.ndarray
    failed: np.ndarray
    timing: Timing
    wall_time: float = 0.0
    extra: dict[str, object] = field(default_factory=dict)

    def take(self, index: slice | np.ndarray) -> RunResult:
        """The runs selected by ``index`` (a slice or an index array over the batch)."""
        per_run = ("peak_applied", "peak_command", "peak_late", "impulse", "failed")
        picked: dict[str, Any] = {f: getattr(self, f)[index] for f in per_run}
        for f in ("records", "settle", "final_max"):
            picked[f] = {k: v[index] for k, v in getattr(self, f).items()}
        return replace(self, **picked)

    def settled(self, quantity: str) -> np.ndarray:
        """(n, n_tol) True where the norm ended below the tolerance before the horizon."""
        return self.settle[quantity] < self.timing.duration - 0.5 * self.timing.step


def run_batch(
    batch: Batch,
    plant: Plant,
    gains: Gains,
    timing: Timing,
    record: Iterable[str] = (),
    threads: int = 0,
) -> RunResult:
    """Integrate ``batch`` with the compiled kernel, recording the groups ``record`` of
    ``layout.RECORD_GROUPS`` on the output grid; ``threads``: 0 for all cores (the numbers do not
    depend on it)."""
    record = list(dict.fromkeys(record))
    offsets = np.full(len(RECORD_GROUPS), -1, dtype=np.int64)
    width = 0
    for name in record:
        offsets[GROUP_INDEX[name]] = width
        width += RECORD_GROUPS[name]
    n, n_steps, every = batch.n, timing.n_steps, timing.record_every
    n_rec = n_steps // every + 1
    rec = np.zeros((n, n_rec, max(width, 1)))
    n_tol = max(len(v) for v in SETTLE_TOLERANCES.values())
    tols = np.zeros((len(SETTLE_TOLERANCES), n_tol))
    for qi, v in enumerate(SETTLE_TOLERANCES.values()):
        tols[qi, : len(v)] = v
    settle = np.zeros((n, len(SETTLE_TOLERANCES), n_tol))
    final_max = np.zeros((n, 4, 3))
    peak_app, peak_cmd, peak_late, impulse = (np.zeros((n, 6)) for _ in range(4))
    failed = np.zeros(n, dtype=np.bool_)
    t0 = time.perf_counter()
    final_start = timing.first_step_at(timing.duration - timing.final_window)
    late_start = timing.first_step_at(timing.late_time)
    with numba_threads(threads):
        _compiled()(batch, plant, gains, float(timing.step), n_steps, every, final_start,
                    late_start, tols, rec, offsets, settle, final_max, peak_app, peak_cmd,
                    peak_late, impulse, failed)
    wall = time.perf_counter() - t0
    log.debug("ft_as kernel: %d runs x %d steps in %.2f s", n, n_steps, wall)
    records = {
        name: rec[:, :, offsets[GROUP_INDEX[name]]
                  : offsets[GROUP_INDEX[name]] + RECORD_GROUPS[name]]
        for name in record
    }  # fmt: skip
    return RunResult(
        time=np.arange(n_rec) * every * timing.step,
        records=records,
        settle={q: settle[:, qi, : len(v)] for qi, (q, v) in enumerate(SETTLE_TOLERANCES.items())},
        final_max={q: final_max[:, qi] for qi, q in enumerate(FINAL_QUANTITIES)},
        peak_applied=peak_app,
        peak_command=peak_cmd,
        peak_late=peak_late,
        impulse=impulse,
        failed=failed,
        timing=timing,
        wall_time=wall,
    )
