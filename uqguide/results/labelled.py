"""A method's statistics as named, labelled arrays: the one description of the variables that
both the result file (format 2, a netCDF-4 group per method) and ``Result.to_xarray()`` use.

Per output ``o`` of ``k`` components (``...`` is ``time`` for a series, nothing for a scalar):

=======================  ==========================================  =========================
variable                 dims                                        what
=======================  ==========================================  =========================
``o``                    (statistic, ..., o_component)               mean, std, skewness,
                                                                     kurtosis (non-excess)
``o_cov``                (..., o_component, o_component2)            covariance
``o_sem``                (..., o_component)                          standard error of the mean
``o_ci``                 (bound, statistic, ..., o_component)        95% intervals (NaN where
                                                                     the method gives none)
``o_sobol_first/total``  (..., o_component, input)                   Sobol' indices (PCE)
``o_quantile``           (quantile, ..., o_component)                quantiles at the levels
``o_ci_quantile``        (bound, quantile, ..., o_component)         their 95% intervals
``o_corrected``          (statistic, ..., o_component)               a validated PCE's
                                                                     control-variate moments
``o_corrected_ci``       (bound, statistic, ..., o_component)        their 95% intervals
``o_validation_error``   (..., o_component)                          out-of-sample relative
                                                                     error of the surrogate
``o_usable``             (..., o_component)                          1 where the surrogate is
                                                                     usable (else its moments
                                                                     are NaN)
=======================  ==========================================  =========================

Coordinates: ``time`` [s], ``input`` (uncertain input names), ``statistic``, ``bound`` (low,
high), ``quantile`` (levels), ``o_component`` and ``o_component2`` (component names; a single
component is named ``""``). Each output has its own component dimension because outputs differ
in their number of components.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..stats.moments import STAT_NAMES, OutputStats

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
    """Name of an output's component dimension (the second one of a covariance).

    Parameters
    ----------
    output : str
    second : bool

    Returns
    -------
    str
        ``"<output>_component"`` or ``"<output>_component2"``.
    """
    return f"{output}_component2" if second else f"{output}_component"


def method_variables(stats: dict[str, OutputStats], outputs: Sequence[OutputInfo],
                     time: np.ndarray, input_names: Sequence[str]
                     ) -> tuple[dict[str, np.ndarray], dict[str, Variable]]:
    """Coordinates (dimension -> values) and variables of one method's statistics.

    Parameters
    ----------
    stats : dict of str to OutputStats
        By output name.
    outputs : sequence of OutputInfo
    time : ndarray, shape (T,)
        Time grid [s].
    input_names : sequence of str, length d

    Returns
    -------
    coords : dict of str to ndarray
        Values of each dimension (``time``, ``statistic``, ``input``, components, ...).
    variables : dict of str to Variable
        Per output: moments, covariance, intervals, Sobol' indices, quantiles, with units.
    """
    coords: dict[str, np.ndarray] = {
        "time": np.asarray(time, dtype=float),
        "input": np.array(input_names, dtype=object),
        "statistic": np.array(STAT_NAMES, dtype=object),
        "bound": np.array(BOUNDS, dtype=object),
    }
    out: dict[str, Variable] = {}
    for o in outputs:
        s = stats.get(o.name)
        if s is None:
            continue
        lead = ("time",) if o.kind == "series" else ()
        c, c2 = component_dim(o.name), component_dim(o.name, True)
        names = np.array(o.components, dtype=object)
        coords[c] = names
        coords[c2] = names
        base = (*lead, c)
        out[o.name] = Variable(
            ("statistic", *base), np.stack([s.stat(n) for n in STAT_NAMES]),
            {"units": o.unit, "long_name": o.description, "kind": o.kind,
             "n_used": int(s.n_used), "moments_method": s.moments_method})
        out[f"{o.name}_cov"] = Variable((*base, c2), s.cov, {"units": f"({o.unit})^2"})
        if s.sem is not None:
            out[f"{o.name}_sem"] = Variable(base, s.sem, {"units": o.unit})
        if s.ci:
            ci = np.full((2, len(STAT_NAMES), *s.mean.shape), np.nan)
            for j, n in enumerate(STAT_NAMES):
                if n in s.ci:
                    ci[:, j] = s.ci[n]
            out[f"{o.name}_ci"] = Variable(
                ("bound", "statistic", *base), ci,
                {"description": "95% interval", "statistics": [n for n in STAT_NAMES
                                                               if n in s.ci]})
        for kind in ("sobol_first", "sobol_total"):
            v = getattr(s, kind)
            if v is not None:
                out[f"{o.name}_{kind}"] = Variable((*base, "input"), v, {"units": "1"})
        table = s.quantile_table()
        if table is not None:
            levels = np.asarray(table[0], dtype=float)
            if "quantile" in coords and not np.array_equal(coords["quantile"], levels):
                raise ValueError(f"output {o.name!r} has quantile levels {levels.tolist()}, "
                                 f"another output {coords['quantile'].tolist()}")
            coords["quantile"] = levels
            out[f"{o.name}_quantile"] = Variable(("quantile", *base), table[1],
                                                 {"units": o.unit})
            out[f"{o.name}_ci_quantile"] = Variable(("bound", "quantile", *base),
                                                    table[2], {"units": o.unit})
        if s.corrected:
            out[f"{o.name}_corrected"] = Variable(
                ("statistic", *base), np.stack([s.corrected[n] for n in STAT_NAMES]),
                {"units": o.unit, "description": "control-variate estimates (PCE + mean "
                                                 "model-minus-surrogate on validation runs)"})
            out[f"{o.name}_corrected_ci"] = Variable(
                ("bound", "statistic", *base),
                np.stack([s.corrected_ci[n] for n in STAT_NAMES], axis=1),
                {"description": "95% interval from the validation runs (delta method, stratified)"})
        if s.validation_error is not None:
            out[f"{o.name}_validation_error"] = Variable(
                base, np.asarray(s.validation_error, dtype=float),
                {"units": "1", "description": "mean squared model-minus-surrogate difference "
                                              "over the model's variance, validation runs"})
        if s.usable is not None:
            out[f"{o.name}_usable"] = Variable(base, np.asarray(s.usable, dtype=np.uint8),
                                               {"units": "1"})
    return coords, out


def stats_from_variables(get: Any, has: Any, attrs: Any, outputs: Sequence[OutputInfo]
                         ) -> dict[str, OutputStats]:
    """The inverse of :func:`method_variables` (a file group or a Dataset alike).

    Parameters
    ----------
    get : callable
        ``get(name)``: the variable's array.
    has : callable
        ``has(name)``: whether it exists.
    attrs : callable
        ``attrs(name)``: its attributes.
    outputs : sequence of OutputInfo

    Returns
    -------
    dict of str to OutputStats
        By output name, for the outputs that have statistics.
    """
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
        if has(f"{o.name}_corrected"):
            cv, cci = get(f"{o.name}_corrected"), get(f"{o.name}_corrected_ci")
            stats[o.name].corrected = {n: cv[j] for j, n in enumerate(STAT_NAMES)}
            stats[o.name].corrected_ci = {n: cci[:, j] for j, n in enumerate(STAT_NAMES)}
        if has(f"{o.name}_validation_error"):
            stats[o.name].validation_error = get(f"{o.name}_validation_error")
        if has(f"{o.name}_usable"):
            stats[o.name].usable = np.asarray(get(f"{o.name}_usable")).astype(bool)
    return stats
