"""The run configuration: YAML validated into typed objects before anything runs.

Every error is a :class:`~uqguide.errors.ConfigError` with one line that names the field path
(``methods[1].n_samples``), the value given and what is allowed. Unknown keys are errors. The
keys (``model``, ``inputs``, ``correlations``, ``outputs``, ``report_times``, ``methods``,
``reference``, ``seed``, ``batch_size``, the failure, quantile, event and group settings and the
budgets), all SI, are documented with their defaults in docs/config.md.
"""

from __future__ import annotations

import difflib
import re
import typing
from dataclasses import replace
from types import MappingProxyType
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

import numpy as np
import yaml
from pydantic import BaseModel, Field, ValidationError, field_validator

from ..errors import ConfigError
from ..core.events import EventSpec, component_index
from ..core.requirements import RequirementSpec
from ..stats.quantiles import resolve_levels
from ..core.strict import StrictModel, leaves
from ..core.inputs import DISTRIBUTIONS, CorrelatedGroup, InputSpace, Marginal, Normal
from ..core.names import PLAIN_NAME_RULE, is_plain_name
from .limits import SIZE_RULE, DEFAULT_MAX_STEPS, check_steps, memory_limit, parse_bytes
from .report_times import check_report_times, model_time_grid, outside_grid
from ..methods.base import Method, RunContext
from ..models.base import Model
from .registry import did_you_mean, method_class, model_class


class CorrelationSpec(StrictModel):
    inputs: list[str] = Field(min_length=2)
    matrix: list[list[float]]


#: What a run name may be (:func:`~uqguide.core.names.is_plain_name`): it names files inside
#: ``--out`` (result, tables, run folder), so never a path, never ``.`` or ``..``.
RUN_NAME_RULE = ("a plain file name of 1 to 200 letters, digits, '_', '.' or '-' (no path "
                 "separators, not '.' or '..')")


def check_run_name(name: str) -> str:
    """``name`` unchanged if it is a valid run name, else ConfigError (field ``name``)."""
    if not is_plain_name(name):
        raise ConfigError(f"name: must be {RUN_NAME_RULE} (got {_short(name)})", field="name")
    return name


class RawConfig(StrictModel):
    """The config file's top level, before model- and method-specific validation."""

    name: str | None = None
    description: str | None = None
    #: The simulator to run; or, in its place, ``data``: runs already made
    #: (:mod:`uqguide.config.data_source`).
    model: dict[str, Any] | None = None
    data: Any = None
    inputs: list[Marginal] = Field(default_factory=list)
    correlations: list[CorrelationSpec] = Field(default_factory=list)
    outputs: list[str] | None = Field(default=None, min_length=1)
    report_times: list[float] | None = None
    methods: list[dict[str, Any]] = Field(min_length=1)
    reference: str | None = None
    seed: int = Field(default=0, ge=0, lt=2**63)
    batch_size: int = Field(default=10_000, ge=1, le=10_000_000)
    #: Largest share of a method's runs that may fail before ``uqguide run`` exits 1 (the
    #: result is still written); why 1%: docs/config.md#failed-runs.
    max_failed_fraction: float = Field(default=0.01, ge=0.0, le=1.0)
    #: Whether a statistic a PCE withholds makes ``uqguide run`` exit 1 (as ``--strict``); off,
    #: the report gives the runs' own Monte Carlo estimate in its place.
    strict: bool = False
    #: A quadrature PCE (tensor, Smolyak) needs every node: ``fail`` (default) stops the method
    #: with the failed nodes named; ``regression`` fits the coefficients by least squares on
    #: the surviving nodes, with a warning and a diagnostics entry.
    pce_failure_policy: Literal["fail", "regression"] = "fail"
    #: Quantile levels in (0, 1), or ``3sigma`` (the median and the 3-sigma envelope).
    quantiles: list[float] | str | None = None
    #: Events on scalar outputs whose probabilities every method reports.
    events: list[EventSpec] = Field(default_factory=list)
    #: Requirements on scalar outputs that every method gives a verdict on
    #: (docs/requirements.md); each is counted as the event of its name.
    requirements: list[RequirementSpec] = Field(default_factory=list)
    #: Groups of inputs (name -> inputs) whose joint first-order Sobol' index the methods that
    #: estimate indices report; default (None): each correlated group, named by its inputs.
    groups: dict[str, list[str]] | None = None
    #: Integration steps one model run may take (a dt of 1e-9 s would run for ever).
    max_steps: int = Field(default=DEFAULT_MAX_STEPS, ge=1, le=10**12)
    #: Largest estimated peak memory of a run ("8 GB", or bytes); default half the machine's
    #: memory, decided when the run starts (so a config means the same on every machine).
    max_memory: int | float | str | None = None
    #: Seconds one model call may take (None: no limit). Set, every call runs in a guard
    #: process; a call over time is killed and bisected, so a hanging sample fails alone.
    #: A call is ``batch_size`` samples (chunk rows at most): size it for that.
    timeout_s: float | None = Field(default=None, gt=0.0, le=1e6)

    @field_validator("max_memory", mode="before")  # before: one message for every wrong type
    @classmethod
    def _memory(cls, v: Any) -> Any:
        if isinstance(v, dict):  # a mapping's check names its value (_from_validation)
            raise ValueError(f"{SIZE_RULE} (got {_short(v)})")
        if v is not None:
            parse_bytes(v)
        return v

    @field_validator("name")
    @classmethod
    def _plain_name(cls, v: str | None) -> str | None:
        if v is not None and not is_plain_name(v):
            raise ValueError(f"must be {RUN_NAME_RULE}")
        return v


@dataclass
class RunConfig:
    """A validated configuration, ready to run.

    ``raw``: the validated file content (its ``model_dump`` is the resolved config written to
    results); ``source``: path of the config file, or ``"<dict>"``.
    """

    model: Model
    space: InputSpace
    outputs: tuple[str, ...]
    methods: list[Method]
    raw: RawConfig
    source: str = "<dict>"
    #: With ``data:``: the stored form of the data section (path, time grid, digest).
    data: dict[str, Any] | None = None
    _resolved: dict[str, Any] | None = field(default=None, init=False, repr=False,
                                             compare=False)

    @property
    def seed(self) -> int:
        return self.raw.seed

    @property
    def reference(self) -> str | None:
        return self.raw.reference

    @property
    def report_times(self) -> list[float] | None:
        return self.raw.report_times

    @property
    def isolate(self) -> bool:
        """Whether a run without workers makes the model's calls in a child process: the
        config's ``model.isolate``, else the model's own
        :attr:`~uqguide.models.base.Model.may_crash`."""
        v = self._model_section.get("isolate")
        return self.model.may_crash if v is None else bool(v)

    @property
    def isolate_asked(self) -> bool:
        """Whether the config itself asked for isolation (``model.isolate: true``): then a
        model that cannot run in a child process is an error, not a fallback."""
        return self._model_section.get("isolate") is True

    @property
    def _model_section(self) -> dict[str, Any]:
        """The config's ``model:`` mapping (empty for a ``data:`` config)."""
        return self.raw.model if isinstance(self.raw.model, dict) else {}

    @property
    def max_memory(self) -> int:
        """Bytes a run may plan to use (the config's ``max_memory`` or half the machine's)."""
        return memory_limit(self.raw.max_memory)

    @property
    def name(self) -> str:
        if self.raw.name:
            return self.raw.name
        if self.source == "<dict>":
            return "run"
        # The file's stem, made a plain name (a name must never leave --out).
        stem = re.sub(r"[^A-Za-z0-9_.\-]", "_", Path(self.source).stem)[:200]
        return stem if is_plain_name(stem) else "run"

    def resolved(self) -> dict[str, Any]:
        """The config with every default filled in (what the run really used), made once per
        config: the run folder's identity, the same-study check and the result all read it.
        JSON-ready, the model's and every method's settings in full, methods labelled; shared: not
        to be modified."""
        if self._resolved is None:
            self._resolved = self._resolve()
        return self._resolved

    def _resolve(self) -> dict[str, Any]:
        # the raw model section may hold a function object (callable model from Python): the
        # model's own params serialise it
        rest = self.raw.model_dump(mode="json", exclude={"model", "data"})
        d: dict[str, Any] = {k: rest.get(k) for k in RawConfig.model_fields}  # in field order
        if self.data is not None:  # the data's model is the file: data: says which
            d["model"], d["data"] = None, dict(self.data)
        else:
            d["model"] = {"name": self.model.name, **self.model.params.model_dump(mode="json")}
            d["data"] = None
            if self._model_section.get("isolate") is not None:  # only when given: results
                d["model"]["isolate"] = self._model_section["isolate"]  # made before compare
        d["outputs"] = list(self.outputs)
        d["methods"] = [{"name": m.name, **m.settings.model_dump(mode="json"), "label": m.label}
                        for m in self.methods]
        return d

    def with_seed(self, seed: int) -> RunConfig:
        """The same config with another seed (validated again)."""
        return validate_config({**self.raw.model_dump(mode="python"), "seed": seed}, self.source)


def _locate(root: type[BaseModel], loc: tuple[Any, ...]) -> tuple[list[Any], Any]:
    """pydantic's error location ``loc`` in ``root`` as the file's keys and indices (the label
    pydantic gives the union branch it tried is no key of the file: dropped), and the type at
    its end (``Any`` past what the annotations say)."""
    keys: list[Any] = []
    ann: Any = root
    for part in loc:
        options = leaves(ann)
        if isinstance(part, str) and len(options) > 1:  # in a union: the branch's label
            ann = next((a for a in options if _is_branch(a, part)), Any)
            continue
        owner = next((m for m in _models(ann) if isinstance(part, str) and part in m.model_fields),
                     None)
        maps = [a for a in options if typing.get_origin(a) is dict]
        if isinstance(part, int):
            seqs = [typing.get_args(a) for a in options if typing.get_origin(a) in (list, tuple)]
            ann = seqs[0][0] if seqs and seqs[0] else Any
        elif owner is not None:
            ann = owner.model_fields[part].annotation
        elif maps:
            ann = typing.get_args(maps[0])[1]
        else:
            ann = Any
        keys.append(part)
    return keys, ann


def _models(annotation: Any) -> list[type[BaseModel]]:
    """The pydantic models among the types ``annotation`` allows."""
    return [a for a in leaves(annotation) if isinstance(a, type) and issubclass(a, BaseModel)]


def _is_branch(option: Any, label: str) -> bool:
    """Whether ``label`` is pydantic's name of the union branch ``option``: a discriminated
    model's tag (``normal``) or the type's name (``int``, ``list[float]``, a model's)."""
    if isinstance(option, type) and issubclass(option, BaseModel):
        return label == option.__name__ or any(
            label in typing.get_args(f.annotation) for f in option.model_fields.values()
            if typing.get_origin(f.annotation) is Literal)
    name = getattr(typing.get_origin(option) or option, "__name__", None)
    return label.split("[")[0] == name


def _path(prefix: str, keys: list[Any]) -> str:
    out = prefix
    for part in keys:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += f".{part}" if out else str(part)
    return _printable(out)


def _keys_allowed(root: type[BaseModel], parent: tuple[Any, ...],
                  also: tuple[str, ...]) -> list[str] | None:
    """The keys the mapping at ``parent`` (pydantic's location) may hold; ``also``: the keys
    ``root``'s own mapping holds besides its fields (``name``); None when not known."""
    if not parent:
        return [*also, *root.model_fields]
    models = _models(_locate(root, parent)[1])
    return list(models[0].model_fields) if len(models) == 1 else None


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _from_validation(err: ValidationError, prefix: str, root: type[BaseModel],
                     also: tuple[str, ...] = ()) -> ConfigError:
    """One ConfigError line from pydantic's first error in validating ``root`` (at ``prefix``
    of the file, whose mapping holds the keys ``also`` besides): path, value, what is allowed."""
    errors = err.errors(include_url=False)
    # An unknown key beside a missing required one is the likelier mistake (a misspelling)
    e, missing = _unknown_beside_missing(errors) or (_mapping_branch(errors), [])
    loc = tuple(e["loc"])
    keys, at = _locate(root, loc)
    path = _path(prefix, keys)
    if e["type"] == "extra_forbidden":
        key = str(loc[-1])
        allowed_keys = _keys_allowed(root, loc[:-1], also) or []
        close = difflib.get_close_matches(key, missing, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else did_you_mean(key, allowed_keys)
        absent = f"; required key missing: {', '.join(missing)}" if missing and not close else ""
        allowed = f"; allowed keys: {', '.join(allowed_keys)}" if allowed_keys else ""
        return ConfigError(f"{path}: unknown key{hint}{absent}{allowed}", field=path)
    if e["type"] == "missing":
        return ConfigError(f"{path}: required field is missing", field=path)
    if e["type"] in ("union_tag_invalid", "union_tag_not_found"):
        tag = e.get("input", {}).get("dist") if isinstance(e.get("input"), dict) else None
        hint = did_you_mean(tag, list(DISTRIBUTIONS)) if isinstance(tag, str) else ""
        got = f"got {tag!r}" if tag is not None else "missing"
        return ConfigError(
            f"{path}.dist: unknown distribution ({got}){hint}; allowed: "
            f"{', '.join(DISTRIBUTIONS)}", field=f"{path}.dist")
    msg = e["msg"].replace("Value error, ", "")
    if e["type"] == "literal_error" and isinstance(e.get("input"), str):
        # pydantic's own list of the allowed values ("'scalar' or 'series'"), as the type
        # is not always found through a validator-wrapped model's branch label
        choices = re.findall(r"'([^']*)'", str(e.get("ctx", {}).get("expected", "")))
        return ConfigError(f"{path}: unknown value {e['input']!r}"
                           f"{did_you_mean(e['input'], choices)}; allowed: {', '.join(choices)}",
                           field=path)
    if e["type"] == "value_error" and (_models(at) or isinstance(e.get("input"), dict)):
        # A check across several fields, or of a mapping's entries (an FMU's inputs): its
        # message names the values itself.
        return ConfigError(f"{path}: {msg}", field=path)
    return ConfigError(f"{path}: {msg} (got {_short(e.get('input'))})", field=path)


def _mapping_branch(errors: list[Any]) -> Any:
    """The error to report: pydantic's first, unless that is a union's plain-type branch
    refusing a mapping (``str | CallableOutput`` given ``{kind: serie}``), whose "Input should
    be a valid string" hides what is wrong in the mapping: then the mapping branch's error."""
    first = errors[0]
    if not (first["type"].endswith("_type") and isinstance(first.get("input"), dict)):
        return first
    stem = tuple(first["loc"][:-1])
    return next((x for x in errors[1:] if tuple(x["loc"][:len(stem)]) == stem
                 and len(x["loc"]) > len(stem) + 1), first)


def _unknown_beside_missing(errors: list[Any]) -> tuple[Any, list[str]] | None:
    """The first unknown-key error with required keys missing beside it, and their names."""
    for x in errors:
        if x["type"] != "extra_forbidden":
            continue
        parent = tuple(x["loc"][:-1])
        missing = [str(m["loc"][-1]) for m in errors
                   if m["type"] == "missing" and tuple(m["loc"][:-1]) == parent]
        if missing:
            return x, missing
    return None


def load_yaml(path: str | Path) -> dict[str, Any]:
    """Read a YAML config file into its top-level mapping, not yet validated; ConfigError on I/O
    or syntax problems, and on what :mod:`uqguide.core.safe_yaml` refuses (aliases, duplicate
    keys, deep nesting, a file over 1 MB)."""
    from ..core.safe_yaml import MAX_BYTES, safe_load

    p = Path(path)
    try:
        size = p.stat().st_size
        if p.exists() and not p.is_file() and not p.is_dir():  # a FIFO's read would block
            raise ConfigError(f"{p}: config file is not a regular file (a FIFO or a device)")
        if size > MAX_BYTES:
            raise ConfigError(f"{p}: config file is {size} bytes; allowed at most {MAX_BYTES} "
                              f"(a config is a few kB: is this the right file?)")
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: config file not found") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a folder, not a config file") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{p}: cannot read config file ({exc})") from None
    try:
        data = safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise ConfigError(f"{p}: invalid YAML{where}: {problem}") from None
    if not isinstance(data, dict):
        raise ConfigError(
            f"{p}: the config must be a mapping with keys model, inputs, methods, ...; "
            f"got {type(data).__name__}")
    return data


def load_config(path: str | Path) -> RunConfig:
    """Read and validate a config file, or the shipped study of that name (``ftcapn_table3``;
    see :mod:`uqguide.config.catalog`); ConfigError naming the field, the value and what is
    allowed when it is invalid."""
    from .catalog import resolve

    path = resolve(path)
    return validate_config(load_yaml(path), str(path))


def validate_config(data: Mapping[str, Any], source: str = "<dict>") -> RunConfig:
    """Validate a config mapping into a :class:`RunConfig` (model, inputs, methods resolved);
    ConfigError naming the field, the value and what is allowed when it is invalid.

    ``source``: a file's path (its folder is where a callable model's module is looked for
    first) or ``"<dict>"``.
    """
    # A NaN is never a meaningful setting (YAML spells it .nan); a NUL ends a C string.
    for bad, rule in ((lambda v: isinstance(v, float) and v != v, "must be a number, not NaN"),
                      (lambda v: isinstance(v, str) and "\x00" in v,
                       "must not contain a NUL character")):
        at = _first_path(data, bad)
        if at is not None:
            raise ConfigError(f"{at[0]}: {rule}", field=at[0])
    try:
        raw = RawConfig.model_validate(dict(data))
    except ValidationError as err:
        raise _from_validation(err, "", RawConfig) from None

    config_dir = str(Path(source).parent) if source != "<dict>" else None
    if (raw.model is None) == (raw.data is None):
        both = raw.model is not None
        raise ConfigError(("data: give either model: (a simulator to run) or data: (a file of "
                           "runs already made), not both") if both else
                          "model: required field is missing (or give data: a file of runs "
                          "already made)", field="data" if both else "model")
    _check_finite_parameters(raw)
    rows = stored_data = None
    entries = raw.methods
    model: Model
    if raw.data is not None:
        from .data_source import load_source, method_entries

        space = _build_space(raw, None)
        found = load_source(raw.data, space, raw.outputs, config_dir,
                            memory_limit(raw.max_memory))
        model, outputs, rows, stored_data = found.model, found.outputs, found.rows, found.spec
        entries = method_entries(raw.methods, rows.x.shape[0], rows.source)
    else:
        assert raw.model is not None
        model = _build_model(raw.model, config_dir)
        space = _build_space(raw, model)
        outputs = _resolve_outputs(raw, model)
    _check_quantiles(raw)
    _check_events(raw, model, outputs)
    methods = _build_methods(entries,
                             replace(_run_context(raw, model, outputs, space), rows=rows))
    if rows is not None:
        from .data_source import check_rows_enough

        check_rows_enough(methods, rows, space.dim)
    for i, m in enumerate(methods):
        m.check(i)
        m.check_model(model, i)  # (a multi-fidelity method's levels are the model's)
    labels = [m.label for m in methods]
    for i, lab in enumerate(labels):
        if labels.index(lab) != i:
            raise ConfigError(
                f"methods[{i}].label: {lab!r} is used twice; give each method a unique label",
                field=f"methods[{i}].label")
    for i, m in enumerate(methods):
        m.check_order(methods, i)  # (a surrogate level names a PCE method listed before it)
    if raw.reference is not None and raw.reference not in labels:
        raise ConfigError(
            f"reference: {raw.reference!r} is not a method label"
            f"{did_you_mean(raw.reference, labels)}; allowed: {', '.join(labels)}",
            field="reference")
    if raw.report_times is not None:
        for i, t in enumerate(raw.report_times):
            if not np.isfinite(t) or t < 0:
                raise ConfigError(
                    f"report_times[{i}]: must be a finite time >= 0 s (got {t!r})",
                    field=f"report_times[{i}]")
    cfg = RunConfig(model=model, space=space, outputs=outputs, methods=methods, raw=raw,
                    source=source, data=stored_data)
    check_steps(model, raw.max_steps)
    for i, m in enumerate(methods):
        try:
            m.plan(space)
        except ConfigError as exc:  # a grid too large to build, refused before it is built
            if (exc.field or "").split(".")[0] in ("groups", "correlations"):
                raise  # a top-level setting the method cannot serve: named as it is written
            raise ConfigError(f"methods[{i}].{exc}", field=f"methods[{i}].{exc.field}") from None
    if raw.report_times:  # last: it may probe the model's grid with a run
        check_report_times(raw.report_times, model_time_grid(model, outputs))
    return cfg


def stored_context(data: Mapping[str, Any]) -> tuple[InputSpace, dict[str, Any]]:
    """The input space and the model's derived outputs of a stored (resolved) config, what a
    surrogate read from a result file is rebuilt with, without validating a run of it. No
    derived outputs for a fit to a data file, which needs its inputs only, not the file (moved
    or gone since, perhaps)."""
    section = data.get("model")
    if data.get("data") is not None or not isinstance(section, Mapping):
        return stored_input_space(data), {}
    if model_class(section.get("name"), "model.name").named_code(section):
        # a callable, program or FMU: building it would import or check code a result file
        # names (only `replay --run-code` runs that); such models derive no outputs
        return stored_input_space(data), {}
    # config_dir "." as for any config not read from a file (a callable model's module)
    model = _build_model(dict(section), ".")
    return _build_space(_stored_inputs(data), model), dict(model.derived_outputs())


def stored_input_space(data: Mapping[str, Any]) -> InputSpace:
    """The input space of a config mapping alone: its ``inputs`` and ``correlations``,
    without building its model or reading its data (a stored config whose data file is not at
    hand); ConfigError when the inputs are invalid."""
    return _build_space(_stored_inputs(data), None)


def _stored_inputs(data: Mapping[str, Any]) -> RawConfig:
    """A config of ``data``'s ``inputs`` and ``correlations`` alone."""
    try:
        return RawConfig.model_validate({k: v for k, v in data.items()
                                         if k in ("inputs", "correlations")} | {"methods": [{}]})
    except ValidationError as err:
        raise _from_validation(err, "", RawConfig) from None


def _check_quantiles(raw: RawConfig) -> None:
    if isinstance(raw.quantiles, str) and raw.quantiles != "3sigma":
        raise ConfigError(f"quantiles: give a list of levels in (0, 1) or 3sigma (got "
                          f"{raw.quantiles!r})", field="quantiles")
    if isinstance(raw.quantiles, list):
        if not raw.quantiles:
            raise ConfigError("quantiles: give at least one level, or 3sigma (got [])",
                              field="quantiles")
        for i, p in enumerate(raw.quantiles):
            if not 0.0 < p < 1.0:
                raise ConfigError(f"quantiles[{i}]: must be a probability strictly between 0 "
                                  f"and 1 (got {p!r})", field=f"quantiles[{i}]")


def _check_events(raw: RawConfig, model: Model, outputs: tuple[str, ...]) -> None:
    _check_event_specs("events", raw.events, model, outputs)
    _check_event_specs("requirements", raw.requirements, model, outputs)
    names = {e.name for e in raw.events}
    for i, r in enumerate(raw.requirements):
        if r.name in names:
            raise ConfigError(f"requirements[{i}].name: {r.name!r} is also an event's name; a "
                              f"requirement is counted as the event of its name, give it "
                              f"another", field=f"requirements[{i}].name")


def _check_event_specs(key: str, entries: Sequence[EventSpec | RequirementSpec], model: Model,
                       outputs: tuple[str, ...]) -> None:
    """The ``key`` list's names unique, each on a scalar output's component, thresholds
    finite."""
    seen: set[str] = set()
    for i, e in enumerate(entries):
        at = f"{key}[{i}]"
        if e.name in seen:
            raise ConfigError(f"{at}.name: {e.name!r} is used twice; give each "
                              f"{key[:-1]} a unique name", field=f"{at}.name")
        seen.add(e.name)
        if e.output not in outputs:
            raise ConfigError(
                f"{at}.output: {e.output!r} is not among the config's outputs"
                f"{did_you_mean(e.output, list(outputs))}; allowed: {', '.join(outputs)}",
                field=f"{at}.output")
        info = model.output_info(e.output)
        time = getattr(e, "time", None)
        if info.kind != "scalar" and time is None:
            what = ("an event is defined on a scalar output" if key == "events" else
                    "give a requirement on it a time: (its value at the nearest step)")
            raise ConfigError(f"{at}.output: {e.output!r} is a time series; {what}",
                              field=f"{at}.output")
        if time is not None:
            _check_requirement_time(f"{at}.time", time, e.output, info.kind,
                                    model_time_grid(model, (e.output,)))
        spec = e if isinstance(e, EventSpec) else e.event()
        try:
            component_index(spec, tuple(info.components))
        except ValueError as exc:
            raise ConfigError(f"{at}.component: {exc}", field=f"{at}.component") from None
        thr = spec.threshold()
        if not np.isfinite(thr):
            raise ConfigError(f"{at}: the threshold must be finite (got {thr!r})", field=at)


def _check_requirement_time(where: str, time: float, output: str, kind: str,
                            grid: np.ndarray) -> None:
    """ConfigError naming ``where`` for a time on a scalar output or outside the series' time
    grid (more than half a step beyond either end, as report times)."""
    if kind == "scalar":
        raise ConfigError(f"{where}: {time:g} s on {output!r}, a scalar output; time: is "
                          f"allowed on a time series output only, remove it", field=where)
    if not np.isfinite(time):
        raise ConfigError(f"{where}: must be a finite time (got {time!r})", field=where)
    if (span := outside_grid(time, grid)) is not None:
        lo, hi = span
        raise ConfigError(f"{where}: {time:g} s is outside the time grid of {output!r} "
                          f"[{lo:g}, {hi:g}] s; give a time within it", field=where)


def _first_path(node: Any, bad: Callable[[Any], bool], path: str = "") -> tuple[str, Any] | None:
    """Path (printable) and value of the first value or key of the config for which ``bad``
    holds (depth first, a key before its value)."""
    if bad(node):
        return _printable(path or "<top>"), node
    if isinstance(node, Mapping):
        for k, v in node.items():
            sub = f"{path}.{k}" if path else str(k)
            found = (_printable(sub), k) if bad(k) else _first_path(v, bad, sub)
            if found:
                return found
    elif isinstance(node, (list, tuple)):
        for i, v in enumerate(node):
            found = _first_path(v, bad, f"{path}[{i}]")
            if found:
                return found
    return None


def _printable(text: str) -> str:
    """``text`` with control characters escaped (a message stays one line)."""
    return text if text.isprintable() else repr(text)[1:-1]


def _check_finite_parameters(raw: RawConfig) -> None:
    """Distribution parameters must be finite; a truncated normal's bounds may be infinite
    (one-sided truncation)."""
    for i, m in enumerate(raw.inputs):
        for name, value in m.model_dump().items():
            if not isinstance(value, float) or np.isfinite(value):
                continue
            if m.dist == "truncnormal" and name in ("low", "high"):
                continue
            raise ConfigError(f"inputs[{i}].{name}: must be a finite number (got {value!r})",
                              field=f"inputs[{i}].{name}")


def _build_model(section: dict[str, Any], config_dir: str | None = None) -> Model:
    if "name" not in section:
        raise ConfigError("model.name: required field is missing", field="model.name")
    cls = model_class(section["name"], "model.name")
    params = {k: v for k, v in section.items() if k not in ("name", "isolate")}
    isolate = section.get("isolate")
    if isolate is not None and not isinstance(isolate, bool):
        raise ConfigError(f"model.isolate: must be true or false (got {_short(isolate)})",
                          field="model.isolate")
    try:
        # config_dir: where a callable model's module is looked for first
        validated = cls.Params.model_validate(params, context={"config_dir": config_dir})
    except ValidationError as err:
        raise _from_validation(err, "model", cls.Params, ("name", "isolate")) from None
    # no model takes an infinite number
    bad = _first_path(validated.model_dump(),
                      lambda v: isinstance(v, float) and not np.isfinite(v), "model")
    if bad is not None:
        raise ConfigError(f"{bad[0]}: must be a finite number (got {bad[1]!r})", field=bad[0])
    return cls(validated)


def _build_space(raw: RawConfig, model: Model | None) -> InputSpace:
    """The config's input space; each input must be one ``model`` accepts (any plain name
    with ``data:``, whose columns are checked against the file)."""
    accepted = list(model.input_names()) if model is not None else None
    seen: dict[str, int] = {}
    for i, m in enumerate(raw.inputs):
        if model is None:
            if not is_plain_name(m.name):
                raise ConfigError(f"inputs[{i}].name: {m.name!r} must be {PLAIN_NAME_RULE}",
                                  field=f"inputs[{i}].name")
        elif accepted is not None and m.name not in accepted:
            where = ""
            if model.declares_inputs:
                names = ", ".join(n.name for n in raw.inputs)
                where = (f" (model.inputs, {', '.join(accepted)} unless set, declares them "
                         f"in column order: for this config, model.inputs: [{names}])")
            raise ConfigError(
                f"inputs[{i}].name: model '{model.name}' has no input {m.name!r}"
                f"{did_you_mean(m.name, accepted)}; allowed: {', '.join(accepted)}{where}",
                field=f"inputs[{i}].name")
        if m.name in seen:
            raise ConfigError(
                f"inputs[{i}].name: {m.name!r} is already inputs[{seen[m.name]}]",
                field=f"inputs[{i}].name")
        seen[m.name] = i
    groups = []
    for g, spec in enumerate(raw.correlations):
        idx = []
        for j, name in enumerate(spec.inputs):
            if name not in seen:
                raise ConfigError(
                    f"correlations[{g}].inputs[{j}]: {name!r} is not an uncertain input of this "
                    f"config", field=f"correlations[{g}].inputs[{j}]")
            if not isinstance(raw.inputs[seen[name]], Normal):
                raise ConfigError(
                    f"correlations[{g}].inputs[{j}]: {name!r} must be a normal input to be "
                    f"correlated (got {raw.inputs[seen[name]].dist})",
                    field=f"correlations[{g}].inputs[{j}]")
            idx.append(seen[name])
        k = len(idx)
        field = f"correlations[{g}].matrix"
        lengths = [len(row) for row in spec.matrix]
        if len(lengths) != k or any(n != k for n in lengths):
            raise ConfigError(f"{field}: must be {k}x{k} (got {len(lengths)} rows of lengths "
                              f"{lengths[:8]})", field=field)
        C = np.asarray(spec.matrix, dtype=float)
        if not np.isfinite(C).all():
            raise ConfigError(f"{field}: entries must be finite numbers", field=field)
        if not np.allclose(C, C.T) or not np.allclose(np.diag(C), 1.0):
            raise ConfigError(f"{field}: must be symmetric with a unit diagonal", field=field)
        if np.linalg.eigvalsh(C).min() <= 0:
            raise ConfigError(f"{field}: must be positive definite", field=field)
        if sorted(idx) != list(range(min(idx), min(idx) + k)) or idx != sorted(idx):
            raise ConfigError(
                f"correlations[{g}].inputs: correlated inputs must be consecutive in the inputs "
                f"list and in the same order (got {spec.inputs})",
                field=f"correlations[{g}].inputs")
        groups.append(CorrelatedGroup(tuple(idx), C))
    return InputSpace(raw.inputs, groups)


def _resolve_outputs(raw: RawConfig, model: Model) -> tuple[str, ...]:
    if raw.outputs is None:
        return model.default_outputs()
    names = [o.name for o in model.outputs()]
    for i, name in enumerate(raw.outputs):
        if name not in names:
            raise ConfigError(
                f"outputs[{i}]: model '{model.name}' has no output {name!r}"
                f"{did_you_mean(name, names)}; allowed: {', '.join(names)}",
                field=f"outputs[{i}]")
    return tuple(dict.fromkeys(raw.outputs))


def _resolve_groups(raw: RawConfig, space: InputSpace) -> tuple[tuple[str, tuple[int, ...]], ...]:
    """The groups of inputs with an index of their own: the config's, else each correlated
    group (named ``dx+dy+dz``)."""
    names = list(space.names)
    if raw.groups is None:
        return tuple(("+".join(names[i] for i in g.index), tuple(g.index))
                     for g in space.groups)
    out = []
    for gname, members in raw.groups.items():
        field = f"groups.{gname}"
        if not re.fullmatch(r"[A-Za-z_][A-Za-z0-9_.+-]*", gname):
            raise ConfigError(f"groups: group name {gname!r} must start with a letter or _ and "
                              f"hold letters, digits, _ . + - only", field="groups")
        if not members:
            raise ConfigError(f"{field}: a group needs at least one input (got [])", field=field)
        idx = []
        for j, name in enumerate(members):
            if name not in names:
                raise ConfigError(f"{field}[{j}]: {name!r} is not an uncertain input of this "
                                  f"config{did_you_mean(name, names)}; allowed: "
                                  f"{', '.join(names)}", field=f"{field}[{j}]")
            if names.index(name) in idx:
                raise ConfigError(f"{field}[{j}]: {name!r} is listed twice", field=f"{field}[{j}]")
            idx.append(names.index(name))
        out.append((gname, tuple(idx)))
    return tuple(out)


def _run_context(raw: RawConfig, model: Model, outputs: tuple[str, ...],
                 space: InputSpace) -> RunContext:
    """What every method of the config is told about the run (:class:`RunContext`)."""
    return RunContext(
        groups=_resolve_groups(raw, space),
        report_times=tuple(raw.report_times) if raw.report_times else None,
        failure_policy=raw.pce_failure_policy,
        quantile_levels=resolve_levels(raw.quantiles),
        # (a requirement at a time is counted by the methods that keep series values per run)
        events=tuple(raw.events) + tuple(r.event() for r in raw.requirements
                                         if r.time is None),
        requirements=tuple(raw.requirements),
        components=MappingProxyType({o: tuple(model.output_info(o).components)
                                     for o in outputs}),
        outputs=outputs,
        derived=MappingProxyType({k: d for k, d in model.derived_outputs().items()
                                  if k in outputs}),
    )


def _build_methods(entries: list[dict[str, Any]], context: RunContext) -> list[Method]:
    methods = []
    for i, entry in enumerate(entries):
        if "name" not in entry:
            raise ConfigError(f"methods[{i}].name: required field is missing",
                              field=f"methods[{i}].name")
        cls = method_class(entry["name"], f"methods[{i}].name")
        settings = {k: v for k, v in entry.items() if k != "name"}
        try:
            method = cls(cls.Settings.model_validate(settings), context)
        except ValidationError as err:
            raise _from_validation(err, f"methods[{i}]", cls.Settings, ("name",)) from None
        methods.append(method)
    return methods

