"""The Result of a run and its HDF5 form.

:class:`Result` holds a run's statistics, diagnostics and provenance per method
(:class:`MethodRun`); :func:`write_hdf5` writes it as a result file of format :data:`FORMAT`
(netCDF-4 conventions, so xarray / h5netcdf read it with named dimensions; every array SI), laid
out by :func:`file_layout`, and :func:`read_hdf5` reads back every format in
:data:`READABLE_FORMATS`. A method's statistics are its Dataset
(:mod:`uqguide.results.dataset`); a PCE's surrogate is :mod:`uqguide.results.surrogate`'s. The file
is written to a temporary name in the same folder and renamed into place, so a file with the
final name is always complete.

The layout, the root group's index and format 1: docs/result-file.md.
"""

from __future__ import annotations

import datetime as _dt
import json
import platform
from dataclasses import dataclass, field
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import yaml

from ..core import atomic
from .._version import __version__
from ..errors import ResultError
from ..core.events import EventEstimate
from ..stats.verdicts import Verdict
from ..core.types import Estimate, GeneratedRows, OutputStats, ScalarIndex
from ..models.base import OutputInfo
from .surrogate import StoredSurrogate, read_surrogate, write_surrogate
from .dataset import (LABEL, frames, misshapen, read_stats, stack, stats_dataset,
                      tidy_frame_class, without_single_components)
from .netcdf_file import UTF8, Blocks, Dataset, Group, dataset_group, strings, write_group

FORMAT = 2
#: Format versions :func:`read_hdf5` reads.
READABLE_FORMATS = (1, 2)


@dataclass
class MethodRun:
    """One method's estimate with the runs behind it.

    ``x (n, d)``: inputs of every run (a Monte Carlo design is generated per chunk on demand:
    slice it, or ``np.asarray`` it); ``scalars``: ``(n, k)`` per output (NaN or garbage where
    ``failed``); ``model_seconds``: in the model, summed over chunks (worker-seconds), compiling
    excluded; ``fit_seconds``: outside the model (refinement fits and the estimate);
    ``wall_seconds``: the whole method, design included; ``success`` False: ``estimate`` holds
    no statistics and ``message`` says why (the runs made are still here); ``compile_seconds``:
    compiling the model's kernel during this method (0 from the cache, and in older files);
    ``verdicts``: on each of the config's requirements, by name.
    """

    estimate: Estimate
    x: np.ndarray | GeneratedRows
    scalars: dict[str, np.ndarray]
    failed: np.ndarray
    reasons: np.ndarray
    time: np.ndarray
    n_runs: int
    model_seconds: float
    fit_seconds: float
    wall_seconds: float
    success: bool = True
    message: str = ""
    compile_seconds: float = 0.0
    verdicts: dict[str, Verdict] = field(default_factory=dict)

    @property
    def label(self) -> str:
        return self.estimate.label

    @property
    def n_failed(self) -> int:
        return int(np.sum(self.failed))

    def __repr__(self) -> str:
        # the dataclass's repr prints every array (runs, statistics): a notebook cell that
        # ends in ``result.run("mc")`` should show what it is, not thousands of lines
        outcome = (f"statistics of {_names(list(self.estimate.stats))}" if self.success
                   else f"no statistics: {self.message}")
        return (f"MethodRun {self.label!r} ({self.estimate.method}): {self.n_runs:,} runs, "
                f"{self.n_failed:,} failed; {outcome}")


def _count(items: list[Any], word: str) -> str:
    return f"{len(items)} {word}{'s' * (len(items) != 1)}"


def _names(names: list[str], width: int = 70) -> str:
    """``names`` joined by commas, cut at about ``width`` characters."""
    text = ", ".join(names)
    if len(text) <= width:
        return text
    cut = text.rfind(", ", 0, width - 4)
    return (text[:cut] if cut > 0 else text[:width - 4]) + ", ..."


@dataclass
class Result:
    """Statistics of every method of a run, with the resolved config and provenance.

    ``repr`` is a summary (model, inputs, outputs, methods and their runs); the statistics
    are ``run(label).estimate.stats``, ``to_xarray()`` and ``to_dataframe(output)``.
    """

    name: str
    model: str
    input_names: list[str]
    outputs: list[OutputInfo]
    time: np.ndarray
    runs: list[MethodRun]
    reference: str | None = None
    report_times: list[float] | None = None
    config: dict[str, Any] = field(default_factory=dict)
    provenance: dict[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        outputs = [o.name + (f" ({self.time.size} steps)" if o.kind == "series" else "")
                   for o in self.outputs]
        lines = [f"Result {self.name!r}: model {self.model}, {_count(self.input_names, 'input')}"
                 f" -> {_count(self.outputs, 'output')}, {_count(self.runs, 'method')}",
                 f"  inputs: {_names(self.input_names)}",
                 f"  outputs: {_names(outputs)}"]
        for r in self.runs:
            lines.append(f"  {r.label} ({r.estimate.method}): {r.n_runs:,} runs, "
                         f"{r.n_failed:,} failed"
                         + ("" if r.success else f"; no statistics: {r.message}")
                         + (" (reference)" if r.label == self.reference else ""))
        lines.append("  .run(label), .surrogate(label), .to_xarray(), .to_dataframe(output)")
        return "\n".join(lines)

    def run(self, label: str) -> MethodRun:
        """One method's estimate and runs by its config label; ResultError (listing the labels)
        when there is none."""
        for r in self.runs:
            if r.label == label:
                return r
        raise ResultError(f"no method labelled {label!r} in this result; "
                          f"it has: {', '.join(r.label for r in self.runs)}")

    def surrogate(self, label: str) -> Any:
        """The PCE surrogate of method ``label``: a vectorised predictor ``f(x (n, d)) ->
        {output: values (n, T, k) or (n, k)}`` of the physical inputs (config order, SI),
        :class:`uqguide.pce.surrogate.Surrogate` (``.statistics(name)``, ``.at_unit(u)``).
        It prints as a summary (method, inputs, per output degree, terms and error); the
        coefficients are ``.expansions[output].alpha`` and ``.coef``.

        A surrogate read from a file gets its germ and the model's derived-output maps from the
        stored config. ResultError when the method kept no surrogate (sampling methods, files
        written before surrogates were kept).
        """
        est = self.run(label).estimate
        s = est.surrogate
        if s is None:
            raise ResultError(f"method {label!r} ({est.method}) kept no surrogate; only PCE "
                              f"methods do (and result files written before surrogates were kept)")
        if isinstance(s, StoredSurrogate):
            from ..pce.germ import Germ
            from . import stored_context

            if stored_context is None:  # pragma: no cover - set whenever uqguide is imported
                raise ResultError("uqguide.results.stored_context is not set")
            space, derived = stored_context(self.config)
            if list(space.names) != list(s.inputs):
                raise ResultError(f"{label}: the surrogate's inputs {s.inputs} are not the "
                                  f"stored config's {list(space.names)}")
            est.surrogate = s = s.resolve(Germ.of(space), derived)
        # its repr names the method and the errors it measured (the surrogate does not know)
        return s.fitted_by(est.label, est.method, est.diagnostics)

    def output(self, name: str) -> OutputInfo:
        """The metadata of one output (kind, unit, components); ResultError when there is none."""
        for o in self.outputs:
            if o.name == name:
                return o
        raise ResultError(f"no output {name!r} in this result (its outputs: "
                          f"{', '.join(o.name for o in self.outputs)})")

    def to_xarray(self, label: str | None = None) -> Any:
        """The statistics as an ``xarray.Dataset``: of method ``label`` (with its cost and
        counts as attributes), or of every method along a ``label`` dimension,
        ``ds.sel(label="mc1000")`` (NaN where a method lacks a variable; ``method_name``,
        ``n_runs`` and ``n_failed`` along ``label``).

        Per output: ``<output>`` (dimensions ``statistic``, ``time`` for a series,
        ``<output>_component`` for an output of several components; of one, a scalar coordinate
        naming it), its covariance, intervals, Sobol' indices and quantiles where the method
        gives them (:mod:`uqguide.results.dataset`).
        """
        if label is not None:
            r = self.run(label)
            ds = without_single_components(
                stats_dataset(r.estimate.stats, self.outputs, self.time, self.input_names),
                self.outputs)
            ds.attrs.update(name=self.name, model=self.model, label=r.label,
                            method=r.estimate.method, n_runs=r.n_runs, n_failed=r.n_failed,
                            model_seconds=r.model_seconds, fit_seconds=r.fit_seconds)
            return ds
        if not self.runs:
            raise ResultError("this result has no methods")
        ds = stack([self.to_xarray(r.label) for r in self.runs], [r.label for r in self.runs])
        ds["method_name"] = (LABEL, np.array([r.estimate.method for r in self.runs],
                                             dtype=object))
        ds["n_runs"] = (LABEL, np.array([r.n_runs for r in self.runs]))
        ds["n_failed"] = (LABEL, np.array([r.n_failed for r in self.runs]))
        ds.attrs.update(name=self.name, model=self.model, reference=self.reference or "")
        return ds

    def to_dataframe(self, output: str | None = None) -> Any:
        """Every statistic of ``output`` (optional when there is only one) at every time step as a
        tidy table: one row per value, columns ``label``, ``time`` [s] (series only),
        ``component``, ``statistic`` (mean, std, skewness, kurtosis, sem, q<level>), ``value``
        (in the output's unit), ``ci_low``, ``ci_high`` (NaN where the method gives no
        interval); a validated PCE's control-variate moments are rows labelled ``<label>+cv``,
        and where a PCE withholds a moment the Monte Carlo estimate of its runs ``<label>+mc``.
        The column ``method`` (now ``label``) still answers, with a DeprecationWarning."""
        import pandas as pd

        if output is None:
            if len(self.outputs) != 1:
                raise ResultError(f"to_dataframe: name one of this result's "
                                  f"{len(self.outputs)} outputs: "
                                  f"{', '.join(o.name for o in self.outputs)}")
            output = self.outputs[0].name
        info = self.output(output)
        rows = [f for r in self.runs if output in r.estimate.stats
                for f in frames(stats_dataset({output: r.estimate.stats[output]}, [info],
                                              self.time, self.input_names), info, r.label)]
        if not rows:
            raise ResultError(f"no method of this result has statistics of {output!r}")
        return tidy_frame_class()(pd.concat(rows, ignore_index=True))


def provenance() -> dict[str, Any]:
    """Versions and host facts that explain where a result's numbers came from:
    ``created_utc`` (ISO time), ``versions`` (uqguide, Python, NumPy, SciPy, chaospy, h5py,
    numba) and ``platform``."""
    import scipy
    from importlib.metadata import PackageNotFoundError, version

    try:
        # From the installed metadata: importing chaospy for its version costs a second.
        chaospy_version = version("chaospy")
    except PackageNotFoundError:  # pragma: no cover
        chaospy_version = "unknown"
    versions = {
        "uqguide": __version__,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "chaospy": chaospy_version,
        "h5py": h5py.__version__,
    }
    try:
        import numba

        versions["numba"] = numba.__version__
    except ImportError:  # pragma: no cover - numba is a dependency, but the numpy path works alone
        pass
    return {
        "created_utc": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "versions": versions,
        "platform": platform.platform(),
    }


# ---------------------------------------------------------------------------- writing
def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def write_hdf5(result: Result, path: str | Path) -> Path:
    """Write ``result`` to ``path`` atomically (temporary file in the same folder, then rename;
    its folder is created): an interrupted write leaves no file under this name."""
    path = Path(path)
    layout = file_layout(result)
    with atomic.atomic_file(path) as tmp:
        # HDF5 crashes the process at exit after a failed write (a full disk): it writes
        # through a file that holds the error until the library has closed it.
        raw = atomic.HeldErrorFile(tmp.fileno())
        try:
            with h5py.File(raw, "w") as f:
                write_group(f, layout)
        finally:
            raw.close()
    return path


def file_layout(result: Result) -> Group:
    """The whole file of ``result``, laid out (module docstring), for one writing pass; large
    arrays (a generated design, the failure reasons) are written block by block."""
    labels = [r.label for r in result.runs]
    attrs = {
        "format": FORMAT, "uqguide_version": __version__, "name": result.name,
        "model": result.model, "seed": int(result.config.get("seed", 0)),
        "reference": result.reference or "",
        "config_yaml": yaml.safe_dump(result.config, sort_keys=False),
        "created_utc": result.provenance.get("created_utc", ""),
        "wall_seconds": float(result.provenance.get("wall_seconds", 0.0)),
        "versions_json": json.dumps(result.provenance.get("versions", {})),
        # HDF5 lists groups alphabetically: keep the config's method order explicitly.
        "method_order": json.dumps(labels),
        "output_order": json.dumps([o.name for o in result.outputs]),
    }
    scales = {"time": Dataset(result.time, attrs={"units": "s", "long_name": "time"}),
              "input": Dataset(np.array(result.input_names, dtype=object),
                               attrs={"long_name": "uncertain input"})}
    if result.report_times:
        scales["report_times"] = Dataset(np.asarray(result.report_times, dtype=float),
                                         attrs={"units": "s"})
    scales["label"] = Dataset(np.array(labels, dtype=object),
                              attrs={"long_name": "method label, config order"})
    scales["output"] = Dataset(np.array([o.name for o in result.outputs], dtype=object),
                               attrs={"long_name": "output, config order"})
    index = {
        "method_name": Dataset(np.array([r.estimate.method for r in result.runs], dtype=object),
                               ("label",), {"long_name": "registered method"}),
        "n_runs": Dataset(np.array([r.n_runs for r in result.runs], dtype=np.int64), ("label",),
                          {"long_name": "model runs"}),
        "n_failed": Dataset(np.array([r.n_failed for r in result.runs], dtype=np.int64),
                            ("label",), {"long_name": "failed model runs"}),
        "success": Dataset(np.array([r.success for r in result.runs], dtype=np.uint8),
                           ("label",), {"long_name": "1 where the method gave statistics"}),
        "method_group": Dataset(np.array([f"methods/{x}" for x in labels], dtype=object),
                                ("label",), {"long_name": "group of the method's statistics"}),
        "output_kind": Dataset(np.array([o.kind for o in result.outputs], dtype=object),
                               ("output",), {"long_name": "series or scalar"}),
        "output_unit": Dataset(np.array([o.unit for o in result.outputs], dtype=object),
                               ("output",), {"long_name": "unit (SI)"}),
        "output_description": Dataset(np.array([o.description for o in result.outputs],
                                               dtype=object), ("output",)),
    }
    outputs = Group(groups={o.name: Group(attrs={
        "kind": o.kind, "unit": o.unit, "description": o.description,
        "components": json.dumps(list(o.components))}) for o in result.outputs})
    methods = Group(groups={r.label: _method_layout(r, result) for r in result.runs})
    return Group(attrs, scales, index, {"outputs": outputs, "methods": methods})


def _method_layout(r: MethodRun, result: Result) -> Group:
    """The group ``methods/<label>``: the method's statistics and the runs behind them."""
    e = r.estimate
    g = dataset_group(stats_dataset(e.stats, result.outputs, result.time, result.input_names))
    g.attrs.update(method=e.method, n_runs=r.n_runs, n_failed=r.n_failed,
                   model_seconds=r.model_seconds, fit_seconds=r.fit_seconds,
                   wall_seconds=r.wall_seconds, compile_seconds=r.compile_seconds,
                   success=r.success, message=r.message,
                   diagnostics_json=json.dumps(e.diagnostics, default=_json_default))
    if e.scalar_names and e.scalar_mean is not None and e.scalar_cov is not None:
        g.groups["scalar_joint"] = Group(
            scales={"names": Dataset(np.array(e.scalar_names, dtype=object))},
            variables={"mean": Dataset(e.scalar_mean, ("names",)),
                       "cov": Dataset(e.scalar_cov)})
    surrogate = e.surrogate
    if surrogate is not None and hasattr(surrogate, "expansions"):
        g.groups["surrogate"] = Group(fill=lambda h: write_surrogate(h, surrogate))
    if e.events:
        g.groups["events"] = Group(groups={name: Group(attrs=ev.as_dict())
                                           for name, ev in e.events.items()})
    if r.verdicts:
        g.groups["requirements"] = Group(groups={name: Group(attrs=v.as_dict())
                                                 for name, v in r.verdicts.items()})
    g.groups["samples"] = _samples_layout(r, g.scales, result)
    return g


def _samples_layout(r: MethodRun, method_scales: dict[str, Dataset], result: Result) -> Group:
    """The group ``samples``: every run's inputs, failure and scalar outputs."""
    x = r.x
    # Not compressed: random inputs are incompressible doubles (1e6 x 7 of them: 56 MB raw,
    # 53 MB deflated, for 1.2 s of a 9 s run).
    if isinstance(x, GeneratedRows):  # written chunk by chunk: never held whole
        xs = Dataset(Blocks(x.shape, "f8", lambda: ((slice(start, start + rows.shape[0]), rows)
                                                    for start, rows in x.chunks())),
                     ("sample", "input"),
                     storage={"chunks": (min(max(x.n, 1), 65536), max(x.d, 1)) if x.size
                              else None})
    else:
        xs = Dataset(x, ("sample", "input"))
    variables = {"x": xs, "failed": Dataset(r.failed.astype(np.uint8), ("sample",)),
                 "reasons": _reasons(r.reasons)}
    info = {o.name: o for o in result.outputs}
    scalars = {}
    for name, y in r.scalars.items():
        big = y.size > 4096
        comp = method_scales.get(f"{name}_component")
        # the component scale only where it fits (a method without statistics of the output
        # has none; a series' scalars are not its components)
        fits = comp is not None and info[name].kind == "scalar" and y.ndim == 2 \
            and y.shape[1] == np.shape(comp.data)[0]
        scalars[name] = Dataset(y, ("sample", f"{name}_component") if fits else None,
                                storage={"shuffle": big, "compression": "gzip" if big else None,
                                         "compression_opts": 1 if big else None})
    return Group(scales={"sample": Dataset(np.arange(x.shape[0]))}, variables=variables,
                 groups={"scalars": Group(variables=scalars)} if scalars else {})


def _reasons(reasons: np.ndarray, block: int = 1 << 20) -> Dataset:
    """Failure reasons as UTF-8 strings (netCDF-4 ``string``), converted a block at a time (a
    list of 1e7 Python strings would cost more than the result)."""
    n = len(reasons)
    # Only failed samples have a reason; the others read back as the dataset's fill value "".
    # Writing just those keeps a 1e6-run result with few failures from converting a million
    # empty Python strings (1.5 s of a 9 s run).
    failed = np.flatnonzero(np.asarray(reasons, dtype=object).astype(bool))

    def blocks() -> Iterator[tuple[Any, np.ndarray]]:
        if failed.size > n // 4:
            for a in range(0, n, block):
                yield slice(a, a + block), np.array([str(v) for v in reasons[a:a + block]],
                                                    dtype=object)
        else:
            for a in range(0, failed.size, block):
                idx = failed[a:a + block]
                yield idx, np.array([str(v) for v in reasons[idx]], dtype=object)

    return Dataset(Blocks((n,), UTF8, blocks), ("sample",),
                   storage={"compression": "gzip" if n > 4096 else None})


# ---------------------------------------------------------------------------- reading
def _read_stats(g: h5py.Group) -> OutputStats:
    ci = {k[3:]: g[k][()] for k in g if k.startswith("ci_") and k != "ci_quantiles"}
    q = g.get("quantiles")
    return OutputStats(
        mean=g["mean"][()], std=g["std"][()], skewness=g["skewness"][()],
        kurtosis=g["kurtosis"][()], cov=g["cov"][()], n_used=int(g.attrs["n_used"]),
        moments_method=str(g.attrs["moments_method"]),
        sem=g["sem"][()] if "sem" in g else None, ci=ci,
        sobol_first=g["sobol_first"][()] if "sobol_first" in g else None,
        sobol_total=g["sobol_total"][()] if "sobol_total" in g else None,
        quantile_levels=tuple(float(p) for p in q.attrs["levels"]) if q is not None else None,
        quantiles=q[()] if q is not None else None,
        ci_quantiles=g["ci_quantiles"][()] if q is not None else None,
    )


def read_hdf5(path: str | Path) -> Result:
    """Read a result file written by :func:`write_hdf5` (any format version); ResultError when
    the file is missing, not a uqguide result or incomplete."""
    path = Path(path)
    if not path.is_file():  # (a FIFO's open would block)
        raise ResultError(f"{path}: " + ("not a regular file" if path.exists() else
                                         "result file not found"))
    try:
        with h5py.File(path, "r") as f:
            fmt = int(f.attrs.get("format", -1))
            if fmt not in READABLE_FORMATS:
                raise ResultError(f"{path}: not a uqguide result file (format "
                                  f"{f.attrs.get('format')!r}, expected one of "
                                  f"{', '.join(map(str, READABLE_FORMATS))})")
            out_order = json.loads(f.attrs.get("output_order", "[]")) or list(f["outputs"])
            outputs = [
                OutputInfo(name, str(g.attrs["kind"]), str(g.attrs["unit"]),  # type: ignore[arg-type]
                           str(g.attrs["description"]),
                           tuple(json.loads(g.attrs["components"])))
                for name, g in ((n, f["outputs"][n]) for n in out_order)
            ]
            runs = []
            order = json.loads(f.attrs.get("method_order", "[]")) or list(f["methods"])
            for label in order:
                g = f["methods"][label]
                if fmt == 1:
                    stats = {name: _read_stats(sg) for name, sg in g.get("stats", {}).items()}
                else:
                    stats = read_stats(g, outputs)
                joint = g.get("scalar_joint")
                est = Estimate(
                    method=str(g.attrs["method"]), label=label, stats=stats,
                    diagnostics=json.loads(g.attrs["diagnostics_json"]),
                    scalar_index=ScalarIndex.parse(strings(joint["names"][()])) if joint else [],
                    scalar_mean=joint["mean"][()] if joint else None,
                    scalar_cov=joint["cov"][()] if joint else None,
                    surrogate=read_surrogate(g["surrogate"]) if "surrogate" in g else None,
                    events={name: EventEstimate.from_dict(name, dict(eg.attrs))
                            for name, eg in g.get("events", {}).items()},
                )
                s = g["samples"]
                runs.append(MethodRun(
                    estimate=est, x=s["x"][()],
                    scalars={k: v[()] for k, v in s.get("scalars", {}).items()},
                    failed=s["failed"][()].astype(bool),
                    reasons=np.array(strings(s["reasons"][()]), dtype=object),
                    time=f["time"][()], n_runs=int(g.attrs["n_runs"]),
                    model_seconds=float(g.attrs["model_seconds"]),
                    fit_seconds=float(g.attrs["fit_seconds"]),
                    wall_seconds=float(g.attrs["wall_seconds"]),
                    compile_seconds=float(g.attrs.get("compile_seconds", 0.0)),
                    success=bool(g.attrs.get("success", True)),
                    message=str(g.attrs.get("message", "")),
                    verdicts={name: Verdict.from_dict(name, label, dict(vg.attrs))
                              for name, vg in g.get("requirements", {}).items()},
                ))
            config = _config_from_yaml(f.attrs["config_yaml"], path)
            result = Result(
                name=str(f.attrs["name"]), model=str(f.attrs["model"]),
                input_names=strings(f["inputs/names" if fmt == 1 else "input"][()]),
                outputs=outputs, time=f["time"][()], runs=runs,
                reference=str(f.attrs["reference"]) or None,
                report_times=list(f["report_times"][()]) if "report_times" in f else None,
                config=config,
                provenance={"created_utc": str(f.attrs["created_utc"]),
                            "wall_seconds": float(f.attrs["wall_seconds"]),
                            "versions": json.loads(f.attrs["versions_json"])},
            )
    except ResultError:
        raise
    except (OSError, KeyError, ValueError, TypeError, IndexError, AttributeError,
            RecursionError) as exc:
        raise ResultError(f"{path}: unreadable or incomplete result file "
                          f"({type(exc).__name__}: {exc})") from None
    _check_result(result, path)
    return result


def read_config(path: str | Path) -> dict[str, Any]:
    """The resolved config a result file was made from, without reading its statistics;
    ResultError when it is not a readable uqguide result file."""
    path = Path(path)
    if path.exists() and not path.is_file():  # (a FIFO's open would block)
        raise ResultError(f"{path}: not a regular file")
    try:
        with h5py.File(path, "r") as f:
            text = f.attrs["config_yaml"]
    except (OSError, KeyError) as exc:
        raise ResultError(f"{path}: not a readable uqguide result file "
                          f"({type(exc).__name__}: {exc})") from None
    return _config_from_yaml(text, path)


def _config_from_yaml(text: Any, path: Path) -> dict[str, Any]:
    from ..core.safe_yaml import YamlLimitError, safe_load

    try:
        config = safe_load(str(text))
    except (yaml.YAMLError, YamlLimitError) as exc:
        raise ResultError(f"{path}: its config_yaml is not a readable config "
                          f"({str(exc).splitlines()[0]})") from None
    if not isinstance(config, dict):
        raise ResultError(f"{path}: its config_yaml is not a mapping (got "
                          f"{type(config).__name__})")
    return config


def _check_result(r: Result, path: Path) -> None:
    """ResultError unless every array has the shape its output says (a file edited or
    written by something else must not reach the gate, the plots or the report)."""
    bad = None
    if r.time.ndim != 1:
        bad = f"time has shape {r.time.shape}, expected (T,)"
    names = {o.name for o in r.outputs}
    for run in r.runs:
        if bad:
            break
        n = run.x.shape[0] if run.x.ndim == 2 else -1
        if run.x.ndim != 2 or run.x.shape[1] != len(r.input_names):
            bad = (f"{run.label}: samples/x has shape {run.x.shape}, "
                   f"expected (n, {len(r.input_names)})")
        elif run.failed.shape != (n,) or run.reasons.shape != (n,):
            bad = f"{run.label}: samples/failed or reasons do not have {n} rows"
        unknown = [name for name in run.estimate.stats if name not in names]
        if not bad and unknown:
            bad = (f"{run.label}: statistics of '{unknown[0]}', which is not an output of "
                   f"the file")
        for o in r.outputs:
            if not bad and o.name in run.estimate.stats:
                bad = misshapen(run.estimate.stats[o.name], o, r.time.size,
                                f"{run.label}/{o.name}")
    if bad:
        raise ResultError(f"{path}: inconsistent result file ({bad})")
