"""The Python API: load a config, run it, read a result back.

These three functions are what ``import uqguide`` offers (``uqguide.load_config``,
``uqguide.run``, ``uqguide.read_result``), with the classes they take and give
(``uqguide.RunConfig``, ``uqguide.Result``, and ``uqguide.Model`` / ``uqguide.Method`` to
subclass); the command line is a thin layer over them.

Examples
--------
>>> import uqguide
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

from __future__ import annotations

import sys
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .config.run_config import RunConfig
    from .results.result import Result


def load_config(config: str | Path | Mapping[str, Any] | RunConfig) -> RunConfig:
    """A validated run configuration.

    Parameters
    ----------
    config : str, Path, mapping or RunConfig
        A YAML config file, the name of a shipped study (``uqguide configs`` lists them), or
        the same content as a mapping. In a mapping, a ``callable`` model's ``function`` may be
        a Python function object instead of ``"module:function"``. A RunConfig is returned
        as it is.

    Returns
    -------
    RunConfig
        The model, input space, outputs and methods, every default filled in.

    Raises
    ------
    uqguide.errors.ConfigError
        Naming the field, the value given and what is allowed.

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
        Also write ``<out>/<name>.h5`` and the CSV / Markdown tables, as ``uqguide run`` does.
        ``<name>`` is the config's ``name``, or a config file's stem. A mapping without a
        ``name`` is refused here (ConfigError, field ``name``) rather than written as
        ``run.h5``, where the next unnamed config would overwrite it (or find its run folder
        and refuse to resume a different config); a name derived from the content would
        avoid the clash but leave a file nobody chose or can find. Without ``out`` nothing is
        written and no name is needed.
    progress : bool
        Show progress on stderr.
    force : bool
        With ``out``: replace ``<out>/<name>.h5`` even when another config made it (a
        ConfigError otherwise; a rerun of the same config may always overwrite its result).

    Returns
    -------
    Result
        Statistics of every method; ``result.to_xarray()``, ``result.to_dataframe(output)``.
        Failed samples are counted in each method's ``n_failed`` and do not raise.

    Raises
    ------
    uqguide.errors.ConfigError
        An invalid config, or ``out`` given for a mapping config without a ``name``.

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
    """
    from .driver.execution import make_executor
    from .driver.execution.processes import refuse_nested_run
    from .driver.progress_display import make_progress
    from .driver.propagate import run as _run

    refuse_nested_run()  # a worker re-running an unguarded script must not start the run again
    cfg = load_config(config)
    if seed is not None:
        cfg = cfg.with_seed(seed)
    if out is not None:
        from .driver.run_and_write import check_result_name

        check_result_name(cfg)  # before a worker pool is started for nothing
    executor = make_executor(workers) if workers else None
    shown = make_progress(sys.stderr, not progress)
    if out is not None:
        from .driver.run_and_write import run_and_write

        return run_and_write(cfg, out, executor, workers=workers or 1, progress=shown,
                             force=force).result
    try:
        result = _run(cfg, executor, progress=shown)
    finally:
        if executor is not None:
            executor.close()
    return result


def read_result(path: str | Path) -> Result:
    """Read a result file (``uqguide run``'s ``<name>.h5``, any format version).

    Parameters
    ----------
    path : str or Path
        The HDF5 result file.

    Returns
    -------
    Result
        Every method's statistics, runs and failures, with the resolved config and provenance.

    Raises
    ------
    uqguide.errors.ResultError
        If the file is missing, not a uqguide result or incomplete.
    """
    from .results.result import read_hdf5

    return read_hdf5(path)
