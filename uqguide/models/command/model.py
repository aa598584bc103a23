"""Any executable as a model: its parameters and the batch interface.

The config's ``model: {name: command, command: "./mysim {inputs} {outputs}", inputs: [...],
outputs: [...]}`` (the template split like a shell would, run without one; ``timeout_s``,
``env``, ``per_sample``, ``shell``, ``workdir``). Each call (a batch, or a sample with
``per_sample``) gets a fresh work folder under ``workdir``, its current folder, holding the
inputs and outputs files and ``stdout.txt``/``stderr.txt``, removed when the call succeeds. The
file formats are in :mod:`.files`, running the program in :mod:`.process`. A sample with
non-finite outputs or ``failed`` 1 fails; a failing call (exit status, signal, ``timeout_s``,
an unusable outputs file) raises :class:`~.process.CommandFailed` and the engine splits the
batch; a malformed outputs file is a :class:`~uqguide.errors.ModelError` and stops the run. No
process the program started outlives its call, and the run's data never reaches a shell. The
config, failures and trust: ``docs/your-simulator.md``.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from ...core.names import PLAIN_NAME_RULE, is_plain_name
from ...core.failures import KEPT_FOLDER
from ...core.process_groups import MARK
from ...errors import ModelError
from ...core.types import ModelOutput
from ..config_dir import ConfigDirParams
from ..callable import (CallableOutput, DeclaredModel, DeclaredParams, check_output_names,
                        non_finite)
from . import process
from .files import NON_FINITE, OutputSpec, read_outputs, write_inputs
from .process import PLACEHOLDERS, CommandFailed, Deadline

_ENV_NAME = "letters, digits and '_', not starting with a digit"
#: Variables each call's environment gets from uqguide, and what they hold.
_RESERVED_ENV = {**{v: f"the value of {{{k}}}" for k, v in process.ENV_NAMES.items()},
                 MARK: "the mark uqguide finds the call's processes by"}

#: The conformance example: a Python program (stdlib only) reading inputs.csv and writing
#: y = a + b^2 and the series path = y t on three times.
_EXAMPLE = """
import csv, sys
rows = list(csv.reader(open(sys.argv[1])))[1:]
ys = [float(a) + float(b) ** 2 for a, b in rows]
with open(sys.argv[2], 'w') as f:
    f.write('y\\n' + ''.join(repr(y) + '\\n' for y in ys))
with open(sys.argv[2][:-4] + '_path.csv', 'w') as f:
    f.write('0.0,0.5,1.0\\n' + ''.join(f'0.0,{y * 0.5!r},{y!r}\\n' for y in ys))
"""


#: Failed calls' work folders kept per process; later ones are removed, their reason says so.
KEEP_FAILED = 20


class CommandParams(ConfigDirParams, DeclaredParams):
    command: str = Field(min_length=1, description=(
        "the program and its arguments, split like a shell would but run without one; "
        f"placeholders: {', '.join('{' + p + '}' for p in PLACEHOLDERS)}"))
    inputs: list[str] = Field(min_length=1,
                              description="names of the inputs file's columns, in order")
    nominal: list[float] | None = Field(default=None,
                                        description="values of inputs not made uncertain")
    outputs: list[str | CallableOutput] = Field(default=["y"], min_length=1, description=(
        "the outputs the program writes: names, or {name, kind: scalar|series, components, "
        "unit, description, component_names}"))
    input_format: Literal["csv", "hdf5"] = Field(default="csv",
                                                 description="format of the inputs file")
    output_format: Literal["csv", "hdf5"] = Field(default="csv",
                                                  description="format of the outputs file(s)")
    timeout_s: float | None = Field(default=None, gt=0.0, le=1e6, description=(
        "seconds a call may take, reading its outputs included, before the program and every "
        "process it started are killed [s]"))
    env: dict[str, str | int | float] = Field(
        default={}, description="environment variables set for the program")
    per_sample: bool = Field(default=False,
                             description="one process per sample (a one-row inputs file)")
    shell: bool = Field(default=False, description=(
        "run the command through /bin/sh -c; each placeholder becomes its environment "
        "variable (\"$UQ_INPUTS\"...), never spliced text"))
    workdir: str | None = Field(default=None, description=(
        "folder under which each call's work folder is made (default: "
        "<tmp>/uqguide-command-<uid>; a relative path is taken from the config's folder)"))
    config_dir: str | None = Field(default=None, description=(
        "folder a relative program path is found in (set by uqguide: the config's folder or "
        "the current folder)"))

    @field_validator("command")
    @classmethod
    def _template(cls, v: str) -> str:
        unknown = process.unknown_placeholders(v)
        if unknown:
            raise ValueError(f"unknown placeholder {{{unknown[0]}}}; allowed: "
                             f"{', '.join('{' + p + '}' for p in PLACEHOLDERS)}")
        try:
            if not shlex.split(v):
                raise ValueError("names no program")
        except ValueError as exc:
            raise ValueError(f"cannot be split into arguments ({exc})") from None
        return v

    @field_validator("inputs")
    @classmethod
    def _plain_inputs(cls, v: list[str]) -> list[str]:
        for name in v:
            if not is_plain_name(name):
                # an input name is a column of the inputs file (and an HDF5 dataset)
                raise ValueError(f"input name {name!r} must be {PLAIN_NAME_RULE}")
        if len(set(v)) != len(v):
            raise ValueError(f"inputs must be unique names, got {v}")
        return v

    @field_validator("outputs", mode="before")
    @classmethod
    def _plain_output_names(cls, v: Any) -> Any:
        v = check_output_names(v)
        if isinstance(v, list) and any(
                (o.get("name") if isinstance(o, Mapping) else o) in ("failed", "reason")
                for o in v):
            raise ValueError("'failed' and 'reason' name the outputs file's failure columns, "
                             "not outputs")
        return v

    @field_validator("env")
    @classmethod
    def _env_names(cls, v: dict[str, Any]) -> dict[str, Any]:
        for k in v:
            if not re.fullmatch(r"[A-Za-z_]\w*", k, re.ASCII):
                raise ValueError(f"environment variable name {k!r} must be {_ENV_NAME}")
            if k in _RESERVED_ENV:
                raise ValueError(f"environment variable {k} is set by uqguide for each call "
                                 f"({_RESERVED_ENV[k]}); choose another name")
        return v

    @model_validator(mode="after")
    def _consistent(self) -> CommandParams:
        if self.shell:
            try:
                process.shell_script(self.command)
            except ValueError as exc:
                self._refuse("command", str(exc))
        self._check_program()
        return self

    def _check_program(self) -> None:
        """A program that cannot be found is a config error, not a run of failed samples."""
        program = (process.shell_program(self.command) if self.shell else
                   shlex.split(self.command)[0])
        if program is None or "{" in program:
            return
        path = self.program_file()
        if "/" in program:
            if path is None or not path.is_file() or not os.access(path, os.X_OK):
                self._refuse("command", f"program {program!r}: no executable file {path} (a "
                                        f"relative path is taken from the config's folder)")
        elif path is None:
            self._refuse("command", f"program {program!r} is not on PATH (give its path, e.g. "
                                    f"'./{program}' for one in the config's folder)")

    def program_file(self) -> Path | None:
        """The file of the program the command starts (what a resumed run checks unchanged);
        None for a program named by a placeholder, one not found, or with ``shell: true`` one
        not given by its path."""
        program = process.shell_program(self.command) if self.shell else \
            os.path.expanduser(shlex.split(self.command)[0])
        if program is None or "{" in program:
            return None
        if "/" in program:
            return Path(self.config_dir or ".", program)
        found = shutil.which(program, path=self.environment().get("PATH"))
        return Path(found) if found else None

    def environment(self) -> dict[str, str]:
        """The program's environment: uqguide's, with ``env`` set over it."""
        return {**os.environ, **{k: str(v) for k, v in self.env.items()}}

    def root(self) -> Path:
        """The folder the work folders are made in."""
        # one per user: another account's folder of the same name would not be writable
        return Path(self.config_dir or ".", self.workdir or
                    Path(tempfile.gettempdir(), f"uqguide-command-{os.getuid()}"))


class CommandModel(DeclaredModel):
    """An executable program, run on files of inputs and outputs, as a uqguide model."""

    name = "command"
    summary = "any executable run on a file of inputs, writing a file of outputs"
    Params = CommandParams
    declares_inputs = True
    params: CommandParams
    #: Fidelity levels of a program are other command lines with the same inputs and outputs
    #: (``fidelities: [{}, {command: "./sim --dt 0.1 {inputs} {outputs}"}]``).
    fidelity_params = ("command",)
    example_params = {
        "command": f"{shlex.quote(sys.executable)} -c {shlex.quote(_EXAMPLE)} "
                   "{inputs} {outputs}",
        "inputs": ["a", "b"], "nominal": [1.0, 0.5],
        "outputs": ["y", {"name": "path", "kind": "series"}]}

    input_column = "column {j} of the inputs file"

    @classmethod
    def named_code(cls, section: Mapping[str, Any]) -> str:
        shell = " through /bin/sh" if section.get("shell") else ""
        return (f"the program {section.get('command')!r}{shell} (relative paths from "
                f"{section.get('config_dir')!r})")

    def _source(self) -> str:
        return "the command"

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int,
                  outputs: frozenset[str]) -> ModelOutput:
        x = np.column_stack([values[name] for name in self.params.inputs])
        specs = [OutputSpec(s.name, s.kind, s.components) for s in self._specs()
                 if s.name in outputs]
        if n == 0:
            return _nan_output(specs, 0, np.zeros(0), "")
        root = self.params.root()
        try:
            root.mkdir(parents=True, exist_ok=True)
            folder = Path(tempfile.mkdtemp(prefix=f"batch-{os.getpid()}-", dir=root))
        except OSError as exc:
            # not a sample's fault: splitting the batch would fail the same way
            raise ModelError(f"cannot make a work folder in {root} (model.workdir): "
                             f"{exc.strerror or exc}") from None
        try:
            if self.params.per_sample:
                out, crashed = self._per_sample(folder, x, specs)
            else:
                out, crashed = self._call(folder, folder.name, x, specs), False
        except ModelError:
            raise  # it stops the run: its work folder is kept, the message names it
        except CommandFailed as exc:
            # A failed call of several samples is split by the engine and its halves run
            # again: their folders, down to the failing samples', say the same thing.
            if n == 1 and self._keep():
                raise  # the work folder is kept for inspection: the message names it
            shutil.rmtree(folder, ignore_errors=True)
            why = "the batch is split" if n > 1 else f"{KEEP_FAILED} kept already"
            raise CommandFailed(KEPT_FOLDER.sub(f"work folder removed ({why})", str(exc))) from None
        except BaseException:
            shutil.rmtree(folder, ignore_errors=True)
            raise
        if crashed and not self._keep():  # a crashed sample's reason names its folder
            shutil.rmtree(folder, ignore_errors=True)
            out.reasons[out.failed] = [
                KEPT_FOLDER.sub(f"work folder removed ({KEEP_FAILED} kept already)", str(r))
                for r in out.reasons[out.failed]]
        elif not crashed:
            shutil.rmtree(folder, ignore_errors=True)
        return out

    def _keep(self) -> bool:
        """Whether a failed call's work folder may be kept: at most :data:`KEEP_FAILED` in
        this process (89 failing samples left 386 folders)."""
        self._kept = getattr(self, "_kept", 0) + 1
        return self._kept <= KEEP_FAILED

    def _call(self, folder: Path, batch: str, x: np.ndarray, specs: list[OutputSpec]
              ) -> ModelOutput:
        """One process on the samples ``x (n, d)`` in ``folder``; ``batch`` fills {batch}."""
        p = self.params
        ext = {"csv": ".csv", "hdf5": ".h5"}
        inputs = folder / f"inputs{ext[p.input_format]}"
        outputs = folder / f"outputs{ext[p.output_format]}"
        write_inputs(inputs, p.inputs, x, p.input_format)
        filled = {"inputs": str(inputs), "input_file": str(inputs), "outputs": str(outputs),
                  "output_file": str(outputs), "workdir": str(folder), "batch": batch,
                  "config_dir": p.config_dir or os.getcwd()}
        deadline = Deadline.start(p.timeout_s)  # for the program and the reading of its files
        process.run(process.argv(p.command, filled, p.shell), folder,
                    {**p.environment(), **{process.ENV_NAMES[k]: v for k, v in filled.items()}},
                    deadline)
        try:
            got = read_outputs(outputs, specs, x.shape[0], p.output_format, deadline)
        except ModelError as exc:
            raise ModelError(f"{exc} (work folder kept: {folder})") from None
        except CommandFailed as exc:
            raise CommandFailed(f"{exc}; work folder kept: {folder}") from None
        bad = got.failed | non_finite([*got.scalars.values(), *got.series.values()], x.shape[0])
        got.reasons[bad & ~got.failed] = NON_FINITE
        got.failed = bad
        return got

    def _per_sample(self, folder: Path, x: np.ndarray, specs: list[OutputSpec]
                    ) -> tuple[ModelOutput, bool]:
        """One process per sample, each in a sub-folder; a failing process fails its sample
        (no split is needed to find it). Also says whether any process failed."""
        parts: list[ModelOutput | str] = []
        for i in range(x.shape[0]):
            sub = folder / f"sample-{i}"
            sub.mkdir()
            try:
                parts.append(self._call(sub, f"{folder.name}-{i}", x[i:i + 1], specs))
                shutil.rmtree(sub, ignore_errors=True)
            except CommandFailed as exc:
                parts.append(f"{type(exc).__name__}: {exc}")
        grid = next((p.time for p in parts if isinstance(p, ModelOutput)), np.zeros(0))
        out = ModelOutput.concatenate([p if isinstance(p, ModelOutput) else
                                       _nan_output(specs, 1, grid, p) for p in parts])
        return out, any(isinstance(p, str) for p in parts)


def _nan_output(specs: list[OutputSpec], n: int, grid: np.ndarray, reason: str) -> ModelOutput:
    """``n`` samples of NaN outputs on ``grid``, failed with ``reason`` (none when empty)."""
    return ModelOutput(
        time=grid,
        series={s.name: np.full((n, grid.size, s.components), np.nan)
                for s in specs if s.kind == "series"},
        scalars={s.name: np.full((n, s.components), np.nan)
                 for s in specs if s.kind == "scalar"},
        failed=np.full(n, bool(reason)), reasons=np.full(n, reason, dtype=object))
