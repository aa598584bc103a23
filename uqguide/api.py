"""The Python API: load a config, run it, read a result back, fit runs already made.

These four functions are what ``import uqguide`` offers (``uqguide.load_config``,
``uqguide.run``, ``uqguide.read_result``, ``uqguide.fit``), with the classes they take and give
(``uqguide.RunConfig``, ``uqguide.Result``, and ``uqguide.Model`` / ``uqguide.Method`` to
subclass); the command line is a thin layer over them. Each function's docstring has a running
example; a walk-through is docs/guide.md#from-python.
"""

from __future__ import annotations

import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .config.run_config import RunConfig
    from .results.result import Result


def load_config(config: str | Path | Mapping[str, Any] | RunConfig) -> RunConfig:
    """A validated run configuration: the model, input space, outputs and methods, every
    default filled in.

    ``config``: a YAML config file, the name of a shipped study (``uqguide configs`` lists
    them), or the same content as a mapping, where a ``callable`` model's ``function`` may be a
    Python function object instead of ``"module:function"``; a RunConfig is returned as it is.
    Raises :class:`uqguide.errors.ConfigError` naming the field, the value given and what is
    allowed.

    Examples
    --------
    >>> import uqguide
    >>> cfg = uqguide.load_config("ftcapn_table3")
    >>> cfg.model.name, [m.label for m in cfg.methods]
    ('ftcapn', ['mc1000'])
    """
    from .config.run_config import RunConfig, load_config as _load, validate_config

    if isinstance(config, RunConfig):
        return config
    if isinstance(config, Mapping):
        return validate_config(config)
    return _load(config)


def run(config: str | Path | Mapping[str, Any] | RunConfig, *, workers: int | None = None,
        seed: int | None = None, out: str | Path | None = None,
        progress: bool = False, force: bool = False) -> Result:
    """Propagate the uncertainty of ``config`` with every method it lists.

    Parameters
    ----------
    config : RunConfig, str, Path or mapping
        Anything :func:`load_config` accepts.
    workers : int, optional
        Evaluate chunks in a pool of this many local processes (the numbers do not change).
        Default: in this process.
    seed : int, optional
        Overrides the config's seed.
    out : str or Path, optional
        Also write ``<out>/<name>.h5`` and the CSV / Markdown tables, as ``uqguide run`` does
        (``<name>``: the config's ``name`` or file stem; a mapping without one is refused,
        ConfigError). Without ``out`` nothing is written.
    progress : bool
        Show progress on stderr.
    force : bool
        With ``out``: replace ``<out>/<name>.h5`` even when another config made it (a
        ConfigError otherwise; a rerun of the same config may always overwrite its result).

    Returns
    -------
    Result
        Statistics of every method; ``result.to_xarray()``, ``result.to_dataframe(output)``.
        Failed samples are counted in each method's ``n_failed`` and do not raise; each
        method whose runs failed logs one warning with their share and its 95% interval
        (its statistics are those conditional on success: docs/config.md#failed-runs).

    Examples
    --------
    >>> import uqguide
    >>> result = uqguide.run({
    ...     "model": {"name": "lognormal", "a": [0.3, 0.2]},
    ...     "inputs": [{"name": f"x{i}", "dist": "normal", "mean": 0, "std": 1} for i in (1, 2)],
    ...     "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 2000}],
    ...     "seed": 1})
    >>> df = result.to_dataframe("y")
    >>> sorted(df.statistic.unique())
    ['kurtosis', 'mean', 'sem', 'skewness', 'std']
    >>> row = df[df.statistic == "mean"].iloc[0]
    >>> bool(row.ci_low < 1.0671 < row.ci_high)   # the exact mean exp(0.13 / 2)
    True

    Every method's statistics along ``label``, as an xarray Dataset:

    >>> cfg = uqguide.load_config({
    ...     "model": {"name": "linear_gaussian"},
    ...     "inputs": [{"name": "x1", "dist": "normal", "std": 1.0},
    ...                {"name": "x2", "dist": "uniform", "low": 0.0, "high": 2.0}],
    ...     "outputs": ["y"],
    ...     "methods": [{"name": "pce_tensor", "label": "tensor", "m": 2}],
    ... })
    >>> result = uqguide.run(cfg)
    >>> ds = result.to_xarray()       # every method, along ``label``
    >>> mean = ds["y"].sel(label="tensor", statistic="mean")   # exact: b + A E[x] = (2, 0)
    >>> [round(float(v), 12) + 0.0 for v in mean]
    [2.0, 0.0]
    >>> list(ds["y"].dims)
    ['label', 'statistic', 'y_component']
    """
    from .commands.run_and_write import check_result_name, run_and_write
    from .driver.execution import make_executor
    from .driver.execution.processes import refuse_nested_run
    from .driver.progress import make_progress
    from .driver.propagate import run as _run

    refuse_nested_run()  # a worker re-running an unguarded script must not start the run again
    cfg = load_config(config)
    if seed is not None:
        cfg = cfg.with_seed(seed)
    if out is not None:
        check_result_name(cfg)  # before a worker pool is started for nothing
    executor = make_executor(workers) if workers else None
    shown = make_progress(sys.stderr, not progress)
    if out is not None:
        return run_and_write(cfg, out, executor, workers=workers or 1, progress=shown,
                             force=force).result
    try:
        result = _run(cfg, executor, progress=shown)
    finally:
        if executor is not None:
            executor.close()
    return result


def fit(x: Any, y: Any, *, inputs: Sequence[Mapping[str, Any]],
        method: str | Mapping[str, Any] = "pce_adaptive", outputs: Sequence[str] | None = None,
        seed: int = 0, name: str | None = None, time: Sequence[float] | None = None,
        workers: int | None = None) -> Result:
    """Statistics (and, for a PCE, the kept surrogate) of runs already made: ``x`` and ``y``.

    The same as a config with ``data:`` (``docs/your-simulator.md``, "Your own samples"), bit for
    bit: the rows of ``x`` are the design, drawn from ``inputs``, checked as a data file's are
    (ConfigError naming the row and the column for bad data or settings).

    Parameters
    ----------
    x : ndarray (n, d), pandas DataFrame, xarray Dataset or mapping of arrays
        The runs' inputs: an array's columns in the order of ``inputs``, the others by name.
    y : ndarray (n,) or (n, m), DataFrame, Dataset or mapping of arrays
        The runs' outputs: a 1-D array is the output ``y`` (or ``outputs[0]``), a 2-D array's
        columns are ``outputs`` (default ``y0``, ``y1``, ...); a series is a DataFrame's
        ``name[0]``, ``name[1]``, ... columns, a Dataset's ``(n, T)`` variable or a mapping's
        ``(n, T)`` array. A row of NaN outputs is a failed run (counted, not dropped).
    inputs : sequence of mapping
        The distribution of each input, as a config's ``inputs:`` (``{"name": "x1", "dist":
        "uniform", "low": 0, "high": 1}``).
    method : str or mapping
        ``"pce_adaptive"`` (default) or ``"monte_carlo"``, or a config's method entry with
        its settings (``{"name": "pce_adaptive", "degree_max": 8}``).
    outputs : sequence of str, optional
        The outputs to report (and the names of a 2-D array ``y``'s columns).
    seed : int
        The run's seed (held-out rows, surrogate draws).
    time : sequence of float, optional
        The series' time grid [s] (default: a Dataset's time coordinate, else 0, 1, ...).
    workers : int, optional
        As :func:`run`.

    Returns
    -------
    Result
        With the method's statistics; a PCE's surrogate is kept (``result.surrogate(label)``).

    Examples
    --------
    >>> import numpy as np, uqguide
    >>> rng = np.random.default_rng(1)
    >>> x = rng.uniform(-1, 1, (60, 2))
    >>> y = 1 + 2 * x[:, 0] + x[:, 1] ** 2           # mean 1 + 1/3, variance 4/3 + 4/45
    >>> result = uqguide.fit(x, y, inputs=[
    ...     {"name": "a", "dist": "uniform", "low": -1, "high": 1},
    ...     {"name": "b", "dist": "uniform", "low": -1, "high": 1}],
    ...     method={"name": "pce_adaptive", "degree_max": 3})
    >>> st = result.to_dataframe("y").set_index("statistic").value
    >>> round(float(st["mean"]), 9), round(float(st["std"] ** 2), 9)
    (1.333333333, 1.422222222)
    """
    from .models.data_rows import table_of

    entry = {"name": method} if isinstance(method, str) else dict(method)
    names = [m.get("name") for m in inputs]
    table = table_of(x, y, [str(n) for n in names], outputs, time)
    config: dict[str, Any] = {"data": table, "inputs": list(inputs), "methods": [entry],
                              "seed": seed}
    if outputs is not None:
        config["outputs"] = list(outputs)
    if name is not None:
        config["name"] = name
    return run(config, workers=workers)


def read_result(path: str | Path) -> Result:
    """Read a result file (``uqguide run``'s ``<name>.h5``, any format version): every method's
    statistics, runs and failures, with the resolved config and provenance.
    :class:`uqguide.errors.ResultError` if the file is missing, not a uqguide result or
    incomplete."""
    from .results.result import read_hdf5

    return read_hdf5(path)
