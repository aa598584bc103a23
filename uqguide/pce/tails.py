"""Quantiles and event probabilities of PCE surrogates, from surrogate draws
(:func:`surrogate_tails`), and the events corrected by validation runs
(:func:`control_variate_events`).

A series keeps at most :data:`SERIES_FLOATS` values (the first draws; ``n_used`` says how
many). The draws' intervals measure how well they know the *surrogate's* tails, not how well
the surrogate knows the model's: docs/pce.md#events-corrected-by-the-validation-runs.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ..core.events import EventEstimate, EventSpec, component_index, count_events
from ..core.types import DerivedOutput
from ..stats.quantiles import order_statistic_quantiles
from .design import surrogate_draws
from .expansion import Expansion
from .germ import Germ
from .surrogate import Surrogate
from .validation_design import ValidationDesign, random_design_of

SERIES_FLOATS = 2**24
_CHUNK_FLOATS = 2**22


def surrogate_tails(
    germ: Germ, expansions: Mapping[str, Expansion], derived: Mapping[str, DerivedOutput], *,
    levels: tuple[float, ...] | None, events: tuple[EventSpec, ...],
    components: Mapping[str, tuple[str, ...]], n_draws: int,
    seed: int | np.random.SeedSequence, sampling: str = "random",
) -> tuple[dict[str, tuple[np.ndarray, np.ndarray]], dict[str, EventEstimate]]:
    """Quantiles ``{output: (values (q, *shape), ci (2, q, *shape))}`` of every fitted and
    derived output (when ``levels``) and the events' probabilities over the draws."""
    wanted = set(expansions) | set(derived) if levels is not None else set()
    wanted |= {e.output for e in events}
    shapes = {n: e.shape for n, e in expansions.items()}
    series_cols = sum(int(np.prod(shapes[n])) for n in wanted
                      if n in shapes and len(shapes[n]) == 2)
    n_series = n_draws if series_cols * n_draws <= SERIES_FLOATS else \
        max(4096, SERIES_FLOATS // max(series_cols, 1))
    width = sum(e.n_columns for e in expansions.values())
    chunk = max(256, _CHUNK_FLOATS // max(width, 1))
    kept: dict[str, list[np.ndarray]] = {n: [] for n in wanted}
    ok_all: list[np.ndarray] = []
    seen = 0
    sur = Surrogate(germ, dict(expansions), derived)
    for u in surrogate_draws(germ.dim, n_draws, seed, chunk, sampling):
        values = sur.at_unit(u, list(wanted))
        m = u.shape[0]
        ok = np.ones(m, dtype=bool)
        for name in wanted - expansions.keys():  # a derived value may be undefined
            ok &= np.isfinite(values[name].reshape(m, -1)).all(axis=1)
        ok_all.append(ok)
        for name in wanted:
            v = values[name]
            if v.ndim == 3:
                take = max(0, min(m, n_series - seen))
                if take:
                    kept[name].append(v[:take][ok[:take]])
            else:
                kept[name].append(v)
        seen += m
    ok = np.concatenate(ok_all) if ok_all else np.zeros(0, dtype=bool)
    quantiles = {}
    if levels is not None:
        for name in expansions.keys() | derived.keys():
            if name not in kept:
                continue
            v = np.concatenate(kept[name], axis=0)
            if v.ndim == 2:
                v = v[ok]
            quantiles[name] = order_statistic_quantiles(v, levels)
    ev = {}
    if events:
        scal = {e.output: np.concatenate(kept[e.output], axis=0) for e in events}
        ev = count_events(list(events), scal, ok, dict(components), estimator="surrogate")
    return quantiles, ev


def surrogate_values(germ: Germ, expansions: Mapping[str, Expansion],
                     derived: Mapping[str, DerivedOutput], name: str,
                     u: np.ndarray) -> np.ndarray:
    """The surrogate's values ``(n, *shape)`` of output ``name`` (fitted or derived) at unit-cube
    points ``u (n, d)``."""
    return Surrogate(germ, dict(expansions), derived).at_unit(u, [name])[name]


def control_variate_events(
    surrogate: Mapping[str, EventEstimate], events: tuple[EventSpec, ...],
    components: Mapping[str, tuple[str, ...]], model_values: Mapping[str, np.ndarray],
    surrogate_at_validation: Mapping[str, np.ndarray], ok: np.ndarray,
    design: ValidationDesign | None = None,
) -> dict[str, EventEstimate]:
    """Events corrected by a validation set of model runs (the surrogate as control variate),
    with a distribution-free interval (docs/pce.md#events-corrected-by-the-validation-runs).
    ``ok (n,)``: the runs that succeeded; ``design``: of all runs (default random).
    """
    from ..core.events import clopper_pearson

    n_all = int(np.asarray(ok).size)
    used = (design if design is not None
            else random_design_of(np.zeros((n_all, 0)))).successful(ok)
    strata = [k for k in range(used.share.size)
              if used.share[k] > 0 and np.any(used.stratum == k)]
    level = 1.0 - 0.05 / (1.0 + 2.0 * len(strata))
    ratio, bounds = used.ratios(), used.ratio_bounds()
    out = {}
    for spec in events:
        s = surrogate.get(spec.name)
        if s is None or not strata:
            continue
        c = component_index(spec, tuple(components.get(spec.output, ("",))))
        im = spec.indicator(np.asarray(model_values[spec.output])[ok, c])
        isur = spec.indicator(np.asarray(surrogate_at_validation[spec.output])[ok, c])
        d_lo, d_hi = clopper_pearson(s.n_in, s.n_used, level)
        p, lo, hi, var = s.probability, d_lo, d_hi, 0.0
        for k in strata:
            rows = used.stratum == k
            nk, wk = int(rows.sum()), float(used.share[k])
            r_lo, r_hi = bounds[k]
            n_plus = int(np.sum(im[rows] & ~isur[rows]))
            n_minus = int(np.sum(~im[rows] & isur[rows]))
            plus = clopper_pearson(n_plus, nk, level)
            minus = clopper_pearson(n_minus, nk, level)
            diff = (im[rows].astype(float) - isur[rows].astype(float)) * ratio[rows]
            p += wk * float(diff.mean())
            lo += wk * (r_lo * plus[0] - r_hi * minus[1])
            hi += wk * (r_hi * plus[1] - r_lo * minus[0])
            var += wk**2 * float(diff.var(ddof=1)) / nk if nk > 1 else 0.0
        n = int(np.sum(ok))
        cov = float(np.sqrt(var) / p) if p > 0 and n > 1 else float("nan")
        out[spec.name] = EventEstimate(spec.name, spec.describe(), float(min(max(p, 0.0), 1.0)),
                                       (max(0.0, lo), min(1.0, hi)), int(im.sum()), n,
                                       "surrogate+cv", cov)
    return out
