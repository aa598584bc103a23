"""Simulating a batch of samples with one FMU instance.

FMI has no batch call, so a batch makes one instance and simulates its samples in turn,
resetting it between them (FMI 1.0 has no reset: a fresh instance per sample); after a sample
that raised, the instance is replaced, since it may no longer reset cleanly. Each sample runs
through ``fmpy.simulate_fmu`` with the already parsed description, folder and instance. A
sample fails when it raised (the FMU's logged errors go into the reason), stopped before
``stop_time`` or gave a non-finite output:
docs/your-simulator.md#how-it-runs-and-when-a-sample-fails.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import ModelError
from .archive import fmpy

#: The FMI statuses whose log messages go into a failed sample's reason (error, fatal).
_ERROR = 3
_REASON_CHARS = 400


@dataclass(frozen=True)
class Setup:
    """What every sample of a run shares: the unzipped FMU's ``folder`` and description
    ``md``, ``start_time``, ``stop_time`` and the communication step ``output_interval`` [s] (a
    whole number of them spans the simulation), the series' ``grid (T,)`` [s] (empty without
    series outputs), and the start values ``fixed`` for every sample (``start_values``)."""

    folder: str
    md: Any
    start_time: float
    stop_time: float
    output_interval: float
    grid: np.ndarray
    relative_tolerance: float | None
    fixed: Mapping[str, Any]


class Instance:
    """One FMU instance, made on first use, reset between samples, freed by :meth:`close`."""

    def __init__(self, setup: Setup) -> None:
        self.setup = setup
        self.messages: list[str] = []
        self._fmu: Any = None

    def _log(self, *args: Any) -> None:
        # FMI 2.0 logs (env, instance, status, category, message), FMI 3.0 (env, status,
        # category, message)
        status, message = args[-3], args[-1]
        if isinstance(status, int) and status >= _ERROR:
            text = message.decode(errors="replace") if isinstance(message, bytes) else message
            self.messages.append(str(text).strip())

    def _ready(self) -> Any:
        if self._fmu is None:
            from fmpy.simulation import instantiate_fmu

            try:
                self._fmu = instantiate_fmu(self.setup.folder, self.setup.md, logger=self._log)
            except Exception as exc:  # noqa: BLE001 - any way the binary will not start
                # no sample's value is involved: every sample would fail the same way
                said = "; ".join(m for m in self.messages if m)
                raise ModelError(f"the FMU cannot be instantiated ({type(exc).__name__}: "
                                 f"{exc}{'; FMU: ' + said if said else ''})") from None
        return self._fmu

    def close(self) -> None:
        """Free the instance (a later sample makes a new one)."""
        fmu, self._fmu = self._fmu, None
        if fmu is not None:
            try:
                fmu.freeInstance()
            except Exception:  # noqa: BLE001 - an instance that will not free is left behind
                pass

    def run(self, values: Mapping[str, float], variables: Sequence[str]) -> Any:
        """Simulate one sample from the start ``values`` (FMU variable -> the sample's input),
        recording ``variables``: FMPy's recording (a structured array, ``time`` and a field per
        variable), or why the simulation failed. ModelError when the FMU cannot be
        instantiated: not a sample's failure, every sample would fail alike."""
        s = self.setup
        self.messages.clear()
        fmu = self._ready()
        try:
            result = fmpy().simulate_fmu(
                s.folder, start_time=s.start_time, stop_time=s.stop_time,
                output_interval=s.output_interval, relative_tolerance=s.relative_tolerance,
                start_values={**s.fixed, **values}, output=list(variables),
                record_events=False, model_description=s.md, fmu_instance=fmu)
        except Exception as exc:  # noqa: BLE001 - whatever the FMU did, it is this sample's
            self.close()
            said = "; ".join(m for m in self.messages if m)
            reason = f"{type(exc).__name__}: {exc}".strip() + (f" (FMU: {said})" if said else "")
            return " ".join(reason.split())[:_REASON_CHARS]
        self._next()
        return result

    def _next(self) -> None:
        """Back to the just-instantiated state for the next sample."""
        if self.setup.md.fmiVersion == "1.0":
            self.close()
            return
        try:
            self._fmu.reset()
        except Exception:  # noqa: BLE001 - a fresh instance does what the reset would have
            self.close()


def pick(result: Any, setup: Setup, scalars: Mapping[str, Sequence[str]],
         series: Mapping[str, Sequence[str]]) -> tuple[dict[str, np.ndarray],
                                                       dict[str, np.ndarray], str]:
    """One sample's outputs from FMPy's recording ``result`` (a ``time`` field and one per
    variable); ``scalars`` and ``series`` map an output to its components' FMU variables.

    Returns the scalars ``(k,)`` at ``stop_time``, the series ``(T, k)`` on ``setup.grid``,
    and why the sample fails ("" when it does not; its arrays are then NaN).
    """
    t = np.asarray(result["time"], dtype=float)
    tol = 1e-9 * max(1.0, abs(setup.stop_time), abs(setup.start_time))
    # scalars at the last row at stop_time (an FMU may record the end twice)
    end = t.size - 1
    reason = ""
    if end < 0 or abs(t[end] - setup.stop_time) > tol:
        last = f"{t[end]:g} s" if end >= 0 else "its start"
        reason = (f"the simulation stopped at t = {last}, before stop_time = "
                  f"{setup.stop_time:g} s (the FMU terminated or gave up)")
    rows = np.searchsorted(t, setup.grid - tol)
    if not reason and setup.grid.size and (
            rows[-1] >= t.size or np.any(np.abs(t[np.minimum(rows, t.size - 1)] - setup.grid)
                                         > tol)):
        reason = "the FMU's recording misses points of the output_interval grid"
    sc = {name: np.array([float(result[v][end]) for v in vs]) if not reason
          else np.full(len(vs), np.nan) for name, vs in scalars.items()}
    se = {name: np.column_stack([np.asarray(result[v], dtype=float)[rows] for v in vs])
          if not reason else np.full((setup.grid.size, len(vs)), np.nan)
          for name, vs in series.items()}
    if not reason and not all(np.isfinite(a).all() for a in [*sc.values(), *se.values()]):
        reason = "non-finite output value"
    return sc, se, reason
