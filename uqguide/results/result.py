"""The Result of a run and its HDF5 form.

Layout of a result file (format 2: netCDF-4 conventions, i.e. HDF5 dimension scales and UTF-8
strings, so xarray / h5netcdf read it with named dimensions; every array SI)::

    /                       attrs: format, uqguide_version, created_utc, name, model, seed,
                                   reference, config_yaml (resolved config), wall_seconds,
                                   versions_json (python and library versions)
    /time                   (time,) time grid [s] (empty for models without series)
    /input                  (input,) uncertain input names, config order
    /report_times           (r,) [s], where the config gives them
    /outputs/<name>         attrs: kind (series|scalar), unit, description, components
    /methods/<label>        attrs: method, n_runs, n_failed, model_seconds, fit_seconds,
                                   wall_seconds, success, message, diagnostics_json,
                                   compile_seconds (absent before it was kept: read as 0)
      <output>, <output>_cov, _sem, _ci, _sobol_first, _sobol_total, _quantile, _ci_quantile
                        the variables of :mod:`uqguide.results.labelled`, e.g. <output> is
                        (statistic, time, <output>_component); coordinates time, input,
                        statistic, bound, quantile, <output>_component
      events/<name>     attrs: definition, probability, ci_low, ci_high, n_in, n_used,
                               estimator (count | surrogate | subset), cov
      scalar_joint/names, mean, cov                    all scalar outputs stacked
      surrogate/        a PCE method's fitted expansions, input-to-germ map and derived
                        outputs' carriers (:mod:`uqguide.results.surrogate`)
      samples/x (sample, input), failed (sample,) 0/1, reasons (sample,),
              scalars/<output> (sample, <output>_component)

Format 1 (uqguide before format 2; still read): ``/inputs/names`` and, per method,
``stats/<output>/{mean, std, skewness, kurtosis, cov, sem, ci_<stat>, sobol_first,
sobol_total, quantiles, ci_quantiles}`` without dimension scales, strings as bytes.

The file is written to a temporary name in the same folder and renamed into place, so a file
with the final name is always complete.
"""

from __future__ import annotations

import datetime as _dt
import json
import platform
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import h5py
import numpy as np
import yaml

from ..core import atomic
from .._version import __version__
from ..errors import ResultError
from ..core.events import EventEstimate
from ..core.types import Estimate, GeneratedRows, ScalarIndex
from ..models.base import OutputInfo
from .surrogate import StoredSurrogate, read_surrogate, write_surrogate
from .netcdf_file import UTF8, attach, read_method_stats, strings, write_method_stats, write_scale
from ..stats.moments import STAT_NAMES, OutputStats

FORMAT = 2
#: Format versions :func:`read_hdf5` reads.
READABLE_FORMATS = (1, 2)


@dataclass
class MethodRun:
    """One method's estimate with the runs behind it.

    Attributes
    ----------
    estimate : Estimate
    x : ndarray or GeneratedRows, shape (n, d)
        Inputs of every model run (a Monte Carlo design is generated per chunk on demand:
        slice it, or ``np.asarray`` it for the whole array).
    scalars : dict of str to ndarray, shape (n, k)
        Scalar outputs of every run (NaN or garbage where ``failed``).
    failed : ndarray of bool, shape (n,)
    reasons : ndarray of object, shape (n,)
    time : ndarray, shape (T,)
    n_runs : int
    model_seconds : float
        Seconds in the model, summed over chunks (worker-seconds), compiling excluded.
    fit_seconds : float
        Seconds the method spent outside the model: refinement fits and the estimate.
    wall_seconds : float
        Wall-clock seconds of the whole method, design included.
    success : bool
        Whether the method produced statistics; when not, ``estimate`` holds none and
        ``message`` says why (the runs made are still here, with their failures).
    message : str
        Why the method failed ("" when it succeeded).
    compile_seconds : float
        Seconds spent compiling the model's kernel during this method (a first run on a fresh
        install; 0 when it came from the cache, and in files written before it was kept).
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

    @property
    def label(self) -> str:
        return self.estimate.label

    @property
    def n_failed(self) -> int:
        return int(np.sum(self.failed))


@dataclass
class Result:
    """Statistics of every method of a run, with the resolved config and provenance."""

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

    def run(self, label: str) -> MethodRun:
        """One method's estimate and runs.

        Parameters
        ----------
        label : str
            The method entry's label in the config.

        Returns
        -------
        MethodRun
            ResultError (listing the labels) when there is none of that label.
        """
        for r in self.runs:
            if r.label == label:
                return r
        raise ResultError(f"no method labelled {label!r} in this result; "
                          f"it has: {', '.join(r.label for r in self.runs)}")

    def surrogate(self, label: str) -> Any:
        """The PCE surrogate of method ``label``: a vectorised predictor ``f(x (n, d)) ->
        {output: values (n, T, k) or (n, k)}`` of the physical inputs (config order, SI),
        :class:`uqguide.pce.surrogate.Surrogate` (``.statistics(name)``, ``.at_unit(u)``).

        A surrogate read from a file gets its germ and the model's derived-output maps from the
        stored config. ResultError when the method kept no surrogate (sampling methods, files
        written before surrogates were kept).
        """
        est = self.run(label).estimate
        s = est.surrogate
        if s is None:
            raise ResultError(f"method {label!r} ({est.method}) kept no surrogate; only PCE "
                              f"methods do (and result files from uqguide 0.x before issue 14)")
        if isinstance(s, StoredSurrogate):
            from ..config.run_config import validate_config
            from ..pce.germ import Germ

            cfg = validate_config(self.config, f"{self.name} (stored config)")
            if list(cfg.space.names) != list(s.inputs):
                raise ResultError(f"{label}: the surrogate's inputs {s.inputs} are not the "
                                  f"stored config's {list(cfg.space.names)}")
            est.surrogate = s = s.resolve(Germ.of(cfg.space), cfg.model.derived_outputs())
        return s

    def output(self, name: str) -> OutputInfo:
        """The metadata of one output (kind, unit, components).

        Parameters
        ----------
        name : str
            An output of this result.

        Returns
        -------
        OutputInfo
            ResultError when the result has no such output.
        """
        for o in self.outputs:
            if o.name == name:
                return o
        raise ResultError(f"no output {name!r} in this result")

    def to_xarray(self, label: str | None = None) -> Any:
        """The statistics as an ``xarray.Dataset``: of method ``label``, or of every method
        along a ``method`` dimension (see :mod:`uqguide.results.frames`; needs ``uqguide[xarray]``).

        Parameters
        ----------
        label : str, optional
            One method's label; default all methods.

        Returns
        -------
        xarray.Dataset
            Per output: ``<output>`` (dimensions ``statistic``, ``time`` for a series,
            ``<output>_component``), its covariance, intervals, Sobol' indices and quantiles
            where the method gives them; plus ``method`` when all methods are stacked.
        """
        from .frames import to_xarray

        return to_xarray(self, label)

    def to_dataframe(self, output: str) -> Any:
        """Every statistic of ``output`` at every time step as a tidy table.

        Parameters
        ----------
        output : str
            An output of this result.

        Returns
        -------
        pandas.DataFrame
            One row per value: columns ``method``, ``time`` [s] (series only), ``component``,
            ``statistic``, ``value`` (in the output's unit), ``ci_low``, ``ci_high``.
        """
        from .frames import to_dataframe

        return to_dataframe(self, output)


def provenance() -> dict[str, Any]:
    """Versions and host facts that explain where a result's numbers came from.

    Returns
    -------
    dict
        ``created_utc`` (ISO time), ``versions`` (uqguide, Python, NumPy, SciPy, chaospy,
        h5py, numba) and ``platform``.
    """
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
    """Write ``result`` to ``path`` atomically (temporary file in the same folder, then rename).

    Parameters
    ----------
    result : Result
    path : str or Path
        The HDF5 file to write; its folder is created.

    Returns
    -------
    Path
        ``path``, complete: an interrupted write leaves no file under this name.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic.atomic_path(path) as tmp:
        with h5py.File(tmp, "w") as f:
            _fill(f, result)
    return path


def _fill(f: h5py.File, result: Result) -> None:
    f.attrs["format"] = FORMAT
    f.attrs["uqguide_version"] = __version__
    f.attrs["name"] = result.name
    f.attrs["model"] = result.model
    f.attrs["seed"] = int(result.config.get("seed", 0))
    f.attrs["reference"] = result.reference or ""
    f.attrs["config_yaml"] = yaml.safe_dump(result.config, sort_keys=False)
    f.attrs["created_utc"] = result.provenance.get("created_utc", "")
    f.attrs["wall_seconds"] = float(result.provenance.get("wall_seconds", 0.0))
    f.attrs["versions_json"] = json.dumps(result.provenance.get("versions", {}))
    # HDF5 lists groups alphabetically: keep the config's method order explicitly.
    f.attrs["method_order"] = json.dumps([r.label for r in result.runs])
    f.attrs["output_order"] = json.dumps([o.name for o in result.outputs])
    write_scale(f, "time", result.time, units="s", long_name="time")
    write_scale(f, "input", result.input_names, long_name="uncertain input")
    if result.report_times:
        write_scale(f, "report_times", np.asarray(result.report_times, dtype=float), units="s")
    for o in result.outputs:
        g = f.create_group(f"outputs/{o.name}")
        g.attrs.update(kind=o.kind, unit=o.unit, description=o.description,
                       components=json.dumps(list(o.components)))
    for r in result.runs:
        _write_run(f.create_group(f"methods/{r.label}"), r, result)


def _write_reasons(g: h5py.Group, reasons: np.ndarray, block: int = 1 << 20) -> h5py.Dataset:
    """Failure reasons as UTF-8 strings (netCDF-4 ``string``), converted a block at a time (a
    list of 1e7 Python strings would cost more than the result)."""
    n = len(reasons)
    ds = g.create_dataset("reasons", shape=(n,), dtype=UTF8,
                          compression="gzip" if n > 4096 else None)
    # Only failed samples have a reason; the others read back as the dataset's fill value "".
    # Writing just those keeps a 1e6-run result with few failures from converting a million
    # empty Python strings (1.5 s of a 9 s run).
    failed = np.flatnonzero(np.asarray(reasons, dtype=object).astype(bool))
    if failed.size > n // 4:
        for a in range(0, n, block):
            ds[a:a + block] = np.array([str(v) for v in reasons[a:a + block]], dtype=object)
    else:
        for a in range(0, failed.size, block):
            idx = failed[a:a + block]
            ds[idx] = np.array([str(v) for v in reasons[idx]], dtype=object)
    return ds


def _write_run(g: h5py.Group, r: MethodRun, result: Result) -> None:
    e = r.estimate
    g.attrs.update(method=e.method, n_runs=r.n_runs, n_failed=r.n_failed,
                   model_seconds=r.model_seconds, fit_seconds=r.fit_seconds,
                   wall_seconds=r.wall_seconds, compile_seconds=r.compile_seconds,
                   success=r.success, message=r.message,
                   diagnostics_json=json.dumps(e.diagnostics, default=_json_default))
    outputs = [o for o in result.outputs if o.name in e.stats or o.name in r.scalars]
    scales = write_method_stats(g, e.stats, outputs, result.time, result.input_names)
    if e.scalar_names and e.scalar_mean is not None:
        j = g.create_group("scalar_joint")
        names = write_scale(j, "names", e.scalar_names)
        attach(j.create_dataset("mean", data=e.scalar_mean), [names])
        j.create_dataset("cov", data=e.scalar_cov)
    if e.surrogate is not None and hasattr(e.surrogate, "expansions"):
        write_surrogate(g.create_group("surrogate"), e.surrogate)
    for name, ev in e.events.items():
        g.create_group(f"events/{name}").attrs.update(ev.as_dict())
    s = g.create_group("samples")
    x = r.x
    sample = write_scale(s, "sample", np.arange(x.shape[0]))
    # Not compressed: random inputs are incompressible doubles (1e6 x 7 of them: 56 MB raw,
    # 53 MB deflated, for 1.2 s of a 9 s run).
    gz = None
    if isinstance(x, GeneratedRows):  # written chunk by chunk: never held whole
        ds = s.create_dataset("x", shape=x.shape, dtype="f8", compression=gz,
                              chunks=(min(max(x.n, 1), 65536), max(x.d, 1)) if x.size else None)
        for start, rows in x.chunks():
            ds[start:start + rows.shape[0]] = rows
    else:
        ds = s.create_dataset("x", data=x, compression=gz)
    attach(ds, [sample, scales["input"]])
    attach(s.create_dataset("failed", data=r.failed.astype(np.uint8)), [sample])
    attach(_write_reasons(s, r.reasons), [sample])
    info = {o.name: o for o in result.outputs}
    for name, y in r.scalars.items():
        comp = scales.get(f"{name}_component")
        d = s.create_dataset(f"scalars/{name}", data=y, shuffle=y.size > 4096,
                             compression="gzip" if y.size > 4096 else None,
                             compression_opts=1 if y.size > 4096 else None)
        if comp is not None and info[name].kind == "scalar" and y.ndim == 2 \
                and y.shape[1] == comp.shape[0]:
            attach(d, [sample, comp])


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
    """Read a result file written by :func:`write_hdf5` (any format version).

    Parameters
    ----------
    path : str or Path
        The HDF5 result file.

    Returns
    -------
    Result
        ResultError when the file is missing, not a uqguide result or incomplete.
    """
    path = Path(path)
    if not path.is_file():
        raise ResultError(f"{path}: result file not found")
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
                    stats = read_method_stats(g, outputs)
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


def _config_from_yaml(text: Any, path: Path) -> dict[str, Any]:
    from ..config.safe_yaml import YamlLimitError, safe_load

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
    names = {o.name: o for o in r.outputs}
    for run in r.runs:
        if bad:
            break
        n = run.x.shape[0] if run.x.ndim == 2 else -1
        if run.x.ndim != 2 or run.x.shape[1] != len(r.input_names):
            bad = (f"{run.label}: samples/x has shape {run.x.shape}, "
                   f"expected (n, {len(r.input_names)})")
        elif run.failed.shape != (n,) or run.reasons.shape != (n,):
            bad = f"{run.label}: samples/failed or reasons do not have {n} rows"
        for name, s in run.estimate.stats.items():
            if bad:
                break
            o = names.get(name)
            if o is None:
                bad = f"{run.label}: statistics of '{name}', which is not an output of the file"
                break
            want = (r.time.size, o.k) if o.kind == "series" else (o.k,)
            for stat in STAT_NAMES:
                arr = np.asarray(s.stat(stat))
                if arr.shape != want or arr.dtype.kind not in "fiu":
                    bad = (f"{run.label}/{name}: {stat} has shape {arr.shape} and type "
                           f"{arr.dtype}, expected {want} numbers")
                    break
            if not bad and s.sem is not None and np.shape(s.sem) != want:
                bad = f"{run.label}/{name}: sem has shape {np.shape(s.sem)}, expected {want}"
            for stat, ci in s.ci.items():
                if not bad and np.shape(ci) != (2, *want):
                    bad = f"{run.label}/{name}: ci_{stat} has shape {np.shape(ci)}"
    if bad:
        raise ResultError(f"{path}: inconsistent result file ({bad})")
