"""The ``uqguide`` command line: click glue over the library, and the exit codes.

Exit codes: 0 success; 1 a run that could not produce its result (UqguideError); 2 bad input
(ConfigError, or a usage error caught by click) with one line naming the field, the value and
what is allowed, and no traceback; 130 stopped by SIGINT (Ctrl-C) or SIGTERM, at any moment
(:mod:`uqguide.driver.interrupts`).
"""

from __future__ import annotations

import functools
import logging
import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import click

from ._version import __version__
from .errors import ConfigError, DiskFull, MethodsFailed, ResultError, UqguideError
from .driver.interrupts import (EXIT_INTERRUPTED, Terminated, ignore_signals, install,
                                 raise_received, restore)


def _handle_errors(fn: Callable[..., Any], result_error: int = 1) -> Callable[..., Any]:
    """One line and the exit code: 2 for a ConfigError, ``result_error`` for a ResultError, 1
    for another UqguideError or a full disk."""

    @functools.wraps(fn)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return fn(*args, **kwargs)
        except UqguideError as exc:
            click.echo(f"error: {exc}", err=True)
            sys.exit(2 if isinstance(exc, ConfigError) else
                     result_error if isinstance(exc, ResultError) else 1)
        except OSError as exc:
            from .core.atomic import is_disk_full

            if not is_disk_full(exc):
                raise
            # a write that did not go through uqguide's writers (a library's cache)
            where = f" writing {exc.filename}" if exc.filename else ""
            click.echo(f"error: disk full{where} ({exc.strerror}): free space and run the "
                       f"command again", err=True)
            sys.exit(1)

    return wrapper


def _setup_logging(verbose: int) -> None:
    level = logging.WARNING if verbose == 0 else logging.INFO if verbose == 1 else logging.DEBUG
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s",
                        stream=sys.stderr)


def _interrupted(exc: KeyboardInterrupt) -> None:
    what = "terminated (SIGTERM)" if isinstance(exc, Terminated) else "interrupted"
    try:
        click.echo(f"{what}; nothing was left half-written", err=True)
    except KeyboardInterrupt:  # a second Ctrl-C while saying so
        pass


def _wrapped_interrupt(exc: BaseException) -> KeyboardInterrupt | None:
    """The KeyboardInterrupt an exception wraps, if any: a Ctrl-C that lands while Python
    creates a class (an import in progress) reaches us as ``RuntimeError: Error calling
    __set_name__``, caused by the interrupt."""
    seen = exc.__cause__ or exc.__context__
    while seen is not None:
        if isinstance(seen, KeyboardInterrupt):
            return seen
        seen = seen.__cause__ or seen.__context__
    return None


class _Group(click.Group):
    """The command group: a SIGINT or SIGTERM anywhere in a command is exit 130, one line."""

    def invoke(self, ctx: click.Context) -> Any:
        try:
            result = super().invoke(ctx)
            # a signal whose exception was swallowed on the way (by Python, a library or the
            # user's code) still stops the command: exit 0 means no signal came before the end
            raise_received()
            return result
        except (KeyboardInterrupt, Exception) as exc:
            interrupt = exc if isinstance(exc, KeyboardInterrupt) else _wrapped_interrupt(exc)
            if interrupt is None:
                raise
            _interrupted(interrupt)
            raise click.exceptions.Exit(EXIT_INTERRUPTED) from None

    def main(self, *args: Any, **kwargs: Any) -> Any:
        # Also around click's own parsing and exit, where click would print "Aborted!", exit 1.
        previous = install()
        try:
            return super().main(*args, **kwargs)
        except KeyboardInterrupt as exc:
            _interrupted(exc)
            sys.exit(EXIT_INTERRUPTED)
        finally:
            restore(previous)  # called in-process (tests, CliRunner): leave the caller's


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="uqguide")
@click.option("-v", "--verbose", count=True, help="More log lines on stderr (-v info, -vv debug).")
def main(verbose: int) -> None:
    """Uncertainty propagation through closed-loop spacecraft guidance simulations."""
    _setup_logging(verbose)


def _check_executor_flags(workers: int | None, scheduler: str | None,
                          scheduler_file: Path | None,
                          no_workers_timeout: int | None = None) -> None:
    """ConfigError (exit 2) for executor options that cannot go together."""
    if scheduler and scheduler_file:
        raise ConfigError("--scheduler-file: give either --scheduler or --scheduler-file, "
                          "not both", field="scheduler_file")
    if (scheduler or scheduler_file) and workers:
        raise ConfigError("--workers: not used with a Dask scheduler (the cluster has its "
                          "own workers)", field="workers")
    if no_workers_timeout is not None and not (scheduler or scheduler_file):
        raise ConfigError("--no-workers-timeout: only for a Dask cluster (give --scheduler "
                          "or --scheduler-file)", field="no_workers_timeout")


def _echo_written(written: Any, again: str) -> None:
    """The report of a written run, the files it wrote, and where the runs of a method that
    failed after them are kept (``again``: the command that resumes)."""
    from .report.tables import render_text

    click.echo(render_text(written.result))
    click.echo("")
    for p in (written.h5, *written.tables):
        click.echo(f"wrote {p}")
    lost = [r.label for r in written.result.runs if not r.success and r.n_runs]
    if lost:
        click.echo(f"{', '.join(lost)}: no statistics; the runs made are kept: in {written.h5} "
                   f"(inputs, scalar outputs) and {written.h5.with_suffix('.run')} (every "
                   f"output; `{again}` fits them again without re-running the model)", err=True)


def _resume_line(n_done: int | None, n_total: int | None, again: str,
                 in_pieces: int = 0) -> str:
    """How far a stopped run got (``in_pieces``: runs of unfinished chunks kept) and the
    command that continues it."""
    from .driver.run_folder import kept_text

    done = f"{kept_text(n_done, n_total, in_pieces)}; " if n_done is not None else ""
    return f"{done}resume with `{again}`"


_CONFIG_ARG = click.argument("config", type=click.Path(dir_okay=False, path_type=Path))


_UNDECIDED = click.option(
    "--undecided", type=click.Choice(["pass", "fail"]), default=None,
    help="With the requirements gate: what an undecided verdict counts as  [default: fail].")


@main.command()
@_CONFIG_ARG
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
@click.option("--no-workers-timeout", type=click.IntRange(1, 86_400), default=None,
              metavar="SECONDS",
              help="With Dask: stop (exit 1, resumable) when the cluster has had no worker "
                   "for this long  [default: 60].")
@click.option("--resume", is_flag=True,
              help="Continue an interrupted run from its checkpoint (<out>/<name>.run).")
@click.option("--force", is_flag=True,
              help="Replace <out>/<name>.h5 even when another config made it.")
@click.option("--check", "check_path", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Then check the statistics against this baseline JSON "
                                 "(exit 1 on a regression, 2 if it is unusable).")
@click.option("--check-sensitivity", is_flag=True,
              help="With --check, also compare the Sobol' indices (as check --sensitivity).")
@click.option("--check-require-key", is_flag=True,
              help="With --check, refuse a baseline without a keyed seal (as check "
                   "--require-key).")
@click.option("--check-requirements", is_flag=True,
              help="Then gate on the requirement verdicts (as check --requirements: exit 1 "
                   "on any fail).")
@_UNDECIDED
@click.option("-q", "--quiet", is_flag=True,
              help="No progress display (and no budget lines) on stderr.")
@click.option("--strict", is_flag=True,
              help="Exit 1 when a PCE withholds a statistic at a reported point (its Monte "
                   "Carlo fallback is still reported); also the config's strict: true.")
@_handle_errors
def run(config: Path, out_dir: Path, seed: int | None, workers: int | None,
        scheduler: str | None, scheduler_file: Path | None, no_workers_timeout: int | None,
        resume: bool, force: bool, check_path: Path | None, check_sensitivity: bool,
        check_require_key: bool, check_requirements: bool, undecided: str | None, quiet: bool,
        strict: bool) -> None:
    """Propagate the uncertainty of CONFIG with every method it lists."""
    from .config.budget import estimate
    from .driver.run_folder import RunInterrupted
    from .config.run_config import load_config
    from .driver.execution import Executor, ProcessExecutor, make_executor
    from .driver.execution.cluster_watch import NO_WORKERS_TIMEOUT
    from .errors import ClusterLost
    from .driver.progress import make_progress
    from .driver.propagate import check_failure_budget, check_methods
    from .commands.run_and_write import WriteInterrupted, Written, run_and_write
    from .core.temp_folders import sweep

    sweep()  # the temporary folders a killed uqguide left (unzipped FMUs, multiprocessing's)
    _check_executor_flags(workers, scheduler, scheduler_file, no_workers_timeout)
    for flag, given in (("--check-sensitivity", check_sensitivity),
                        ("--check-require-key", check_require_key)):
        if given and not check_path:
            raise click.UsageError(f"{flag} compares with a baseline: give it with "
                                   f"--check BASELINE.json")
    if undecided is not None and not check_requirements:
        raise click.UsageError("--undecided says how the requirements gate counts an "
                               "undecided verdict: give it with --check-requirements")
    executor: Executor | None = None
    if workers and not (scheduler or scheduler_file):
        # local workers start importing now, while the config is read and checked
        pool = ProcessExecutor(workers)
        pool.start()
        executor = pool
    try:
        cfg = load_config(config)
        if seed is not None:
            cfg = cfg.with_seed(seed)
        baseline = (_gate_preflight(check_path, cfg, check_sensitivity, check_require_key)
                    if check_path else None)
        if check_requirements and not cfg.raw.requirements:
            raise click.UsageError(f"--check-requirements gates on requirement verdicts: "
                                   f"{config} lists no requirements")
        if not quiet:
            click.echo("budget:", err=True)
            for line in estimate(cfg, workers or 1).lines():
                click.echo(line, err=True)
    except BaseException:
        if executor is not None:
            executor.close()
        raise
    again = f"uqguide run {config} --resume" + (f" --out {out_dir}" if out_dir != Path(
        "results/runs") else "") + (f" --seed {seed}" if seed is not None else "") + (
        " --force" if force else "")
    if executor is None:
        executor = make_executor(workers, scheduler,
                                 str(scheduler_file) if scheduler_file else None,
                                 no_workers_timeout or NO_WORKERS_TIMEOUT)
    try:
        written = run_and_write(cfg, out_dir, executor, workers=workers or 1, resume=resume,
                                progress=make_progress(sys.stderr, quiet), resume_hint=again,
                                force=force)
    except RunInterrupted as exc:
        click.echo(f"interrupted: {_resume_line(exc.n_done, exc.n_total, again, exc.in_pieces)}",
                   err=True)
        sys.exit(EXIT_INTERRUPTED)
    except ClusterLost as exc:
        # on the same cluster once it is back (or on any other executor: the same numbers)
        where = f" --scheduler {scheduler}" if scheduler else \
            f" --scheduler-file {scheduler_file}"
        click.echo(f"error: {exc}; {_resume_line(exc.n_done, exc.n_total, again + where)}",
                   err=True)
        sys.exit(1)
    except WriteInterrupted:
        click.echo(f"interrupted while writing the result; resume with `{again}`", err=True)
        sys.exit(EXIT_INTERRUPTED)
    except MethodsFailed as exc:
        assert isinstance(exc.written, Written)
        _echo_written(exc.written, again)
        raise
    except (DiskFull, OSError) as exc:
        from .core.atomic import is_disk_full

        if not is_disk_full(exc):
            raise
        full = exc.path if isinstance(exc, DiskFull) else exc.filename or "a file"
        click.echo(f"error: disk full writing {full}; the run folder is intact; free space "
                   f"and --resume: `{again}`", err=True)
        sys.exit(1)
    result = written.result
    _echo_written(written, again)
    check_methods(result)
    check_failure_budget(result, cfg.raw.max_failed_fraction)
    if strict or cfg.raw.strict:
        from .commands.strict import check_withheld

        check_withheld(result)
    _gates(result, baseline, check_path, check_requirements, undecided,
           sensitivity=check_sensitivity)


@main.command()
@_CONFIG_ARG
@_handle_errors
def validate(config: Path) -> None:
    """Check CONFIG without running anything; print its runs and estimated peak memory.

    A ``callable`` model's module is imported (its code runs): treat a config like code.
    """
    from .config.budget import check_budget, estimate
    from .config.run_config import load_config
    from .core.temp_folders import sweep

    sweep()
    cfg = load_config(config)
    methods = ", ".join(f"{m.label} ({m.name})" for m in cfg.methods)
    source = f"model {cfg.model.name}" if cfg.data is None else \
        f"data {cfg.data['path']} ({getattr(cfg.model.params, 'n_rows', 0)} rows)"
    click.echo(f"{config}: OK — {source}, {cfg.space.dim} uncertain inputs "
               f"({', '.join(cfg.space.names) or 'none'}), outputs {', '.join(cfg.outputs)}, "
               f"methods {methods}, seed {cfg.seed}")
    budget = estimate(cfg)
    click.echo("budget (serial run):")
    for line in budget.lines():
        click.echo(line)
    if cfg.raw.requirements:
        from .stats.verdicts import plan_lines  # not report.tables: pandas is slow to import

        for line in plan_lines(cfg.raw.requirements):
            click.echo(line)
    check_budget(budget)


@main.command()
@click.argument("where", type=click.Path(exists=True, path_type=Path))
@click.option("--dry-run", is_flag=True, help="List the folders without removing them.")
@_handle_errors
def clean(where: Path, dry_run: bool) -> None:
    """Remove the work folders a `command` model's runs left (failed or killed calls).

    WHERE is a config (its model's workdir) or the folder they are in. Only folders uqguide
    made are touched: named batch-<pid>-<8 letters>, holding a call's inputs file, of a process
    that is gone.
    """
    from .models.command.leftovers import leftovers, remove

    root = where
    if where.is_file():
        from .config.run_config import load_config

        cfg = load_config(where)
        if cfg.model.name != "command":
            raise ConfigError(f"model.name: {cfg.model.name!r} leaves no work folders; "
                              f"`uqguide clean` is for a command model", field="model.name")
        root = cfg.model.params.root()  # type: ignore[attr-defined]
    found = leftovers(root)
    size = sum(f.size for f in found)
    for f in found:
        click.echo(f"{'would remove' if dry_run else 'removed'} {f.path}")
    if not dry_run:
        remove(found)
    click.echo(f"{len(found)} work folders ({size / 1e6:.2f} MB) in {root}"
               f"{' (nothing removed: --dry-run)' if dry_run else ' removed'}")


@main.command()
@_CONFIG_ARG
@click.option("--figures", "fig_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Also write the nominal run's figures (PNG) into this folder.")
@_handle_errors
def simulate(config: Path, fig_dir: Path | None) -> None:
    """Run CONFIG's model once at its nominal inputs and print its outputs: a paper's model
    its scenario's figures beside the paper's, any other model its scalars and series at the
    uncertain inputs' means (each series plotted with --figures)."""
    from .config.run_config import load_config
    from .papers import has_scenario, format_report, nominal_figures, nominal_report

    cfg = load_config(config)
    if cfg.data is not None:
        raise ConfigError("data: a config of given runs has no model to simulate", field="data")
    if has_scenario(cfg.model):
        click.echo(format_report(cfg.model.name, nominal_report(cfg.model)))
        written = nominal_figures(cfg.model, fig_dir) if fig_dir is not None else []
    else:
        from .commands.nominal import centre_run, render, write_figures

        values, out = centre_run(cfg)
        click.echo(render(values, out, list(cfg.model.outputs())))
        written = write_figures(out, cfg.name, fig_dir) if fig_dir is not None else []
    for p in written:
        click.echo(f"wrote {p}")


@main.command()
@_CONFIG_ARG
@click.option("--n", "n_runs", type=click.IntRange(1, 1_000_000), required=True,
              help="How many runs to suggest.")
@click.option("--out", "out_path", type=click.Path(dir_okay=False, path_type=Path),
              required=True, help="The CSV to write (input names as header).")
@click.option("--force", is_flag=True, help="Replace an existing --out file.")
@_handle_errors
def suggest(config: Path, n_runs: int, out_path: Path, force: bool) -> None:
    """Write the next runs that extend the design of CONFIG's data file.

    The inputs only, one row per run: run them elsewhere, append their rows with the outputs
    to the data file, and run CONFIG again. The points fill the largest holes of the file's
    design (greedy maximin over scrambled Sobol' candidates in the inputs' probability space).
    """
    from .config.data_source import write_suggestion
    from .config.run_config import load_config

    cfg = load_config(config)
    click.echo(f"wrote {write_suggestion(cfg, n_runs, out_path, force)} ({n_runs} runs)")


@main.command("compile")
@click.argument("configs", nargs=-1)
@_handle_errors
def compile_command(configs: tuple[str, ...]) -> None:
    """Compile the simulators' kernels now, once per install (every shipped study, or CONFIGS).

    For a container build, before a cluster job array, or before timing anything: a kernel
    already in the cache is only loaded.
    """
    from .commands.compile_kernels import compile_kernels, format_compiled

    click.echo(format_compiled(compile_kernels(configs)))


@main.command("configs")
@click.option("--copy", "copy", nargs=2, type=(str, click.Path(file_okay=False, path_type=Path)),
              default=None, metavar="NAME DIR", help="Copy the shipped study NAME into DIR.")
@_handle_errors
def configs_command(copy: tuple[str, Path] | None) -> None:
    """List the shipped studies (run one with `uqguide run NAME`), or copy one out to edit."""
    from .config.catalog import copy_study, studies

    if copy is not None:
        click.echo(f"wrote {copy_study(copy[0], copy[1])}")
        return
    listed = studies()
    width = max(len(s.name) for s in listed)
    for s in listed:
        click.echo(f"{s.name:<{width}}  {s.description}")


@main.command()
@click.argument("name", required=False)
@_handle_errors
def models(name: str | None) -> None:
    """List the models with their inputs, outputs and parameters (or one model: NAME)."""
    from .config.registry import MODELS, model_class
    from .report.describe import describe_model

    _echo_each([name] if name else list(MODELS), lambda n: describe_model(model_class(n, "NAME")))


@main.command()
@click.argument("name", required=False)
@_handle_errors
def methods(name: str | None) -> None:
    """List the propagation methods with their settings (NAME: one method, with the rules
    behind its defaults)."""
    from .config.registry import METHODS, method_class
    from .report.describe import describe_defaults, describe_settings

    def describe(n: str) -> str:
        cls = method_class(n, "NAME")
        rules = describe_defaults(cls) if name else ""
        return "\n".join([f"{n}: {cls.summary}", describe_settings(cls.Settings)]
                         + ([rules] if rules else []))

    _echo_each([name] if name else list(METHODS), describe)


def _echo_each(names: list[str], describe: Callable[[str], str]) -> None:
    """The description of each name, a blank line between two."""
    for i, n in enumerate(names):
        if i:
            click.echo("")
        click.echo(describe(n))


# ---------------------------------------------------------------------------- regression gate
#: A result or baseline that cannot be read or compared (ResultError): exit code 2.
_unusable_input_is_2 = functools.partial(_handle_errors, result_error=2)


@_unusable_input_is_2
def _gate_preflight(path: Path, cfg: Any, sensitivity: bool = False,
                    require_key: bool = False) -> Any:
    """The baseline of ``run --check``, matched to the config before anything runs."""
    from .gate.check import check_compatible, check_sensitivity_possible, read_baseline

    baseline = read_baseline(path, require_key)
    check_compatible(baseline, cfg.model.name, {m.label: m.name for m in cfg.methods},
                     {o: cfg.model.output_info(o) for o in cfg.outputs}, str(path))
    if sensitivity:
        check_sensitivity_possible(baseline, str(path))
    return baseline


@_unusable_input_is_2
def _gate_verdict(result: Any, baseline: Any, path: Path, sigmas: float | None = None,
                  pce_rtol: float | None = None, show_all: bool = False,
                  sensitivity: bool = False) -> None:
    """Print the check of ``result`` against ``baseline``; exit 1 on a regression."""
    from .gate.check import check_result
    from .gate.tolerances import DEFAULT_SIGMAS

    report = check_result(result, baseline, DEFAULT_SIGMAS if sigmas is None else sigmas,
                          pce_rtol, str(path), sensitivity=sensitivity)
    click.echo(report.render(show_all))
    if not report.passed:
        sys.exit(1)


class _GateTolerance(click.ParamType):
    """A gate tolerance within its limits (:mod:`uqguide.gate.tolerances`), the same range for
    ``check`` and ``baseline`` (click's FloatRange lets inf and nan through)."""

    name = "float"

    def __init__(self, option: str) -> None:
        self.option = option

    def convert(self, value: Any, param: Any, ctx: Any) -> float:
        from .gate.tolerances import tolerance_problem

        problem = tolerance_problem(self.option, value)
        if problem:
            self.fail(problem.split(": ", 1)[1], param, ctx)
        return float(value)


SIGMAS = _GateTolerance("--sigmas")
PCE_RTOL = _GateTolerance("--pce-rtol")

_RESULT_ARG = click.argument("result_path", metavar="RESULT",
                             type=click.Path(dir_okay=False, path_type=Path))


@main.command()
@_RESULT_ARG
@click.option("--baseline", "baseline_path", default=None,
              type=click.Path(dir_okay=False, path_type=Path),
              help="Baseline JSON written by `uqguide baseline`.")
@click.option("--requirements", "requirements", is_flag=True,
              help="Gate on the result's requirement verdicts: exit 1 on any fail, 0 when "
                   "all pass (undecided as --undecided says).")
@_UNDECIDED
@click.option("--sigmas", type=SIGMAS, default=None,
              help="Monte Carlo tolerance in combined standard errors, at most 10 "
                   "[default: 4].")
@click.option("--pce-rtol", type=PCE_RTOL, default=None,
              help="Relative tolerance of PCE statistics, at most 0.2 [default: the "
                   "baseline's].")
@click.option("--all", "show_all", is_flag=True,
              help="List every compared statistic, not only the failing ones.")
@click.option("--sensitivity", is_flag=True,
              help="Also compare the Sobol' indices (the error budget) within their "
                   "combined intervals; the baseline must hold them (format 4).")
@click.option("--require-key", is_flag=True,
              help="Refuse (exit 2) a baseline without a keyed seal made with the key in "
                   "UQGUIDE_BASELINE_KEY: its digest alone detects accidental edits only.")
@_unusable_input_is_2
def check(result_path: Path, baseline_path: Path | None, requirements: bool,
          undecided: str | None, sigmas: float | None, pce_rtol: float | None,
          show_all: bool, sensitivity: bool, require_key: bool) -> None:
    """Compare the statistics of RESULT with a baseline (--baseline), or gate on its
    requirement verdicts (--requirements), or both.

    Exit 0 when every statistic is within tolerance and every verdict passes, 1 on a
    regression (the failing quantities are listed with value, baseline and tolerance) or a
    failing verdict, 2 when RESULT or the baseline is unusable.
    """
    from .gate.check import read_baseline
    from .results.result import read_hdf5

    if baseline_path is None and not requirements:
        raise click.UsageError("give --baseline BASELINE.json, --requirements, or both")
    if undecided is not None and not requirements:
        raise click.UsageError("--undecided says how the requirements gate counts an "
                               "undecided verdict: give it with --requirements")
    baseline = read_baseline(baseline_path, require_key) if baseline_path else None
    _gates(read_hdf5(result_path), baseline, baseline_path, requirements, undecided,
           sigmas=sigmas, pce_rtol=pce_rtol, show_all=show_all, sensitivity=sensitivity)


def _gates(result: Any, baseline: Any, baseline_path: Path | None, requirements: bool,
           undecided: str | None, **tolerances: Any) -> None:
    """The baseline gate (with a baseline), then the requirements gate (when asked); exit 1
    when either fails, after both have printed."""
    regression = False
    if baseline_path is not None:
        try:
            _gate_verdict(result, baseline, baseline_path, **tolerances)
        except SystemExit as exc:
            if exc.code != 1 or not requirements:
                raise
            regression = True
    if requirements:
        _requirements_verdict(result, undecided or "fail")
    if regression:
        sys.exit(1)


@_unusable_input_is_2
def _requirements_verdict(result: Any, undecided: str) -> None:
    """Print the requirements gate of ``result``; exit 1 when a verdict blocks it."""
    from .gate.requirements import blocking_verdicts, gate_lines

    blocking = blocking_verdicts(result, "pass" if undecided == "pass" else "fail")
    for line in gate_lines(blocking, sum(len(r.verdicts) for r in result.runs)):
        click.echo(line)
    if blocking:
        sys.exit(1)


@main.command()
@_RESULT_ARG
@click.option("-o", "--output", "out_path", required=True,
              type=click.Path(dir_okay=False, path_type=Path), help="Baseline JSON to write.")
@click.option("--pce-rtol", type=PCE_RTOL, default=0.02, show_default=True,
              help="Relative tolerance of PCE statistics, stored in it; at most 0.2.")
@click.option("--force", is_flag=True, help="Replace an existing baseline (on purpose).")
@_unusable_input_is_2
def baseline(result_path: Path, out_path: Path, pce_rtol: float, force: bool) -> None:
    """Write the baseline of RESULT: its statistics, their uncertainties, config and versions.

    With UQGUIDE_BASELINE_KEY set it also carries a keyed seal (HMAC-SHA256) that
    `uqguide check --require-key` verifies.
    """
    from .gate.baseline import KEY_ENV, baseline_key
    from .gate.check import write_baseline
    from .results.result import read_hdf5

    if out_path.exists() and not force:
        raise ConfigError(f"{out_path}: baseline exists; baselines change only on purpose: "
                          f"pass --force to replace it")
    written = write_baseline(read_hdf5(result_path), out_path, pce_rtol)
    how = f" (sealed with the key in {KEY_ENV})" if baseline_key() is not None else ""
    click.echo(f"wrote {written}{how}")


@main.command()
@_RESULT_ARG
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Folder of the figures [default: RESULT's folder/figures].")
@click.option("--format", "fmt", type=click.Choice(["png", "svg", "pdf"]), default="png",
              show_default=True, help="File format (svg, pdf: vector, for a review deck).")
@_unusable_input_is_2
def plot(result_path: Path, out_dir: Path | None, fmt: str) -> None:
    """Figures of RESULT: statistics over time, scalar histograms, the cost table."""
    from .report.plots import write_figures
    from .results.result import read_hdf5

    result = read_hdf5(result_path)
    for f in write_figures(result, out_dir or result_path.parent / "figures", fmt=fmt):
        click.echo(f"wrote {f.path}")


@main.command()
@_RESULT_ARG
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=None, help="Folder of the report [default: RESULT's folder]; the "
                                 "figures go into its figures/ subfolder.")
@click.option("--baseline", "baseline_path", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Also include the regression check against this baseline.")
@_unusable_input_is_2
def report(result_path: Path, out_dir: Path | None, baseline_path: Path | None) -> None:
    """A Markdown report of RESULT embedding its figures and tables."""
    from .gate.check import check_result, read_baseline
    from .report.document import write_report
    from .results.result import read_hdf5

    result = read_hdf5(result_path)
    check_report = None
    if baseline_path is not None:
        check_report = check_result(result, read_baseline(baseline_path),
                                    source=str(baseline_path))
    path, figures = write_report(result, out_dir or result_path.parent, check_report)
    for f in figures:
        click.echo(f"wrote {f.path}")
    click.echo(f"wrote {path}")


@main.command()
@_RESULT_ARG
@click.option("--label", required=True, help="Method label of the sample (e.g. mc1e4).")
@click.option("--sample", type=int, default=None, help="Sample number (0-based).")
@click.option("--worst", default=None, metavar="OUTPUT",
              help="The sample with the largest value of this scalar output.")
@click.option("--lowest", is_flag=True, help="With --worst: the smallest value instead.")
@click.option("--component", default=None, help="With --worst: component of the output.")
@click.option("--event", default=None, metavar="NAME",
              help="The first sample in this event of the config.")
@click.option("--out", "out_dir", type=click.Path(file_okay=False, path_type=Path),
              default=Path("replay"), show_default=True,
              help="Folder of the histories and figures (created; nothing is written "
                   "beside RESULT unless this names its folder).")
@click.option("--exact", is_flag=True,
              help="Any difference from the stored scalars exits 1, round-off included (on "
                   "the machine that wrote RESULT).")
@click.option("--run-code", is_flag=True,
              help="Run the code RESULT's model names (a callable's Python module, a "
                   "command's program, an FMU): only for a file you trust.")
@click.option("--config", "own_path", type=click.Path(dir_okay=False, path_type=Path),
              default=None, help="Your own config of RESULT's study: when its model "
                                 "section is RESULT's, that code is yours and runs without "
                                 "--run-code.")
@_unusable_input_is_2
def replay(result_path: Path, label: str, sample: int | None, worst: str | None,
           lowest: bool, component: str | None, event: str | None,
           out_dir: Path, exact: bool, run_code: bool, own_path: Path | None) -> None:
    """Rerun one sample of RESULT: its scalars (checked), histories and figures.

    Exit 0 when the replayed scalars equal the stored ones bit for bit or to round-off (at
    most 1e-9 relative: another CPU's last bits), 1 when they differ by more (the code or a
    dependency changed since RESULT was written; with --exact, by any bit), 2 on bad input.

    RESULT names the model that made it. A callable, command or fmu model is code (a Python
    module, a program, an FMU's binary) that the replay imports and runs, so a result file
    someone sent you can run any code: such a replay first says what it runs, and needs
    --run-code, or --config with your own config of the same model (exit 2 otherwise). The
    built-in simulators need neither.
    """
    from .commands.replay import (ROUNDOFF, allowed_code, render, replay as replay_sample,
                                  write_replay)
    from .config.run_config import load_config
    from .results.result import read_hdf5

    result = read_hdf5(result_path)
    own = load_config(own_path) if own_path is not None else None
    for code in allowed_code(result, run_code=run_code, own=own, source=str(result_path)):
        click.echo(f"replay runs {code}", err=True)
    rep, cfg = replay_sample(result, label, run_code=True, sample=sample, worst=worst,
                             lowest=lowest, event=event, component=component)
    click.echo(render(rep))
    for p in write_replay(rep, cfg, result.name, out_dir):
        click.echo(f"wrote {p}")
    bad = rep.mismatches(0.0 if exact else ROUNDOFF)
    if bad:
        more = "" if exact else f" by more than round-off ({ROUNDOFF:g} relative)"
        raise UqguideError(f"replayed scalars differ from the stored ones{more}: "
                           f"{', '.join(bad)} (code or dependency changed since the result was "
                           f"written?)")
    largest = max(rep.differences().values(), default=0.0)
    if largest == 0.0:
        click.echo("replayed scalars equal the stored ones bit for bit")
    else:
        click.echo(f"replayed scalars equal the stored ones to round-off (largest relative "
                   f"difference {largest:.1e}, at most {ROUNDOFF:g}: another CPU or math "
                   f"library; --exact to require every bit)")


def entry() -> None:
    """The ``uqguide`` program: :func:`main`, then signals ignored while the interpreter exits
    (the command is over, its files written or refused: a late Ctrl-C has nothing to stop and
    must not turn a finished run into a killed one)."""
    install()  # first thing: a Ctrl-C from here on is exit 130
    try:
        main()
    except SystemExit as exc:
        if exc.code != EXIT_INTERRUPTED:
            raise
        # A Ctrl-C that landed inside a C extension's PyRun_String (Cython module imports do
        # that) leaves CPython's "unhandled KeyboardInterrupt" flag set, and the interpreter
        # would then kill itself with SIGINT at exit even though the interrupt was handled.
        # Everything is written or refused and the lock released: leave with 130 directly.
        ignore_signals()
        import atexit

        atexit._run_exitfuncs()  # multiprocessing's clean-up, logging's flush
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        os._exit(EXIT_INTERRUPTED)
    finally:
        ignore_signals()


if __name__ == "__main__":  # pragma: no cover
    entry()
