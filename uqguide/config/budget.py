"""Time and memory budgets, checked before anything runs.

Per method the model runs, the steps of one run and an estimate of the driver's peak memory
(:func:`estimate`, printed by ``validate`` and ``run``). Refused before anything is allocated
(ConfigError, exit 2): an estimate above ``max_memory`` (:func:`check_memory`), surrogate draws
over :data:`MAX_SURROGATE_TERMS` term evaluations (:func:`check_surrogate`); a run over
``max_steps`` steps is refused by :func:`uqguide.config.limits.check_steps`. What the estimate
counts: docs/scale.md#what-the-memory-estimate-counts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from ..errors import ConfigError
from .limits import BASE_BYTES, human

if TYPE_CHECKING:
    from .run_config import RunConfig

@dataclass(frozen=True)
class MethodBudget:
    label: str
    runs: int | None
    steps_per_run: float | None
    peak_bytes: float | None
    parts: dict[str, float]
    exact: bool = True
    #: The method's ``surrogate_draws`` (0: it draws none) and the basis terms of a draw.
    surrogate_draws: int = 0
    surrogate_terms: int = 0
    #: Where the method sits in the config (``methods[i]``), for a refusal's field.
    index: int = 0

    @property
    def surrogate_work(self) -> float:
        """Basis-term evaluations of the surrogate's draws (its terms and
        :data:`DRAW_OVERHEAD_TERMS` a draw)."""
        return float(self.surrogate_draws) * (self.surrogate_terms + DRAW_OVERHEAD_TERMS)


@dataclass(frozen=True)
class Budget:
    methods: list[MethodBudget]
    max_memory: int
    workers: int
    #: The runs of a ``data:`` file, held by the model (0 for a simulator), and the copies of
    #: them alive at once: the driver's, and with workers one per chunk in flight (the model
    #: travels whole with each chunk).
    data_bytes: float = 0.0
    data_copies: int = 1

    @property
    def peak_bytes(self) -> float:
        """Kept data adds up over methods (the result holds them all); transients do not."""
        kept = sum(sum(m.parts.get(p, 0.0) for p in KEPT_PARTS) for m in self.methods) + \
            self.data_bytes * self.data_copies
        transient = max((sum(m.parts.get(p, 0.0) for p in TRANSIENT_PARTS)
                         for m in self.methods), default=0.0)
        return kept + transient + BASE_BYTES

    def lines(self) -> list[str]:
        """The budget for the console: one line per method, then the peak memory."""
        out = []
        for m in self.methods:
            runs = "runs unknown until the design is built" if m.runs is None \
                else f"{'' if m.exact else 'up to '}{m.runs:,} model runs"
            steps = "" if m.steps_per_run is None else f" x {m.steps_per_run:,.0f} steps"
            mem = "" if m.peak_bytes is None else f", ~{human(m.peak_bytes)} " + \
                "(" + ", ".join(f"{k} {human(v)}" for k, v in m.parts.items() if v) + ")"
            out.append(f"  {m.label}: {runs}{steps}{mem}")
        if self.data_bytes:
            copies = f" x {self.data_copies} copies" if self.data_copies > 1 else ""
            out.append(f"  data table: {human(self.data_bytes)}{copies}")
        out.append(f"  estimated peak memory {human(self.peak_bytes)} of max_memory "
                   f"{human(self.max_memory)}")
        return out


#: The parts of a method's estimate held until the run ends, and those alive for one chunk.
KEPT_PARTS = ("kept", "series kept", "quantiles kept", "bootstrap sums", "sensitivity kept")
TRANSIENT_PARTS = ("per chunk", "basis", "bootstrap per chunk", "sensitivity")
#: What one surrogate draw costs beside its basis terms, in term evaluations.
DRAW_OVERHEAD_TERMS = 50
#: Largest surrogate work of one method, in term evaluations (:func:`check_surrogate`).
MAX_SURROGATE_TERMS = 5e9


def estimate(cfg: RunConfig, workers: int = 1, batch_size: int | None = None) -> Budget:
    """The budget of ``cfg`` (module docstring), without building any design: per method, model
    runs, steps per run and the estimated memory [bytes] by part; ``workers``: chunks in flight
    at once; ``batch_size``: samples per model call (default the config's)."""
    model = cfg.model
    count = model.step_count()
    grid = count.grid if count is not None else 0.0
    infos = [model.output_info(o) for o in cfg.outputs]
    k_scalar = sum(i.k for i in infos if i.kind == "scalar")
    k_series = sum(i.k for i in infos if i.kind == "series")
    d = cfg.space.dim
    bs = batch_size or cfg.raw.batch_size
    in_flight = 1 if workers <= 1 else 2 * workers
    rows = []
    for index, method in enumerate(cfg.methods):
        plan = method.plan(cfg.space)
        draws = int(getattr(method.settings, "surrogate_draws", 0) or 0)
        # a fitted basis has at most one term per run
        terms = min(plan.terms, plan.runs) if plan.runs is not None else plan.terms
        if plan.runs is None:
            rows.append(MethodBudget(method.label, None, count.steps if count else None, None,
                                     {}, surrogate_draws=draws, surrogate_terms=terms,
                                     index=index))
            continue
        n = plan.runs
        chunk = min(plan.chunk or bs, n)
        boot = getattr(method.settings, "bootstrap", 0) or 0
        per_chunk = chunk * (8.0 * d + 4 * 8.0 * grid * k_series + 8.0 * boot + 9.0)
        reduced = not method.holds_runs  # its series are never kept whole
        parts = {
            # reduced chunks are copied into arrays allocated once; others joined (twice)
            "kept": (1 if reduced else 2) * n * (8.0 * k_scalar + 9.0 +
                                                 (0 if reduced else 8.0 * d)),
            "per chunk": per_chunk * (1 if workers <= 1 else in_flight / 2),
            "series kept": 0.0 if reduced else 2 * n * 8.0 * grid * k_series,
            "basis": 3 * 8.0 * n * plan.terms,
        }
        sums = _bootstrap_sums(method, cfg, k_scalar, k_series, grid)
        if sums:
            parts["bootstrap sums"] = 2 * sums
            parts["bootstrap per chunk"] = 3 * sums * (1 if workers <= 1 else in_flight / 2)
        if reduced and k_series and method.context.quantile_levels is not None:
            # exact quantiles keep every good run's series values (at every step while that
            # stays small, else at the report times and the last step), per chunk and joined
            from ..methods.monte_carlo import QUANTILE_ALL_FLOATS

            steps = grid if n * grid * k_series <= QUANTILE_ALL_FLOATS else \
                len(cfg.raw.report_times or ()) + 1
            parts["quantiles kept"] = 2 * n * 8.0 * steps * k_series
        if method.sensitivity_for(cfg.space, n):
            report_steps = len(cfg.raw.report_times or ()) + 1
            series = n * 8.0 * report_steps * k_series
            if k_series and method.context.quantile_levels is None:
                parts["sensitivity kept"] = 2 * series
            parts["sensitivity"] = n * 12.0 * d + series
        rows.append(MethodBudget(method.label, n, count.steps if count else None,
                                 sum(parts.values()), parts, plan.exact,
                                 surrogate_draws=draws, surrogate_terms=terms, index=index))
    return Budget(rows, cfg.max_memory, workers, _data_bytes(model),
                  1 + (in_flight if workers > 1 else 0))


def _data_bytes(model: object) -> float:
    """Bytes of a data model's table: its columns, 8 a value, and its text (0 otherwise)."""
    from ..models.data_rows import DataModel
    from ..models.data_rows.claims import TEXT_CELL_BYTES

    table = model.table if isinstance(model, DataModel) else None
    if table is None:
        return 0.0
    text = 0.0 if table.reasons is None else \
        sum(TEXT_CELL_BYTES + len(r) for r in table.reasons)
    flags = 0.0 if table.flagged is None else float(table.flagged.nbytes)
    return float(sum(v.nbytes for v in table.columns.values())) + text + flags


def _bootstrap_sums(method: object, cfg: RunConfig, k_scalar: int, k_series: int,
                    grid: float) -> float:
    """Bytes of one set of a Monte Carlo method's bootstrap power sums (0 without them)."""
    settings = getattr(method, "settings", None)
    boot = getattr(settings, "bootstrap", 0) or 0
    kind = getattr(settings, "intervals", None)
    if kind not in ("bootstrap", "studentized") or boot <= 0:
        return 0.0
    steps = grid if getattr(settings, "bootstrap_times", "report") == "all" else \
        len(cfg.raw.report_times or ()) + 1
    columns = k_scalar + k_series * steps
    # the studentised bootstrap keeps the central sums of orders 5-8 too
    return (8 if kind == "studentized" else 4) * 8.0 * boot * columns


#: The setting that shrinks each part of the estimate, named when the budget refuses a run.
LOWER = {
    "kept": "n_samples (or the scalar outputs kept)",
    "per chunk": "chunk_size or batch_size",
    "series kept": "n_samples or the series outputs",
    "quantiles kept": "quantiles (or n_samples)",
    "bootstrap sums": "bootstrap (the resamples), or bootstrap_times: report, or intervals: "
                      "delta",
    "bootstrap per chunk": "bootstrap (the resamples), or bootstrap_times: report, or "
                           "intervals: delta",
    "basis": "the PCE's degree or its runs",
    "sensitivity kept": "sensitivity: off (or n_samples, or fewer report_times)",
    "sensitivity": "sensitivity: off (or n_samples)",
}


def check_budget(budget: Budget) -> None:
    """ConfigError (exit 2) when a run is over its budget: memory (:func:`check_memory`) or a
    surrogate's draws (:func:`check_surrogate`)."""
    check_memory(budget)  # first: a basis too large to hold is the more basic refusal
    check_surrogate(budget)


def check_surrogate(budget: Budget) -> None:
    """ConfigError (exit 2) naming the first method whose surrogate draws exceed
    :data:`MAX_SURROGATE_TERMS`, by how much, and the ``surrogate_draws`` that would fit."""
    for m in budget.methods:
        work = m.surrogate_work
        if work <= MAX_SURROGATE_TERMS:
            continue
        per_draw = m.surrogate_terms + DRAW_OVERHEAD_TERMS
        fits = int(MAX_SURROGATE_TERMS // per_draw)
        field = f"methods[{m.index}].surrogate_draws"
        raise ConfigError(
            f"{field}: {m.label}'s {m.surrogate_draws:.3g} surrogate draws need an estimated "
            f"{work:.3g} basis-term evaluations ({m.surrogate_terms} terms + "
            f"{DRAW_OVERHEAD_TERMS} a draw), {work / MAX_SURROGATE_TERMS:.3g} times the limit "
            f"of {MAX_SURROGATE_TERMS:.3g} (about ten minutes of one core); lower "
            f"surrogate_draws to at most {fits:,}", field=field)


def check_memory(budget: Budget) -> None:
    """ConfigError (exit 2) when the estimate exceeds ``max_memory``."""
    if budget.peak_bytes > budget.max_memory:
        worst = max((m for m in budget.methods if m.peak_bytes is not None),
                    key=lambda m: m.peak_bytes or 0.0, default=None)
        who, lower = "", "n_samples / chunk_size / the grid"
        if worst is not None:
            part, size = max(worst.parts.items(), key=lambda kv: kv[1])
            who = f" ({worst.label}: {worst.runs:,} runs; its largest part, {part}, " \
                  f"{human(size)})"
            lower = LOWER.get(part, lower)
        over = budget.peak_bytes - budget.max_memory
        raise ConfigError(
            f"max_memory: this run needs an estimated {human(budget.peak_bytes)}{who}, "
            f"{human(over)} more than max_memory = {human(budget.max_memory)}; lower {lower}, "
            f"or raise max_memory if the machine has it", field="max_memory")
