"""``data:`` in place of ``model:``: a config whose runs are already made.

The config's ``data`` section, which methods take it (those with an empty
:attr:`~uqguide.methods.base.Method.own_design`), the sizes it fixes, the recorded hash that
refuses a changed file, and the memory check before reading: docs/config.md, "Data files
(data:) in detail".
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import Field, ValidationError

from ..core.inputs import InputSpace
from ..core.strict import StrictModel
from ..errors import ConfigError
from ..methods.base import GivenRows
from ..models.callable import CallableOutput
from ..models.data_rows import DataModel, DataParams, Table, read_table
from ..models.data_rows.claims import Claim
from ..models.data_rows.files import ARRAYS
from ..models.data_rows.checks import (
    failed_rows, goodness_of_fit, input_rows, output_names, warn_failed, warn_goodness_of_fit,
)
from .limits import BASE_BYTES, human
from .registry import method_class

log = logging.getLogger(__name__)


class DataSpec(StrictModel):
    """``data:`` as a mapping (a plain string is its ``path``)."""

    path: str = Field(min_length=1, description="the file of runs (.csv, .parquet, .h5, .npz)")
    time: list[float] | None = Field(default=None, description="time grid of the series [s]")
    sha256: str | None = Field(default=None, description="the file content's digest (a stored "
                                                         "config refuses a changed file)")


@dataclass
class DataSource:
    """What a ``data:`` config reads: the model answering the rows, the outputs and the rows."""

    model: DataModel
    outputs: tuple[str, ...]
    rows: GivenRows
    spec: dict[str, Any]


def parse_spec(value: Any) -> DataSpec | Table:
    """``data:`` as given (a path, a mapping, or from Python a :class:`Table` in memory) as a
    :class:`DataSpec`, or the table itself."""
    if isinstance(value, Table):
        return value
    if isinstance(value, (str, Path)):
        value = {"path": str(value)}
    if not isinstance(value, Mapping):
        raise ConfigError(f"data: must be a file path or a mapping {{path: ..., time: [...]}} "
                          f"(got {type(value).__name__})", field="data")
    try:
        return DataSpec.model_validate(dict(value))
    except ValidationError as err:
        e = err.errors(include_url=False)[0]
        where = ".".join(str(p) for p in e["loc"])
        raise ConfigError(f"data.{where}: {e['msg']}", field=f"data.{where}") from None


def read_bytes(claim: Claim, n_inputs: int) -> float:
    """Peak memory [bytes] of reading a file that makes ``claim`` and checking its rows of
    ``n_inputs`` inputs."""
    # 8 bytes a value, twice while a CSV's steps are stacked into a series; the claim's extra
    # bytes (text, copies); the inputs (n, d) four times (the design, and the repeated-rows
    # check's sorted copy, unique rows and merge-sort buffer) and 40 bytes a row of indices
    return (BASE_BYTES + 16.0 * claim.cells + claim.extra_bytes
            + 8.0 * claim.rows * (4 * n_inputs + 5))


def _within(source: str, n_inputs: int, max_memory: int) -> Callable[[Claim], None]:
    def check(claim: Claim) -> None:
        need = read_bytes(claim, n_inputs)
        if need > max_memory:
            raise ConfigError(f"data: {source}: reading it needs an estimated {human(need)} "
                              f"({claim.what}), more than max_memory = {human(max_memory)}; "
                              f"split the file or keep fewer columns, or raise max_memory if "
                              f"the machine has it", field="data")
    return check


def load_source(value: Any, space: InputSpace, outputs: list[str] | None,
                config_dir: str | None, max_memory: int | None = None) -> DataSource:
    """Read and check a config's ``data`` (docs/config.md#data-files-data-in-detail).

    ``outputs``: default every column that is not an input; ``config_dir``: where relative
    paths start; ``max_memory`` [bytes]: a file whose reading would need more is refused before
    it is read (None: not checked).
    """
    spec = parse_spec(value)
    if isinstance(spec, Table):
        table, time = spec, None
        stored: dict[str, Any] = {"path": table.source}
    elif spec.path == ARRAYS:
        raise ConfigError("data: the runs were given from Python (uqguide.fit) and are not "
                          "stored with the result; write them to a file and give data: FILE",
                          field="data")
    else:
        p = Path(spec.path).expanduser()
        if not p.is_absolute() and config_dir:
            p = Path(config_dir) / p
        table = read_table(p, spec.path, None if max_memory is None else
                           _within(spec.path, space.dim, max_memory))
        if spec.sha256 is not None and spec.sha256 != table.digest:
            raise ConfigError(f"data: {spec.path}: the file changed since this config was "
                              f"stored (its columns' SHA-256 is {table.digest[:12]}..., the "
                              f"stored one {spec.sha256[:12]}...)", field="data")
        time = spec.time
        stored = {"path": spec.path}
    x = input_rows(table, space)
    names = output_names(table, space, outputs)
    specs = [CallableOutput(name=n, kind="series" if table.columns[n].ndim == 2 else "scalar")
             for n in names]
    steps = {table.columns[n].shape[1] for n in names if table.columns[n].ndim == 2}
    if len(steps) > 1:
        raise ConfigError(f"data: {table.source}: the series have different numbers of steps "
                          f"({sorted(steps)}); every series shares one time grid", field="data")
    grid = time if time is not None else (None if table.time is None else table.time.tolist())
    if steps and grid is not None and len(grid) != next(iter(steps)):
        raise ConfigError(f"data.time: {len(grid)} times for series of {next(iter(steps))} "
                          f"steps", field="data.time")
    failed = failed_rows(table, names)
    warn_failed(table, failed)
    warn_goodness_of_fit(table, goodness_of_fit(x, space), space)
    params = DataParams(source=table.source, digest=table.digest, n_rows=table.n_rows,
                        inputs=list(space.names), outputs=specs, time=time)
    stored.update(time=time, sha256=table.digest)
    return DataSource(DataModel(params, table), names, GivenRows(x, table.source, failed),
                      stored)


def method_entries(entries: list[dict[str, Any]], n_rows: int, source: str
                   ) -> list[dict[str, Any]]:
    """The config's ``methods`` entries for a design of the ``n_rows`` rows of the file
    ``source``: methods that need their own design refused, sizes filled in."""
    out = []
    for i, entry in enumerate(entries):
        name = entry.get("name")
        if name is None:
            raise ConfigError(f"methods[{i}].name: required field is missing",
                              field=f"methods[{i}].name")
        cls = method_class(name, f"methods[{i}].name")
        if cls.own_design:
            raise ConfigError(f"methods[{i}].name: {name} cannot take its design from data: "
                              f"{source} ({cls.own_design}); with data: use monte_carlo or "
                              f"pce_adaptive", field=f"methods[{i}].name")
        sized = dict(entry)
        for key in ("n_samples", "max_runs"):
            if key not in cls.Settings.model_fields:
                continue
            given = sized.get(key)
            if given is not None and given != n_rows:
                raise ConfigError(f"methods[{i}].{key}: {given!r}, but with data: the design is "
                                  f"the {n_rows} rows of {source}; leave {key} out",
                                  field=f"methods[{i}].{key}")
            sized[key] = n_rows
        out.append(sized)
    return out


def check_rows_enough(methods: list[Any], rows: GivenRows, dim: int) -> None:
    """ConfigError when a method's fit has fewer successful ``rows`` than it needs for
    ``dim`` inputs."""
    n_ok = int((~rows.failed).sum())
    for i, m in enumerate(methods):
        need = m.min_rows(dim)
        if n_ok < need:
            failed = rows.failed.size - n_ok
            why = (f" ({failed} of {rows.failed.size} {'has' if failed == 1 else 'have'} NaN "
                   f"outputs)") if failed else ""
            raise ConfigError(f"data: {rows.source}: {n_ok} usable rows{why}; methods[{i}] "
                              f"({m.label}) needs at least {need} for {dim} inputs",
                              field="data")


def write_suggestion(config: Any, n: int, out: str | Path, force: bool = False) -> Path:
    """Write the ``n`` next runs that extend the design of a ``data:`` config
    (:func:`uqguide.models.data_rows.suggest.suggest_runs`): a CSV of the inputs, the input
    names as header, values in ``repr`` precision; returns ``out``. ``force``: replace an
    existing ``out`` (refused otherwise: it may hold runs already made).
    """
    from ..core.atomic import refuse_unwritable, write_text
    from ..models.command.files import inputs_csv
    from ..models.data_rows.suggest import suggest_runs

    if not isinstance(config.model, DataModel):
        raise ConfigError(f"{config.source}: model: {config.model.name}; suggest extends the "
                          f"rows of a data file: give the config data: instead of model:",
                          field="data")
    path = Path(out)
    if path.suffix.lower() != ".csv":
        raise ConfigError(f"--out: {out} must be a .csv file", field="out")
    if path.exists() and not force:
        raise ConfigError(f"--out: {out} exists (it may hold runs already made); pass --force "
                          f"to replace it", field="out")
    refuse_unwritable(path)
    x = suggest_runs(config.space, config.model.rows(), n, config.seed)
    names = list(config.space.names)
    return write_text(path, inputs_csv(names, x))
