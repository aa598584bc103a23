"""The model of a data file: each design row is answered with the outputs the file holds for
it.

The methods that take their design from the file (``monte_carlo``, ``pce_adaptive``) ask for
exactly the file's rows, so every row is found; the driver, its chunks, worker pools,
checkpoints and the result file then work as for any model. A row is looked up by its inputs'
exact bits (the checks refuse repeated inputs, so each is one run); a row the file does not
hold is a :class:`~uqguide.errors.ModelError`, never a made-up value.

The table travels with the model to worker processes (the model is not in the registry, so
:class:`~uqguide.driver.execution.transport.ModelHandle` pickles it whole): a worker never
reads a file that may have changed since the config was read.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from pydantic import Field

from ...core.types import ModelOutput
from ...errors import ModelError
from ..base import ModelParams
from ..callable import CallableOutput, DeclaredModel
from .files import Table


class DataParams(ModelParams):
    """What the result records of a data file (the table itself is not a parameter)."""

    source: str = Field(default="<arrays>", description="the data file, as the config names it")
    digest: str = Field(default="", description="SHA-256 of the file's columns")
    n_rows: int = Field(default=0, ge=0, description="rows (runs) of the file")
    inputs: list[str] = Field(default_factory=list, description="input columns, in order")
    nominal: list[float] | None = None
    outputs: list[CallableOutput] = Field(default_factory=list)
    time: list[float] | None = Field(default=None, description="time grid of the series [s]")


class DataModel(DeclaredModel):
    """The runs of a data file as a model (module docstring)."""

    name = "data"
    summary = "the runs of a data file (config data:): each design row answered from the file"
    Params = DataParams
    params: DataParams
    input_column = "column {j} of the data"

    def __init__(self, params: DataParams | Mapping[str, object] | None = None,
                 table: Table | None = None) -> None:
        super().__init__(params)
        self.table = table
        self._index: dict[bytes, int] | None = None

    def __getstate__(self) -> dict[str, Any]:
        return {"params": self.params, "table": self.table}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(state["params"], state["table"])  # type: ignore[misc]

    def _source(self) -> str:
        return self.params.source

    def rows(self) -> np.ndarray:
        """The file's inputs ``(n, d)``, columns in ``params.inputs`` order."""
        if self.table is None:
            raise ModelError(f"data model of {self.params.source}: the table is not loaded")
        cols = [self.table.columns[n] for n in self.params.inputs]
        return np.column_stack(cols) if cols else np.empty((self.table.n_rows, 0))

    def time_grid(self) -> np.ndarray:
        """The series' time grid [s] (empty without series): ``data.time``, else the file's
        ``time``, else the step numbers; known without a run (the report times are checked
        against it, and no nominal row exists to run)."""
        steps = [self.table.columns[s.name].shape[1] for s in self._specs()
                 if s.kind == "series"] if self.table is not None else []
        if not steps:
            return np.zeros(0)
        if self.params.time is not None:
            return np.asarray(self.params.time, dtype=float)
        if self.table is not None and self.table.time is not None:
            return np.asarray(self.table.time, dtype=float)
        return np.arange(steps[0], dtype=float)

    def _row_index(self) -> dict[bytes, int]:
        if self._index is None:
            x = np.ascontiguousarray(self.rows(), dtype=np.float64)
            self._index = {x[i].tobytes(): i for i in range(x.shape[0])}
        return self._index

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        assert self.table is not None  # (rows() said so otherwise)
        x = np.ascontiguousarray(np.column_stack([values[k] for k in self.params.inputs])
                                 if self.params.inputs else np.empty((n, 0)), dtype=np.float64)
        index = self._row_index()
        at = np.empty(n, dtype=np.intp)
        for i in range(n):
            found = index.get(x[i].tobytes())
            if found is None:
                raise ModelError(f"data: {self.params.source}: no row has the inputs "
                                 f"{dict(zip(self.params.inputs, x[i].tolist()))}; a data "
                                 f"model answers only the file's own rows")
            at[i] = found
        scalars: dict[str, np.ndarray] = {}
        series: dict[str, np.ndarray] = {}
        failed = np.zeros(n, dtype=bool)
        reasons = np.full(n, "", dtype=object)
        if self.table.flagged is not None:
            # the user's own verdict comes first, in the user's own words
            failed = self.table.flagged[at].copy()
            given = (self.table.reasons[at] if self.table.reasons is not None
                     else np.full(n, "", dtype=object))
            reasons[failed] = [r or f"marked failed in {self.params.source}"
                               for r in given[failed]]
        for spec in self._specs():
            v = self.table.columns[spec.name][at]
            bad = ~np.isfinite(v.reshape(n, -1)).all(axis=1)
            reasons[bad & ~failed] = f"non-finite {spec.name} in {self.params.source}"
            failed |= bad
            if spec.kind == "series":
                series[spec.name] = v[:, :, None]
            else:
                scalars[spec.name] = v[:, None]
        return ModelOutput(time=self.time_grid(), scalars=scalars, series=series,
                           failed=failed, reasons=reasons)
