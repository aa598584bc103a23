"""The ``uqguide`` command line: click glue over the library, and the exit codes.

Exit codes: 0 success; 1 a run that could not produce its result (UqguideError); 2 bad input
(ConfigError, or a usage error caught by click) with one line naming the field, the value and
what is allowed, and no traceback.
"""

from __future__ import annotations

import functools
import logging
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from . import __version__
from .errors import ConfigError, UqguideError


def _handle_errors(fn: Callable[..., Any]) -> Callable[..., Any]:
    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except ConfigError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2)
        except UqguideError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(1)

    return wrapper


def _setup_logging(verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s",
                        stream=sys.stderr)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="uqguide")
@click.option("-v", "--verbose", count=True, help="More log lines on stderr (-v info, -vv debug).")
def main(verbose: int) -> None:
    """Uncertainty propagation through closed-loop spacecraft guidance simulations."""
    _setup_logging(verbose)


@main.command()
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("results/runs"), show_default=True,
              help="Folder for the HDF5 result and the CSV / Markdown tables.")
@click.option("--seed", type=click.IntRange(0, 2**63 - 1), default=None,
              help="Override the config's seed.")
@click.option("--workers", type=click.IntRange(1, 4096), default=None,
              help="Evaluate chunks in a pool of N local worker processes (same numbers).")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Evaluate chunks on a Dask cluster, e.g. tcp://host:8786 (same numbers).")
@click.option("--scheduler-file", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Dask scheduler file (dask scheduler --scheduler-file).")
@click.option("--resume", is_flag=True,
              help="Continue an interrupted run from its checkpoint (<out>/<name>.run).")
@_handle_errors
def run(config: Path, out_dir: Path, seed: int | None, workers: int | None,
        scheduler: str | None, scheduler_file: Path | None, resume: bool) -> None:
    """Propagate the uncertainty of CONFIG with every method it lists."""
    from .checkpoint import RunInterrupted, RunStore, run_dir, run_identity
    from .config import load_config
    from .execution import make_executor
    from .progress import Progress
    from .propagate import check_failure_budget
    from .propagate import run as run_config
    from .report import render_text, write_tables
    from .result import write_hdf5

    cfg = load_config(config)
    if seed is not None:
        cfg = cfg.with_seed(seed)
    again = f"uqguide run {config} --resume" + (f" --out {out_dir}" if out_dir != Path(
        "results/runs") else "") + (f" --seed {seed}" if seed is not None else "")
    store = RunStore.open(run_dir(out_dir, cfg.name), run_identity(cfg.resolved(), cfg.model),
                          resume, again)
    executor = make_executor(workers, scheduler,
                             str(scheduler_file) if scheduler_file else None)
    try:
        result = run_config(cfg, executor, store=store, progress=Progress(sys.stderr))
    except RunInterrupted as exc:
        click.echo(f"interrupted: {exc.n_done} of {exc.n_total} chunks done; resume with "
                   f"`{again}`", err=True)
        sys.exit(130)
    finally:
        executor.close()
    click.echo(render_text(result))
    h5 = write_hdf5(result, out_dir / f"{cfg.name}.h5")
    tables = write_tables(result, out_dir, cfg.name)
    store.remove()  # the result file holds everything the chunks did
    click.echo("")
    click.echo(f"wrote {h5}")
    for p in tables:
        click.echo(f"wrote {p}")
    check_failure_budget(result, cfg.raw.max_failed_fraction)


@main.command()
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@_handle_errors
def validate(config: Path) -> None:
    """Check CONFIG without running anything."""
    from .config import load_config

    cfg = load_config(config)
    methods = ", ".join(f"{m.label} ({m.name})" for m in cfg.methods)
    click.echo(f"{config}: OK — model {cfg.model.name}, {cfg.space.dim} uncertain inputs "
               f"({', '.join(cfg.space.names) or 'none'}), outputs {', '.join(cfg.outputs)}, "
               f"methods {methods}, seed {cfg.seed}")


@main.command()
@click.argument("config", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--figures", "fig_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Also write the nominal run's figures (PNG) into this folder.")
@_handle_errors
def simulate(config: Path, fig_dir: Path | None) -> None:
    """Run CONFIG's model once at its nominal inputs; print its figures beside the paper's."""
    from .config import load_config
    from .describe import format_report

    cfg = load_config(config)
    try:
        rows = cfg.model.nominal_report()
    except NotImplementedError as exc:
        raise ConfigError(f"model.name: {exc}; `uqguide simulate` needs a paper scenario") from None
    click.echo(format_report(cfg.model.name, rows))
    if fig_dir is not None:
        for p in cfg.model.nominal_figures(str(fig_dir)):
            click.echo(f"wrote {p}")


@main.command()
@click.argument("name", required=False)
@_handle_errors
def models(name: str | None) -> None:
    """List the models with their inputs, outputs and parameters (or one model: NAME)."""
    from .registry import MODELS, model_class
    from .describe import describe_model

    names = [name] if name else list(MODELS)
    for i, n in enumerate(names):
        cls = model_class(n, "NAME")
        if i:
            click.echo("")
        click.echo(describe_model(cls))


@main.command()
@_handle_errors
def methods() -> None:
    """List the propagation methods with their settings."""
    from .registry import METHODS, method_class
    from .describe import describe_settings

    for i, n in enumerate(METHODS):
        cls = method_class(n)
        if i:
            click.echo("")
        click.echo(f"{n}: {cls.summary}")
        click.echo(describe_settings(cls.Settings))


if __name__ == "__main__":  # pragma: no cover
    main()
