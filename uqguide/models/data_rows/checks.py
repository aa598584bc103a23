"""The rows of a data file against the config's inputs: what makes a file unusable is refused
with one line naming the file, the row and the column (exit 2); what only weakens the
statistics is logged as a warning.

The list of refusals and warnings, and why each:
docs/config.md#what-a-data-files-rows-must-satisfy.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ...core.inputs import InputSpace
from ...core.names import PLAIN_NAME_RULE, is_plain_name
from ...errors import ConfigError
from .files import Table
from .names import data_error

log = logging.getLogger(__name__)

#: Family-wise level of the goodness-of-fit warnings: each of the ``d`` inputs is tested at
#: ``GOF_LEVEL / d`` (Bonferroni), so iid rows from the declared inputs raise a false warning
#: in at most 1% of files, whatever the number of inputs.
GOF_LEVEL = 0.01


@dataclass(frozen=True)
class GoodnessOfFit:
    """The Kolmogorov-Smirnov test of one input's column against its declared marginal: the
    distance ``statistic = sup |F_n - F|``, its ``p_value``, and whether it is ``rejected``
    (``p_value`` below ``GOF_LEVEL / d``)."""

    name: str
    statistic: float
    p_value: float
    rejected: bool


def _fail(table: Table, text: str) -> ConfigError:
    return data_error(table.source, text)


def input_rows(table: Table, space: InputSpace) -> np.ndarray:
    """The design ``x (n, d)`` [SI, as the file holds them] the file's rows give, columns in
    the order of the config's inputs ``space.names``, after every check on the inputs (module
    docstring)."""
    columns = table.column_names()
    for i, name in enumerate(space.names):
        v = table.columns.get(name)
        if v is None:
            raise _fail(table, f"no column {name!r} for inputs[{i}] (columns: "
                               f"{', '.join(columns[:20])}{', ...' if len(columns) > 20 else ''})")
        if v.ndim != 1:
            raise _fail(table, f"input {name!r} (inputs[{i}]) is a series of {v.shape[1]} "
                               f"columns; an input is one value per run")
    if table.n_rows == 0:
        raise _fail(table, "no rows (one row per run after the header)")
    x = np.column_stack([table.columns[n] for n in space.names]) if space.dim else \
        np.empty((table.n_rows, 0))
    bad = ~np.isfinite(x)
    if bad.any():
        r, j = np.argwhere(bad)[0]
        raise _fail(table, f"{table.where(r)}, column {space.names[j]!r}: input is "
                           f"{float(x[r, j])!r}; every run's inputs must be known numbers "
                           f"(a failed run is a row of NaN outputs)")
    for j, m in enumerate(space.marginals):
        low, high = m.support()
        strict = m.dist == "lognormal"  # exp(.) > 0: 0 itself is no draw
        out = (x[:, j] <= low) if strict else (x[:, j] < low)
        out |= x[:, j] > high
        if out.any():
            r = int(np.flatnonzero(out)[0])
            lo = "(" if strict else "["
            k = int(out.sum())
            raise _fail(table, f"{table.where(r)}, column {m.name!r}: {float(x[r, j])!r} is "
                               f"outside the support {lo}{low:g}, {high:g}] of inputs[{j}] "
                               f"{m.describe()} ({k} row{'s are' if k > 1 else ' is'} outside)")
    _refuse_repeats(table, x, space.names)
    return x


def _refuse_repeats(table: Table, x: np.ndarray, names: Sequence[str]) -> None:
    if x.shape[0] < 2:
        return
    _, first, inverse = np.unique(x, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    repeat = np.flatnonzero(first[inverse] != np.arange(x.shape[0]))
    if repeat.size:
        r = int(repeat[0])
        f = int(first[inverse[r]])
        shown = ", ".join(f"{n}={v!r}" for n, v in list(zip(names, x[r].tolist()))[:4])
        raise _fail(table, f"{table.where(r)} repeats the inputs of {table.where(f)} ({shown}"
                           f"{', ...' if len(names) > 4 else ''}); each row must be a distinct "
                           f"run: average repeated runs into one row or drop the copy "
                           f"({repeat.size} repeated row{'s' if repeat.size > 1 else ''})")


def output_names(table: Table, space: InputSpace, outputs: Sequence[str] | None
                 ) -> tuple[str, ...]:
    """The outputs to read: those the config names (each must be a column or a series of the
    file), or by default (``outputs`` None) every column that is not an input."""
    if outputs is None:
        found = tuple(k for k in table.columns if k not in space.names)
        if not found:
            raise _fail(table, f"no output columns: every column is an input "
                               f"({', '.join(space.names)})")
        for name in found:
            if not is_plain_name(name):
                raise _fail(table, f"column {name!r} cannot name an output: an output's name "
                                   f"must be {PLAIN_NAME_RULE}; rename the column, or list the "
                                   f"outputs to read in outputs:")
        return found
    for i, name in enumerate(outputs):
        if name in space.names:
            raise ConfigError(f"outputs[{i}]: {name!r} is an input (inputs: "
                              f"{', '.join(space.names)}); an output is a column the runs "
                              f"produced", field=f"outputs[{i}]")
        if name not in table.columns:
            cols = [k for k in table.columns if k not in space.names]
            raise _fail(table, f"no column {name!r} (or {name}[0], {name}[1], ...) for "
                               f"outputs[{i}]; output columns: {', '.join(cols) or 'none'}")
    return tuple(dict.fromkeys(outputs))


def failed_rows(table: Table, outputs: Sequence[str]) -> np.ndarray:
    """The runs that failed: rows flagged in the ``failed`` column, and rows whose outputs
    hold a NaN or an infinity (a mask ``(n,)``)."""
    bad = np.zeros(table.n_rows, dtype=bool) if table.flagged is None else table.flagged.copy()
    for name in outputs:
        v = table.columns[name]
        bad |= ~np.isfinite(v.reshape(v.shape[0], -1)).all(axis=1)
    return bad


def warn_failed(table: Table, failed: np.ndarray) -> None:
    """Log the failed rows (flagged, or NaN outputs): counted, never dropped silently."""
    if failed.any():
        rows = np.flatnonzero(failed)
        shown = ", ".join(str(r + 1) for r in rows[:8])
        how = ("are flagged failed or have NaN or infinite outputs" if table.flagged is not None
               else "have NaN or infinite outputs")
        log.warning("data: %s: %d of %d rows %s (rows %s%s); they are failed runs, counted in "
                    "n_failed", table.source, rows.size, failed.size, how, shown,
                    ", ..." if rows.size > 8 else "")


def goodness_of_fit(x: np.ndarray, space: InputSpace) -> list[GoodnessOfFit]:
    """The Kolmogorov-Smirnov test of each input's values in the rows ``x (n, d)`` [SI]
    against its declared marginal, judged at ``GOF_LEVEL / d``: one per input, in order (none
    with fewer than 2 rows). Per input, not of the joint law; a space-filling design passes
    (docs/your-simulator.md#bad-data)."""
    from scipy import stats

    if x.shape[0] < 2:
        return []
    level = GOF_LEVEL / max(space.dim, 1)
    out = []
    for j, m in enumerate(space.marginals):
        res = stats.kstest(x[:, j], m.cdf)
        out.append(GoodnessOfFit(m.name, float(res.statistic), float(res.pvalue),
                                 bool(res.pvalue < level)))
    return out


def warn_goodness_of_fit(table: Table, tests: Sequence[GoodnessOfFit], space: InputSpace
                         ) -> None:
    """Log a warning per input whose column fails :func:`goodness_of_fit`."""
    for t in tests:
        if t.rejected:
            m = space.marginals[space.names.index(t.name)]
            log.warning("data: %s: column %r does not look like draws from %s "
                        "(Kolmogorov-Smirnov D = %.3g, p = %.2g < %.2g); Monte Carlo statistics "
                        "assume the rows are independent draws from inputs:", table.source,
                        t.name, m.describe(), t.statistic, t.p_value,
                        GOF_LEVEL / max(space.dim, 1))
