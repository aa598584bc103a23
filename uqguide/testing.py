"""Conformance checks: every model and method against its contract, one named check a rule.

As scikit-learn's ``check_estimator`` and ``parametrize_with_checks`` do for estimators:
:func:`model_checks` and :func:`method_checks` yield ``(rule, check)`` pairs,
:func:`parametrize_with_checks` makes each its own pytest case (a plugin's suite shows each
broken rule as its own failure), and :func:`check_model` / :func:`check_method` run them all and
raise :class:`ConformanceError` naming the first broken rule. A class states how it is checked
cheaply through :attr:`Model.example_params` and :attr:`Method.example_settings`.

The rules, and why each holds: docs/architecture.md, "Checking the contracts".
"""

from __future__ import annotations

import functools
import random
import tempfile
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from types import MappingProxyType
from typing import Any

import numpy as np
from pydantic import ValidationError

from .driver.run_folder import RunStore, run_identity
from .config.run_config import validate_config
from .errors import ModelError
from .driver.execution import ChunkJob, ChunkResult, Executor, ProcessExecutor, SerialExecutor, Task
from .core.types import Estimate, GeneratedRows, ModelOutput
from .methods.base import GivenRows, Method, RunContext
from .models.base import Model
from .models.benchmarks import LinearGaussian
from .driver.propagate import propagate
from .results.result import MethodRun

__all__ = ["ConformanceError", "check_method", "check_model", "method_checks", "model_checks",
           "parametrize_with_checks"]


class ConformanceError(AssertionError):
    """A model or method breaks its contract; the message names the class and the rule."""


def _fail(who: str, rule: str, detail: str) -> ConformanceError:
    return ConformanceError(f"{who}: {rule}: {detail}")


# ---------------------------------------------------------------------------- models
def model_checks(cls: type[Model], params: Mapping[str, Any] | None = None, *, n: int = 6,
                 seed: int = 0) -> Iterator[tuple[str, Callable[[], None]]]:
    """The model contract's checks of ``cls``, one ``(rule, check)`` pair a rule.

    ``params``: to build it with (default ``cls.example_params``); ``n``: samples of the batch
    checked (at least 2, so that it can be split); ``seed``: of the inputs drawn around the
    nominal values. Each check takes no argument and raises :class:`ConformanceError` naming
    the model, the rule and what was seen.
    """
    params = dict(cls.example_params if params is None else params)
    who = f"model '{getattr(cls, 'name', cls.__name__)}'"

    @functools.cache
    def batch() -> tuple[Model, np.ndarray, list[str], list[str]]:
        model = cls(params)
        return (model, _inputs_near_nominal(model, n, seed), list(model.input_names()),
                [o.name for o in model.outputs()])

    def metadata() -> None:
        _check_metadata(batch()[0], who)

    def parameters() -> None:
        _check_nonfinite_params(cls, params, who)

    def shapes() -> None:
        model, x, names, outputs = batch()
        _check_output(model, _evaluate(model, x, names, outputs, who), n, who)

    def determinism() -> None:
        model, x, names, outputs = batch()
        out = _evaluate(model, x, names, outputs, who)
        np.random.seed(seed + 1)
        random.seed(seed + 1)
        again = _evaluate(model, x, names, outputs, who)
        np.random.seed(seed + 2)
        random.seed(seed + 2)
        _same_bits(again, _evaluate(model, x, names, outputs, who), who, "determinism",
                   "the global random state changed the outputs")
        _same_bits(out, again, who, "determinism", "a second evaluation of the same batch")

    def batch_split() -> None:
        model, x, names, outputs = batch()
        out = _evaluate(model, x, names, outputs, who)
        for half in (slice(0, n // 2), slice(n // 2, n)):
            part = _evaluate(model, x[half], names, outputs, who)
            _same_bits(out.subset(np.arange(n)[half]), part, who, "batch-split invariance",
                       f"samples {half.start}..{half.stop - 1} evaluated apart")

    yield from (("metadata", metadata), ("parameters", parameters), ("shapes", shapes),
                ("determinism", determinism), ("batch-split invariance", batch_split))


def check_model(cls: type[Model], params: Mapping[str, Any] | None = None, *, n: int = 6,
                seed: int = 0) -> None:
    """Run every check of :func:`model_checks`: ConformanceError at the first broken rule."""
    for _, check in model_checks(cls, params, n=n, seed=seed):
        check()


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


# ---------------------------------------------------------------------------- methods
#: The benchmark of the method checks: y = A x (2 components) with x ~ N(mean, diag(std^2)).
_MEANS = (0.5, -1.0, 0.25)
_STDS = (1.0, 0.5, 2.0)
#: The event: y1 above 2.5 of its standard deviations over its mean.
_TAIL_SIGMAS = 2.5


@dataclass
class _Bench:
    """The method checked on the benchmark, with its exact values; ``who`` names the method in
    messages."""

    method: Method
    context: RunContext
    model: LinearGaussian
    space: Any
    outputs: tuple[str, ...]
    seed: int
    who: str
    mean: np.ndarray
    sd: np.ndarray
    p_tail: float

    def run(self, executor: Executor, method: Method | None = None, **kwargs: Any) -> MethodRun:
        return propagate(method or self.method, self.model, self.space, self.outputs, self.seed,
                         executor, **kwargs)

    @functools.cached_property
    def first(self) -> MethodRun:
        """The method's first run (in this process), which the checks share."""
        return self.run(SerialExecutor(16))


def _benchmark(cls: type[Method], settings: dict[str, Any], seed: int, who: str) -> _Bench:
    model = LinearGaussian()
    mean, cov = model.exact_mean_cov(np.array(_MEANS), np.diag(np.square(_STDS)))
    sd = np.sqrt(np.diag(cov))
    from scipy.stats import norm

    cfg = validate_config({
        "model": {"name": "linear_gaussian"},
        "inputs": [{"name": f"x{i + 1}", "dist": "normal", "mean": m, "std": s}
                   for i, (m, s) in enumerate(zip(_MEANS, _STDS))],
        "outputs": ["y", "ramp"],
        "events": [{"name": "tail", "output": "y", "component": "y1",
                    "above": float(mean[0] + _TAIL_SIGMAS * sd[0])}],
        "methods": [{"name": "monte_carlo", "n_samples": 10}],  # (replaced by the method checked)
    })
    context = RunContext(events=tuple(cfg.raw.events), components=MappingProxyType(
        {o: tuple(model.output_info(o).components) for o in cfg.outputs}))
    return _Bench(cls(settings, context), context, model, cfg.space, cfg.outputs, seed, who,
                  mean, sd, float(norm.sf(_TAIL_SIGMAS)))


def method_checks(cls: type[Method], settings: Mapping[str, Any] | None = None, *,
                  seed: int = 5, workers: bool = True
                  ) -> Iterator[tuple[str, Callable[[], None]]]:
    """The method contract's checks of ``cls``, one ``(rule, check)`` pair a rule.

    ``settings`` default to ``cls.example_settings``; ``seed``: root seed of the runs;
    ``workers``: also check a 2-process pool (its start takes seconds). The checks share the
    method's first run on the benchmark; each raises as :func:`model_checks`'s do.
    """
    settings = dict(cls.example_settings if settings is None else settings)
    who = f"method '{getattr(cls, 'name', cls.__name__)}'"

    @functools.cache
    def bench() -> _Bench:
        return _benchmark(cls, settings, seed, who)

    def seeds() -> None:
        b = bench()
        _same_runs(b.first, b.run(SerialExecutor(16)), who, "seeds",
                   "the same seed gave other numbers")
        if cls.random_design:
            x0 = np.asarray(b.method.design(b.space, seed).x)
            x1 = np.asarray(b.method.design(b.space, seed + 1).x)
            if x0.shape == x1.shape and np.array_equal(x0, x1):
                raise _fail(who, "seeds", f"seeds {seed} and {seed + 1} give the same design; "
                            f"a method with a random design must derive it from the seed (or "
                            f"declare random_design = False)")

    def batch_size() -> None:
        b = bench()
        _same_runs(b.first, b.run(SerialExecutor(5)), who, "batch size",
                   "another batch size gave other numbers")

    def pool() -> None:
        b, executor = bench(), ProcessExecutor(2, batch_size=16)
        try:
            _same_runs(b.first, b.run(executor), who, "workers",
                       "a 2-process pool gave other numbers than this process")
        finally:
            executor.close()

    yield "closed forms", lambda: _check_closed_forms(bench().first, bench())
    yield from (("seeds", seeds), ("batch size", batch_size))
    if workers:
        yield "workers", pool
    if not cls.holds_runs:
        yield "streaming", lambda: _check_streaming(bench())
    yield "resume", lambda: _check_resume(bench())
    if not cls.own_design:
        yield "given rows", lambda: _check_given_rows(bench(), cls, settings)


def check_method(cls: type[Method], settings: Mapping[str, Any] | None = None, *,
                 seed: int = 5, workers: bool = True) -> None:
    """Run every check of :func:`method_checks`: ConformanceError at the first broken rule."""
    for _, check in method_checks(cls, settings, seed=seed, workers=workers):
        check()


def parametrize_with_checks(models: Sequence[type[Model] | tuple[type[Model], Mapping[str, Any]]]
                            = (), methods: Sequence[type[Method]] = (), *,
                            workers: bool = False) -> Any:
    """A ``pytest.mark.parametrize`` of every check of ``models`` and ``methods``.

    Each check is its own test case, with the id ``<name>-<rule>``; the decorated test takes
    one argument, ``check``, and calls it::

        @parametrize_with_checks(models=[MyModel])
        def test_contract(check):
            check()

    ``models``: classes or ``(class, params)`` pairs; ``methods``: classes (with their
    ``example_settings``); ``workers``: include the 2-process pool check (seconds a method).
    """
    import pytest

    named: list[tuple[type, Iterator[tuple[str, Callable[[], None]]]]] = []
    for entry in models:
        cls, params = entry if isinstance(entry, tuple) else (entry, None)
        named.append((cls, model_checks(cls, params)))
    named += [(mcls, method_checks(mcls, workers=workers)) for mcls in methods]
    cases = [(f"{getattr(c, 'name', c.__name__)}-{rule}", check)
             for c, checks in named for rule, check in checks]
    return pytest.mark.parametrize("check", [c for _, c in cases], ids=[i for i, _ in cases])


def _check_given_rows(b: _Bench, cls: type[Method], settings: Mapping[str, Any]) -> None:
    """The method on the rows of its own first run, given as a data file's."""
    x = np.asarray(b.first.x, dtype=float)
    rows = GivenRows(x, "<conformance>", np.zeros(x.shape[0], dtype=bool))
    given = cls(dict(settings), replace(b.context, rows=rows))
    design = np.asarray(given.design(b.space, b.seed).x, dtype=float)
    if design.shape != x.shape or not np.array_equal(np.unique(design, axis=0),
                                                     np.unique(x, axis=0)):
        raise _fail(b.who, "given rows", f"its design of {x.shape[0]} given rows has shape "
                    f"{design.shape} and other rows; with data: the design is the rows, each "
                    f"once")
    run = b.run(SerialExecutor(16), given)
    if run.n_runs != x.shape[0]:
        raise _fail(b.who, "given rows", f"made {run.n_runs} runs of {x.shape[0]} given rows")
    _check_closed_forms(run, b)


def _check_closed_forms(run: MethodRun, b: _Bench) -> None:
    mean, sd, p_tail, who = b.mean, b.sd, b.p_tail, b.who
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


def _check_streaming(b: _Bench) -> None:
    design = b.method.design(b.space, b.seed)
    held = SerialExecutor(16).evaluate(b.model, np.asarray(design.x), b.space.names, b.outputs)
    try:
        estimate = b.method.estimate(b.space, design, held)
    except Exception as exc:  # noqa: BLE001 - whatever it is, the rule is broken
        raise _fail(b.who, "streaming", f"estimate of outputs in memory raised "
                    f"{type(exc).__name__}: {exc}") from None
    _same_estimates(b.first.estimate, estimate, b.who, "streaming",
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


def _check_resume(b: _Bench) -> None:
    identity = run_identity({"check": "resume", "method": b.method.name,
                             "settings": b.method.settings.model_dump(mode="json")}, b.model)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "run"
        store = RunStore.open(folder, identity, resume=False)
        try:
            b.run(_StopAfterFirstChunk(SerialExecutor(16)), store=store)
        except KeyboardInterrupt:
            pass
        finally:
            store.close()
        store = RunStore.open(folder, identity, resume=True)
        if store.n_done < 1:
            raise _fail(b.who, "resume", "no chunk was kept by the interrupted run")
        try:
            resumed = b.run(SerialExecutor(16), store=store)
        finally:
            store.close()
    _same_runs(b.first, resumed, b.who, "resume",
               "a run interrupted after its first chunk and resumed gave other numbers")
