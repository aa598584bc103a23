"""A method's statistics as named, labelled arrays: the variables that both the result file
(format 2, a netCDF-4 group per method) and ``Result.to_xarray()`` hold, laid out from the
description of :mod:`uqguide.results.statistics`.

Per output ``o``: ``o`` (statistic, ..., o_component) with mean, std, skewness and kurtosis,
then ``o_cov``, ``o_sem``, ``o_ci``, the Sobol' indices of inputs and groups with their
intervals, the quantiles, and a validated PCE's ``o_corrected``, ``o_fallback``,
``o_validation_error`` and ``o_usable`` (:func:`method_variables`; read back by
:func:`stats_from_variables`). Each output has its own component dimension
(:func:`component_dim`) because outputs differ in their number of components.

The table of variables, their dimensions and coordinates:
docs/result-file.md#a-methods-variables.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.types import STAT_NAMES, OutputStats
from .statistics import OutputStatistics, Statistic

if TYPE_CHECKING:
    from ..models.base import OutputInfo

BOUNDS = ("low", "high")


@dataclass
class Variable:
    """One labelled array: its dimension names, values and attributes."""

    dims: tuple[str, ...]
    data: np.ndarray
    attrs: dict[str, Any] = field(default_factory=dict)


def component_dim(output: str, second: bool = False) -> str:
    """Name of an output's component dimension, ``"<output>_component"``, or with ``second``
    the covariance's second one, ``"<output>_component2"``."""
    return f"{output}_component2" if second else f"{output}_component"


def method_variables(stats: Mapping[str, OutputStatistics], time: np.ndarray,
                     input_names: Sequence[str]) -> tuple[dict[str, Variable], dict[str, Variable]]:
    """Coordinates and variables of one method's statistics.

    ``stats``: by output name, in the outputs' order
    (:func:`uqguide.results.statistics.method_statistics`); ``time (T,)`` [s]. Returns the
    coordinate of each dimension by name (``time``, ``input``, ``statistic``, ``bound``,
    components, ``quantile``) and per output its moments, covariance, intervals, Sobol' indices
    and quantiles, with units.
    """
    coords: dict[str, Variable] = {
        "time": Variable(("time",), np.asarray(time, dtype=float),
                         {"units": "s", "long_name": "time"}),
        "input": Variable(("input",), np.array(input_names, dtype=object)),
        "statistic": Variable(("statistic",), np.array(STAT_NAMES, dtype=object)),
        "bound": Variable(("bound",), np.array(BOUNDS, dtype=object)),
    }
    out: dict[str, Variable] = {}
    for v in stats.values():
        o = v.output
        lead = ("time",) if o.kind == "series" else ()
        c, c2 = component_dim(o.name), component_dim(o.name, True)
        names = np.array(o.components, dtype=object)
        coords[c] = Variable((c,), names)
        coords[c2] = Variable((c2,), names)
        base = (*lead, c)
        out[o.name] = Variable(
            ("statistic", *base), np.stack([m.value for m in v.moments]),
            {"units": o.unit, "long_name": o.description, "kind": o.kind,
             "n_used": v.n_used, "moments_method": v.moments_method})
        out[f"{o.name}_cov"] = Variable((*base, c2), v.cov, {"units": f"({o.unit})^2"})
        if v.sem is not None:
            out[f"{o.name}_sem"] = Variable(base, v.sem, {"units": o.unit})
        given = [m for m in v.moments if m.ci is not None]
        if given:
            ci = np.full((2, len(STAT_NAMES), *v.moments[0].value.shape), np.nan)
            for j, m in enumerate(v.moments):
                if m.ci is not None:
                    ci[:, j] = m.ci
            out[f"{o.name}_ci"] = Variable(("bound", "statistic", *base), ci,
                                           {"description": "95% interval",
                                            "statistics": [m.name for m in given]})
        for kind, sobol, band in (("sobol_first", v.sobol_first, v.sobol_first_ci),
                                  ("sobol_total", v.sobol_total, v.sobol_total_ci)):
            if sobol is not None:
                out[f"{o.name}_{kind}"] = Variable(
                    (*base, "input"), sobol,
                    {"units": "1", "estimator": v.sobol_estimator or "pce"})
            if sobol is not None and band is not None:
                out[f"{o.name}_{kind}_ci"] = Variable(("bound", *base, "input"), band,
                                                      {"units": "1",
                                                       "description": "95% interval"})
        if v.sobol_group_first is not None and v.sobol_groups:
            coords["group"] = Variable(("group",), np.array(v.sobol_groups, dtype=object))
            for kind, sobol, band in (
                    ("first", v.sobol_group_first, v.sobol_group_first_ci),
                    ("total", v.sobol_group_total, v.sobol_group_total_ci)):
                if sobol is None:
                    continue
                out[f"{o.name}_sobol_group_{kind}"] = Variable(
                    (*base, "group"), sobol,
                    {"units": "1", "estimator": v.sobol_estimator or "given-data"})
                if band is not None:
                    out[f"{o.name}_sobol_group_{kind}_ci"] = Variable(
                        ("bound", *base, "group"), band,
                        {"units": "1", "description": "95% interval"})
        if v.quantiles:
            levels = np.asarray(v.quantile_levels, dtype=float)
            if "quantile" in coords and not np.array_equal(coords["quantile"].data, levels):
                raise ValueError(f"output {o.name!r} has quantile levels {levels.tolist()}, "
                                 f"another output {coords['quantile'].data.tolist()}")
            coords["quantile"] = Variable(("quantile",), levels)
            out[f"{o.name}_quantile"] = Variable(
                ("quantile", *base), np.stack([q.value for q in v.quantiles]), {"units": o.unit})
            out[f"{o.name}_ci_quantile"] = Variable(
                ("bound", "quantile", *base), np.stack([_ci(q) for q in v.quantiles], axis=1),
                {"units": o.unit})
        if v.corrected:
            out[f"{o.name}_corrected"] = Variable(
                ("statistic", *base), np.stack([m.value for m in v.corrected]),
                {"units": o.unit, "description": "control-variate estimates (PCE + mean "
                                                 "model-minus-surrogate on validation runs)"})
            out[f"{o.name}_corrected_ci"] = Variable(
                ("bound", "statistic", *base), np.stack([_ci(m) for m in v.corrected], axis=1),
                {"description": "95% interval from the validation runs (delta method, stratified)"})
        if v.fallback:
            out[f"{o.name}_fallback"] = Variable(
                ("statistic", *base), np.stack([m.value for m in v.fallback]),
                {"units": o.unit, "description": "where the PCE withholds a moment: the Monte "
                                                 "Carlo estimate of its own fit and "
                                                 "validation runs"})
            out[f"{o.name}_fallback_ci"] = Variable(
                ("bound", "statistic", *base), np.stack([_ci(m) for m in v.fallback], axis=1),
                {"description": "95% interval, the runs treated as independent draws"})
        if v.validation_error is not None:
            out[f"{o.name}_validation_error"] = Variable(
                base, np.asarray(v.validation_error, dtype=float),
                {"units": "1", "description": "mean squared model-minus-surrogate difference "
                                              "over the model's variance, validation runs"})
        if v.usable is not None:
            out[f"{o.name}_usable"] = Variable(base, np.asarray(v.usable, dtype=np.uint8),
                                               {"units": "1"})
    return coords, out


def _ci(st: Statistic) -> np.ndarray:
    """The interval of a statistic that always has one (quantiles, control-variate moments)."""
    if st.ci is None:
        raise ValueError(f"{st.label}: {st.name} has no interval")
    return st.ci


def stats_from_variables(get: Any, has: Any, attrs: Any, outputs: Sequence[OutputInfo]
                         ) -> dict[str, OutputStats]:
    """The inverse of :func:`method_variables` (a file group or a Dataset alike), through
    ``get(name)`` (the array), ``has(name)`` and ``attrs(name)``; by output name, for the outputs
    that have statistics."""
    stats = {}
    for o in outputs:
        if not has(o.name):
            continue
        m = get(o.name)
        a = attrs(o.name)
        ci = {}
        if has(f"{o.name}_ci"):
            arr = get(f"{o.name}_ci")
            known = list(attrs(f"{o.name}_ci")["statistics"])
            ci = {n: arr[:, j] for j, n in enumerate(STAT_NAMES) if n in known}
        q = has(f"{o.name}_quantile")
        stats[o.name] = OutputStats(
            mean=m[0], std=m[1], skewness=m[2], kurtosis=m[3], cov=get(f"{o.name}_cov"),
            n_used=int(a["n_used"]), moments_method=str(a["moments_method"]),
            sem=get(f"{o.name}_sem") if has(f"{o.name}_sem") else None, ci=ci,
            sobol_first=get(f"{o.name}_sobol_first") if has(f"{o.name}_sobol_first") else None,
            sobol_total=get(f"{o.name}_sobol_total") if has(f"{o.name}_sobol_total") else None,
            quantile_levels=tuple(float(p) for p in get("quantile")) if q else None,
            quantiles=get(f"{o.name}_quantile") if q else None,
            ci_quantiles=get(f"{o.name}_ci_quantile") if q else None,
        )
        first = f"{o.name}_sobol_first"
        if has(first):
            stats[o.name].sobol_estimator = str(attrs(first).get("estimator", "pce"))
            for kind in ("first", "total"):
                if has(f"{o.name}_sobol_{kind}_ci"):
                    setattr(stats[o.name], f"sobol_{kind}_ci", get(f"{o.name}_sobol_{kind}_ci"))
        if has(f"{o.name}_sobol_group_first") and has("group"):
            stats[o.name].sobol_groups = tuple(
                g.decode() if isinstance(g, bytes) else str(g) for g in get("group"))
            for kind in ("first", "total", "first_ci", "total_ci"):
                if has(f"{o.name}_sobol_group_{kind}"):
                    setattr(stats[o.name], f"sobol_group_{kind}",
                            get(f"{o.name}_sobol_group_{kind}"))
        if has(f"{o.name}_corrected"):
            cv, cci = get(f"{o.name}_corrected"), get(f"{o.name}_corrected_ci")
            stats[o.name].corrected = {n: cv[j] for j, n in enumerate(STAT_NAMES)}
            stats[o.name].corrected_ci = {n: cci[:, j] for j, n in enumerate(STAT_NAMES)}
        if has(f"{o.name}_fallback"):
            fb, fci = get(f"{o.name}_fallback"), get(f"{o.name}_fallback_ci")
            stats[o.name].fallback = {n: fb[j] for j, n in enumerate(STAT_NAMES)}
            stats[o.name].fallback_ci = {n: fci[:, j] for j, n in enumerate(STAT_NAMES)}
        if has(f"{o.name}_validation_error"):
            stats[o.name].validation_error = get(f"{o.name}_validation_error")
        if has(f"{o.name}_usable"):
            stats[o.name].usable = np.asarray(get(f"{o.name}_usable")).astype(bool)
    return stats
