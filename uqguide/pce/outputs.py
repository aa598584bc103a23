"""From model outputs to expansion columns (``(n, T, k)`` or ``(n, k)`` flattened to ``m``
columns), and from fitted expansions to the statistics of every output (:func:`assemble`),
with the joint covariance of all scalars stacked (docs/statistics.md#statistics).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np

from ..errors import MethodError
from ..core.failures import reason_summary
from ..core.types import DerivedOutput, ModelOutput, OutputStats, ScalarIndex
from . import moments
from .derived import derived_statistics
from .expansion import Expansion
from .tails import surrogate_tails
from ..core.events import EventEstimate, EventSpec


@dataclass
class OutputColumns:
    """One output's runs as columns: ``y (n, m)`` and the shape ``(T, k)`` or ``(k,)``."""

    name: str
    kind: str
    y: np.ndarray
    shape: tuple[int, ...]


def output_columns(outputs: ModelOutput,
                   rows: np.ndarray | slice = slice(None)) -> list[OutputColumns]:
    """Series then scalar outputs of the selected runs, flattened to columns."""
    cols = []
    for kind, group in (("series", outputs.series), ("scalar", outputs.scalars)):
        for name, y in group.items():
            y = np.asarray(y[rows], dtype=float)
            cols.append(OutputColumns(name, kind, y.reshape(y.shape[0], -1), y.shape[1:]))
    return cols


def failure_summary(outputs: ModelOutput) -> str:
    """``"reason (count); ..."`` of the failed runs, most frequent first
    (:func:`uqguide.core.failures.reason_summary`)."""
    return reason_summary(outputs.reasons[outputs.failed])


def joint_scalar_moments(
    expansions: list[tuple[str, Expansion]]
) -> tuple[list[ScalarIndex], np.ndarray | None, np.ndarray | None]:
    """Names, mean ``(s,)`` and covariance ``(s, s)`` of all scalar outputs stacked.

    The expansions' coefficients are scattered onto the union of their multi-index sets, where
    ``cov = sum_{alpha != 0} c_alpha c_alpha^T`` (eq 22).
    """
    if not expansions:
        return [], None, None
    union: dict[tuple[int, ...], int] = {}
    for _, e in expansions:
        for a in map(tuple, e.alpha.tolist()):
            union.setdefault(a, len(union))
    names: list[ScalarIndex] = []
    blocks = []
    for name, e in expansions:
        c = np.zeros((len(union), e.n_columns))
        rows = [union[a] for a in map(tuple, e.alpha.tolist())]
        c[rows] = e.coef
        blocks.append(c)
        names += ScalarIndex.of(name, e.n_columns)
    coef = np.concatenate(blocks, axis=1)
    r0 = union[(0,) * expansions[0][1].alpha.shape[1]]
    mean = coef[r0]
    dev = np.delete(coef, r0, axis=0)
    return names, mean, dev.T @ dev


def assemble(
    fitted: list[tuple[OutputColumns, Expansion]], derived: Mapping[str, DerivedOutput],
    outputs: ModelOutput, *, n_runs: int, n_draws: int, seed: int, label: str,
    sampling: str = "random", levels: tuple[float, ...] | None = None,
    events: tuple[EventSpec, ...] = (), components: Mapping[str, tuple[str, ...]] | None = None,
    note: Callable[[str], None] | None = None,
) -> tuple[dict[str, OutputStats], list[ScalarIndex], np.ndarray | None, np.ndarray | None,
           dict[str, object], dict[str, EventEstimate]]:
    """Statistics of every output, and the stacked scalars' joint moments.

    ``fitted``: the outputs fitted directly; ``derived``: computed from fitted carriers
    (:mod:`uqguide.pce.derived`); ``outputs``: the runs (for the scalars' order); ``n_draws``,
    ``seed``, ``sampling``: surrogate draws where moments are sampled; ``levels``, ``events``,
    ``components``: quantiles and events from draws (:mod:`uqguide.pce.tails`). Returns stats,
    scalar names, scalar mean, scalar covariance, diagnostics, events.
    """
    stats = {}
    expansions = {}
    scalars = []
    for i, (col, exp) in enumerate(fitted):
        if note is not None:
            note(f"surrogate statistics of {col.name} ({i + 1}/{len(fitted)})")
        stats[col.name] = moments.output_statistics(exp, n_runs=n_runs, n_draws=n_draws,
                                                    seed=seed, sampling=sampling)
        expansions[col.name] = exp
        if col.kind == "scalar":
            scalars.append((col.name, exp))
    names, s_mean, s_cov = joint_scalar_moments(scalars)
    diag: dict[str, object] = {}
    if derived:
        for name, dv in derived.items():
            missing = [c for c in dv.carriers if c not in expansions]
            if missing:
                raise MethodError(f"{label}: output '{name}' is derived from "
                                  f"{', '.join(dv.carriers)}, but the runs have no "
                                  f"{', '.join(missing)}")
        order = [nm for nm in outputs.scalars if nm in expansions or nm in derived]
        order += [nm for nm, dv in derived.items() if dv.kind == "scalar" and nm not in order]
        d_stats, joint, n_invalid = derived_statistics(
            next(iter(expansions.values())).germ, expansions, derived, scalar_order=order,
            n_draws=n_draws, seed=seed, n_runs=n_runs, sampling=sampling)
        stats.update(d_stats)
        if joint is not None:
            names = [s for nm in order for s in ScalarIndex.of(nm, stats[nm].mean.shape[-1])]
            s_mean, s_cov = joint
            diag["scalar_moments"] = "surrogate-sampling"
        diag["derived"] = ", ".join(f"{nm} from {'+'.join(dv.carriers)}"
                                    for nm, dv in derived.items())
        diag["derived_invalid_draws"] = n_invalid
    return stats, names, s_mean, s_cov, diag, _tails(
        stats, expansions, derived, levels, events, components, n_draws, seed, sampling)


def _tails(stats: dict[str, OutputStats], expansions: dict[str, Expansion],
           derived: Mapping[str, DerivedOutput], levels: tuple[float, ...] | None,
           events: tuple[EventSpec, ...], components: Mapping[str, tuple[str, ...]] | None,
           n_draws: int, seed: int, sampling: str) -> dict[str, EventEstimate]:
    """Quantiles into ``stats`` and the events' probabilities, from surrogate draws."""
    if (levels is None and not events) or not expansions:
        return {}
    germ = next(iter(expansions.values())).germ
    quantiles, ev = surrogate_tails(germ, expansions, derived, levels=levels, events=events,
                                    components=components or {}, n_draws=n_draws, seed=seed,
                                    sampling=sampling)
    for name, (q, ci) in quantiles.items():
        if name in stats:
            stats[name].quantile_levels, stats[name].quantiles = levels, q
            stats[name].ci_quantiles = ci
    return ev
