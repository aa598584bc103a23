"""Conformance suites: every model and method checked against its contract, from the registry.

As scikit-learn's ``check_estimator`` does for estimators, :func:`check_model` and
:func:`check_method` take a class and raise :class:`ConformanceError` naming the first broken
rule, so a model or method added to :mod:`uqguide.config.registry` is covered by the parametrised
test ``tests/test_conformance.py`` with no test code of its own. A class states how it is checked
cheaply through :attr:`Model.example_params` (a short horizon) and
:attr:`Method.example_settings` (a small design).

Model contract (uq-methods.md section 1), checked on a small batch around the nominal inputs:

- metadata: unique input and output names, finite nominal values, output kinds and non-empty,
  unique component names, default outputs that exist;
- parameters: every float parameter refuses NaN and infinity (a validation error, not a run);
- shapes and dtypes: a float time grid ``(T,)`` non-decreasing, series ``(n, T, k)`` and
  scalars ``(n, k)`` of floats, a boolean failure mask ``(n,)`` with a non-empty reason exactly
  where a sample failed;
- batch-split invariance: the halves of a batch evaluated apart give the same bits (the
  executors rely on it: a chunk's numbers must not depend on where it ran);
- determinism: the same bits whatever the global random state (a model drawing noise must key
  it on its inputs);
- kernels: where the model has a ``kernel`` parameter, the NumPy reference and the compiled
  kernel agree to round-off (1e-6 of each output's scale).

Method contract, on the ``linear_gaussian`` benchmark (3 Gaussian inputs) whose statistics and
event probabilities are known in closed form:

- closed forms: a sampling estimate's mean lies within 4 of its standard errors, an interval
  estimate of the std within twice its 95% half-width, an event probability within twice its
  95% half-width; a surrogate without intervals (PCE: exact for this linear model) to 1e-8;
- seeds: the same seed gives the same bits; a method with a random design
  (:attr:`Method.random_design`) gives another design for another seed;
- workers: serial and a 2-process pool give the same bits;
- streaming: a method that holds no runs (:attr:`Method.holds_runs`, a
  :class:`~uqguide.methods.base.StreamingMethod`) gives from its ``estimate`` of outputs held
  in memory the bits of its chunks reduced where they ran and folded by the driver;
- resume: a run interrupted after its first chunk and resumed from its checkpoint gives the
  bits of an uninterrupted run;
- given rows: a method that takes a data file's rows as its design (an empty
  :attr:`Method.own_design`) runs exactly those rows, every one once, and its statistics of
  them pass the closed forms.
"""

from __future__ import annotations

import random
import tempfile
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from pydantic import ValidationError

from .driver.run_folder import RunStore, run_identity
from .config.run_config import validate_config
from .errors import ModelError
from .driver.execution import ChunkJob, ChunkResult, Executor, ProcessExecutor, SerialExecutor, Task
from .core.types import Estimate
from .methods.base import GivenRows, Method, RunContext
from .models.base import Model
from .models.benchmarks import LinearGaussian
from .driver.propagate import propagate
from .results.result import MethodRun
from .core.types import GeneratedRows, ModelOutput

__all__ = ["ConformanceError", "check_method", "check_model"]


class ConformanceError(AssertionError):
    """A model or method breaks its contract; the message names the class and the rule."""


def _fail(who: str, rule: str, detail: str) -> ConformanceError:
    return ConformanceError(f"{who}: {rule}: {detail}")


# ---------------------------------------------------------------------------- models
def check_model(cls: type[Model], params: Mapping[str, Any] | None = None, *, n: int = 6,
                seed: int = 0) -> None:
    """Check the model class ``cls`` against the model contract (module docstring).

    Parameters
    ----------
    cls : subclass of Model
    params : mapping, optional
        Parameters to build it with (default: ``cls.example_params``).
    n : int
        Samples of the batch checked (at least 2, so that it can be split).
    seed : int
        Seed of the inputs drawn around the nominal values.

    Raises
    ------
    ConformanceError
        Naming the model, the rule and what was seen.
    """
    params = dict(cls.example_params if params is None else params)
    who = f"model '{getattr(cls, 'name', cls.__name__)}'"
    model = cls(params)
    _check_metadata(model, who)
    _check_nonfinite_params(cls, params, who)
    names = list(model.input_names())
    x = _inputs_near_nominal(model, n, seed)
    outputs = [o.name for o in model.outputs()]
    out = _evaluate(model, x, names, outputs, who)
    _check_output(model, out, n, who)
    np.random.seed(seed + 1)
    random.seed(seed + 1)
    again = _evaluate(model, x, names, outputs, who)
    np.random.seed(seed + 2)
    random.seed(seed + 2)
    _same_bits(again, _evaluate(model, x, names, outputs, who), who, "determinism",
               "the global random state changed the outputs")
    _same_bits(out, again, who, "determinism", "a second evaluation of the same batch")
    for half in (slice(0, n // 2), slice(n // 2, n)):
        part = _evaluate(model, x[half], names, outputs, who)
        _same_bits(out.subset(np.arange(n)[half]), part, who, "batch-split invariance",
                   f"samples {half.start}..{half.stop - 1} evaluated apart")
    fields = getattr(cls.Params, "model_fields", {})
    if "kernel" in fields:
        _check_kernels(cls, params, x, names, outputs, who)


def _check_metadata(model: Model, who: str) -> None:
    inputs = model.inputs()
    names = [i.name for i in inputs]
    if len(set(names)) != len(names):
        raise _fail(who, "metadata", f"input names are not unique: {names}")
    for i in inputs:
        if not np.isfinite(i.nominal):
            raise _fail(who, "metadata", f"input '{i.name}' has nominal {i.nominal!r}")
    outs = model.outputs()
    onames = [o.name for o in outs]
    if len(set(onames)) != len(onames):
        raise _fail(who, "metadata", f"output names are not unique: {onames}")
    for o in outs:
        if o.kind not in ("series", "scalar"):
            raise _fail(who, "metadata", f"output '{o.name}' has kind {o.kind!r}; allowed: "
                        f"series, scalar")
        if not o.components or len(set(o.components)) != len(o.components):
            raise _fail(who, "metadata", f"output '{o.name}' has components {o.components!r}; "
                        f"give one unique name per component")
        if "[" in o.name or "]" in o.name:
            raise _fail(who, "metadata", f"output '{o.name}': brackets are kept for component "
                        f"indices")
    for d in model.default_outputs():
        if d not in onames:
            raise _fail(who, "metadata", f"default output '{d}' is not an output")
    for name, derived in model.derived_outputs().items():
        missing = [c for c in derived.carriers if c not in onames]
        if name not in onames or missing:
            raise _fail(who, "metadata", f"derived output '{name}' needs carriers {missing} or "
                        f"is not an output")


def _float_fields(cls: type[Model]) -> list[str]:
    found = []
    for name, f in cls.Params.model_fields.items():
        ann = str(f.annotation)
        if "float" in ann and "list" not in ann and "dict" not in ann:
            found.append(name)
    return found


def _check_nonfinite_params(cls: type[Model], params: dict[str, Any], who: str) -> None:
    for name in _float_fields(cls):
        for bad in (float("nan"), float("inf")):
            try:
                cls.Params(**{**params, name: bad})
            except ValidationError:
                continue
            raise _fail(who, "parameters", f"'{name}' accepts {bad!r}; a float parameter "
                        f"must refuse NaN and infinity (pydantic: allow_inf_nan=False or a "
                        f"bound)")


def _inputs_near_nominal(model: Model, n: int, seed: int) -> np.ndarray:
    """Inputs within 2% of their nominal values (1e-3 absolute about a zero nominal)."""
    rng = np.random.default_rng(seed)
    nominal = np.array([i.nominal for i in model.inputs()], dtype=float)
    u = rng.uniform(-1.0, 1.0, size=(n, nominal.size))
    step = np.where(nominal != 0.0, 0.02 * np.abs(nominal), 1e-3)
    return nominal + u * step


def _evaluate(model: Model, x: np.ndarray, names: Sequence[str], outputs: Sequence[str],
              who: str) -> ModelOutput:
    try:
        return model.evaluate(x, names, outputs)
    except ModelError as exc:
        raise _fail(who, "shapes", str(exc)) from None


def _check_output(model: Model, out: ModelOutput, n: int, who: str) -> None:
    t = np.asarray(out.time)
    if t.ndim != 1 or t.dtype.kind != "f" or (t.size > 1 and np.any(np.diff(t) < 0)):
        raise _fail(who, "shapes", f"time must be a non-decreasing float grid (T,), got "
                    f"{t.dtype} of shape {t.shape}")
    for name, v in {**out.series, **out.scalars}.items():
        if np.asarray(v).dtype.kind != "f":
            raise _fail(who, "dtypes", f"output '{name}' is {np.asarray(v).dtype}, not float")
    if out.failed.dtype != bool:
        raise _fail(who, "failure mask", f"failed is {out.failed.dtype}, not bool")
    reasons = np.array([str(r) for r in out.reasons])
    if np.any((reasons == "") & out.failed) or np.any((reasons != "") & ~out.failed):
        raise _fail(who, "failure mask", "every failed sample needs a reason and only failed "
                    "samples have one")


def _same_bits(a: ModelOutput, b: ModelOutput, who: str, rule: str, what: str) -> None:
    pairs: list[tuple[str, np.ndarray, np.ndarray | None]] = [
        ("failed", a.failed, b.failed), ("time", a.time, b.time)]
    pairs += [(k, v, b.series.get(k)) for k, v in a.series.items()]
    pairs += [(k, v, b.scalars.get(k)) for k, v in a.scalars.items()]
    for name, u, v in pairs:
        if v is None or np.shape(u) != np.shape(v) or not np.array_equal(u, v, equal_nan=True):
            raise _fail(who, rule, f"'{name}' differs ({what})")


def _check_kernels(cls: type[Model], params: dict[str, Any], x: np.ndarray,
                   names: Sequence[str], outputs: Sequence[str], who: str) -> None:
    ref = cls({**params, "kernel": "numpy"}).evaluate(x, names, outputs)
    fast = cls({**params, "kernel": "numba"}).evaluate(x, names, outputs)
    if not np.array_equal(ref.failed, fast.failed):
        raise _fail(who, "kernels", "the NumPy and compiled kernels fail different samples")
    ok = ~ref.failed
    for name in ref.series.keys() | ref.scalars.keys():
        a = (ref.series[name] if name in ref.series else ref.scalars[name])[ok]
        b = (fast.series[name] if name in fast.series else fast.scalars[name])[ok]
        scale = float(np.nanmax(np.abs(a))) if a.size and np.isfinite(a).any() else 0.0
        err = np.abs(a - b)
        if a.size and not np.all((err <= 1e-6 * scale + 1e-12) | (np.isnan(a) & np.isnan(b))):
            raise _fail(who, "kernels", f"'{name}' differs by {np.nanmax(err):.3g} between the "
                        f"NumPy and compiled kernels (scale {scale:.3g}; allowed 1e-6 of it)")


# ---------------------------------------------------------------------------- methods
#: The benchmark of the method checks: y = A x (2 components) with x ~ N(mean, diag(std^2)).
_MEANS = (0.5, -1.0, 0.25)
_STDS = (1.0, 0.5, 2.0)
#: The event: y1 above 2.5 of its standard deviations over its mean.
_TAIL_SIGMAS = 2.5


def _benchmark() -> tuple[LinearGaussian, dict[str, Any], np.ndarray, np.ndarray, float, float]:
    model = LinearGaussian()
    mean, cov = model.exact_mean_cov(np.array(_MEANS), np.diag(np.square(_STDS)))
    sd = np.sqrt(np.diag(cov))
    threshold = float(mean[0] + _TAIL_SIGMAS * sd[0])
    from scipy.stats import norm

    p_tail = float(norm.sf(_TAIL_SIGMAS))
    cfg = {
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i + 1}", "dist": "normal", "mean": m, "std": s}
                   for i, (m, s) in enumerate(zip(_MEANS, _STDS))],
        "outputs": ["y", "ramp"],
        "events": [{"name": "tail", "output": "y", "component": "y1", "above": threshold}],
        "methods": [{"name": "monte_carlo", "n_samples": 10}],  # (replaced by the method checked)
    }
    return model, cfg, mean, sd, threshold, p_tail


def check_method(cls: type[Method], settings: Mapping[str, Any] | None = None, *,
                 seed: int = 5, workers: bool = True) -> None:
    """Check the method class ``cls`` against the method contract (module docstring).

    Parameters
    ----------
    cls : subclass of Method
    settings : mapping, optional
        Its settings (default: ``cls.example_settings``).
    seed : int
        Root seed of the runs.
    workers : bool
        Also run it in a 2-process pool (starting the pool takes seconds).

    Raises
    ------
    ConformanceError
        Naming the method, the rule and what was seen.
    """
    settings = dict(cls.example_settings if settings is None else settings)
    who = f"method '{getattr(cls, 'name', cls.__name__)}'"
    model, cfg_dict, mean, sd, _, p_tail = _benchmark()
    cfg = validate_config(cfg_dict)
    context = RunContext(events=tuple(cfg.raw.events), components=MappingProxyType(
        {o: tuple(model.output_info(o).components) for o in cfg.outputs}))
    method = cls(settings, context)
    space, outputs = cfg.space, cfg.outputs
    first = _run(method, model, space, outputs, seed, SerialExecutor(16))
    _check_closed_forms(first, mean, sd, p_tail, who)
    _same_runs(first, _run(method, model, space, outputs, seed, SerialExecutor(16)), who,
               "seeds", "the same seed gave other numbers")
    if cls.random_design:
        a = np.asarray(method.design(space, seed).x)
        b = np.asarray(method.design(space, seed + 1).x)
        if a.shape == b.shape and np.array_equal(a, b):
            raise _fail(who, "seeds", f"seeds {seed} and {seed + 1} give the same design; a "
                        f"method with a random design must derive it from the seed (or declare "
                        f"random_design = False)")
    _same_runs(first, _run(method, model, space, outputs, seed, SerialExecutor(5)), who,
               "batch size", "another batch size gave other numbers")
    if workers:
        pool = ProcessExecutor(2, batch_size=16)
        try:
            _same_runs(first, _run(method, model, space, outputs, seed, pool), who, "workers",
                       "a 2-process pool gave other numbers than this process")
        finally:
            pool.close()
    if not method.holds_runs:
        _check_streaming(method, model, space, outputs, seed, first, who)
    _check_resume(method, model, space, outputs, seed, first, who)
    if not cls.own_design:
        _check_given_rows(cls, settings, context, model, space, outputs, seed, first, who,
                          mean, sd, p_tail)


def _check_given_rows(cls: type[Method], settings: Mapping[str, Any], context: RunContext,
                      model: Model, space: Any, outputs: tuple[str, ...], seed: int,
                      first: MethodRun, who: str, mean: np.ndarray, sd: np.ndarray,
                      p_tail: float) -> None:
    """The method on the rows of its own first run, given as a data file's."""
    x = np.asarray(first.x, dtype=float)
    rows = GivenRows(x, "<conformance>", np.zeros(x.shape[0], dtype=bool))
    given = cls(dict(settings), replace(context, rows=rows))
    design = np.asarray(given.design(space, seed).x, dtype=float)
    if design.shape != x.shape or not np.array_equal(np.unique(design, axis=0),
                                                     np.unique(x, axis=0)):
        raise _fail(who, "given rows", f"its design of {x.shape[0]} given rows has shape "
                    f"{design.shape} and other rows; with data: the design is the rows, each "
                    f"once")
    run = _run(given, model, space, outputs, seed, SerialExecutor(16))
    if run.n_runs != x.shape[0]:
        raise _fail(who, "given rows", f"made {run.n_runs} runs of {x.shape[0]} given rows")
    _check_closed_forms(run, mean, sd, p_tail, who)


def _run(method: Method, model: Model, space: Any, outputs: tuple[str, ...], seed: int,
         executor: Executor, store: RunStore | None = None) -> MethodRun:
    return propagate(method, model, space, outputs, seed, executor, store=store)


def _check_closed_forms(run: MethodRun, mean: np.ndarray, sd: np.ndarray, p_tail: float,
                        who: str) -> None:
    if not run.success:
        raise _fail(who, "closed forms", f"no statistics on the linear benchmark: "
                    f"{run.message}")
    est = run.estimate
    s = est.stats.get("y")
    if s is not None:
        if s.sem is not None:
            err = np.abs(s.mean - mean)
            if np.any(err > 4 * s.sem):
                raise _fail(who, "closed forms", f"mean {s.mean} is more than 4 standard "
                            f"errors {s.sem} from the exact {mean}")
        elif np.any(np.abs(s.mean - mean) > 1e-8 * (1 + np.abs(mean))):
            raise _fail(who, "closed forms", f"mean {s.mean} differs from the exact {mean} "
                        f"(a surrogate without intervals must be exact for a linear model)")
        ci = s.ci.get("std")
        if ci is not None and np.all(np.isfinite(ci)):
            half = np.where(sd > s.std, ci[1] - s.std, s.std - ci[0])
            if np.any(np.abs(s.std - sd) > 2 * half):
                raise _fail(who, "closed forms", f"std {s.std} is beyond twice its 95% "
                            f"interval from the exact {sd}")
        elif s.sem is None and np.any(np.abs(s.std - sd) > 1e-8 * sd):
            raise _fail(who, "closed forms", f"std {s.std} differs from the exact {sd}")
    ev = est.events.get("tail")
    if ev is not None:
        lo, hi = ev.ci
        half = (hi - ev.probability) if p_tail > ev.probability else (ev.probability - lo)
        if abs(ev.probability - p_tail) > 2 * half:
            raise _fail(who, "closed forms", f"P(tail) {ev.probability:.4g} [{lo:.3g}, "
                        f"{hi:.3g}] is beyond twice its interval from the exact {p_tail:.4g}")
    if s is None and ev is None:
        raise _fail(who, "closed forms", "estimated neither the moments of 'y' nor the event")


def _same_runs(a: MethodRun, b: MethodRun, who: str, rule: str, what: str) -> None:
    if a.success != b.success or a.n_runs != b.n_runs:
        raise _fail(who, rule, f"{what} (runs {a.n_runs} vs {b.n_runs})")
    _same_estimates(a.estimate, b.estimate, who, rule, what)


def _same_estimates(a: Estimate, b: Estimate, who: str, rule: str, what: str) -> None:
    for name, s in a.stats.items():
        t = b.stats.get(name)
        for stat in ("mean", "std", "skewness", "kurtosis", "cov"):
            u, v = getattr(s, stat), None if t is None else getattr(t, stat)
            if v is None or not np.array_equal(u, v, equal_nan=True):
                raise _fail(who, rule, f"{what}: '{name}' {stat}")
    for name, e in a.events.items():
        f = b.events.get(name)
        if f is None or (e.probability != f.probability and not
                         (np.isnan(e.probability) and np.isnan(f.probability))):
            raise _fail(who, rule, f"{what}: event '{name}'")


def _check_streaming(method: Method, model: Model, space: Any,
                     outputs: tuple[str, ...], seed: int, streamed: MethodRun, who: str) -> None:
    design = method.design(space, seed)
    held = SerialExecutor(16).evaluate(model, np.asarray(design.x), space.names, outputs)
    try:
        estimate = method.estimate(space, design, held)
    except Exception as exc:  # noqa: BLE001 - whatever it is, the rule is broken
        raise _fail(who, "streaming", f"estimate of outputs in memory raised "
                    f"{type(exc).__name__}: {exc}") from None
    _same_estimates(streamed.estimate, estimate, who, "streaming",
                    "the estimate of outputs in memory differs from the streamed one")


class _StopAfterFirstChunk:
    """An executor that stops (as Ctrl-C would) once its first chunk is done."""

    def __init__(self, inner: Executor) -> None:
        self.inner, self.batch_size = inner, inner.batch_size
        self.shares_memory = inner.shares_memory

    def map_chunks(self, job: ChunkJob, tasks: Sequence[Task], x: np.ndarray | GeneratedRows
                   ) -> Iterator[ChunkResult]:
        for i, r in enumerate(self.inner.map_chunks(job, tasks, x)):
            yield r
            if i == 0:
                raise KeyboardInterrupt

    def abort(self) -> None:
        self.inner.abort()

    def close(self) -> None:
        self.inner.close()


def _check_resume(method: Method, model: Model, space: Any, outputs: tuple[str, ...],
                  seed: int, whole: MethodRun, who: str) -> None:
    identity = run_identity({"check": "resume", "method": method.name,
                             "settings": method.settings.model_dump(mode="json")}, model)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "run"
        store = RunStore.open(folder, identity, resume=False)
        try:
            _run(method, model, space, outputs, seed, _StopAfterFirstChunk(SerialExecutor(16)),
                 store)
        except KeyboardInterrupt:
            pass
        finally:
            store.close()
        store = RunStore.open(folder, identity, resume=True)
        if store.n_done < 1:
            raise _fail(who, "resume", "no chunk was kept by the interrupted run")
        try:
            resumed = _run(method, model, space, outputs, seed, SerialExecutor(16), store)
        finally:
            store.close()
    _same_runs(whole, resumed, who, "resume",
               "a run interrupted after its first chunk and resumed gave other numbers")
