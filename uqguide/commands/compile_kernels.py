"""Compile the simulators' kernels once, up front: ``uqguide compile``.

A compiled kernel is built on its first call and then loaded from numba's cache; paying that
once on purpose suits a container build, a cluster job array and anything timed. Each study's
model runs once on two samples at its nominal inputs, and the statistics kernel is compiled
too. What it costs, and why running the studies is what compiles their specialisations:
``docs/performance.md#the-first-run-compile``.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..config.catalog import resolve, studies
from ..config.run_config import load_config
from ..models import kernels


@dataclass(frozen=True)
class Compiled:
    """What one study's model cost: its compile (a cache miss), and the whole run of it."""

    study: str
    model: str
    kernel: str           # "numba", "numpy" (nothing to compile) or "" (no kernel choice)
    compile_s: float      # wall seconds compiling; 0.0 when the cache had it
    total_s: float        # wall seconds of the two-sample run, compile included
    compile_cpu_s: float  # the same two in CPU seconds, as printed: a loaded machine's wall
    total_cpu_s: float    # clock overstates them (the docs quote CPU-s)


def compile_kernels(configs: Sequence[str | Path] = ()) -> list[Compiled]:
    """Run each study's model once so that its compiled kernel is built and cached.

    ``configs``: config files or shipped study names (empty: every shipped study). One row per
    model (with its parameters) not met before, then one for the statistics kernel (study
    ``"-"``); ConfigError for a config that cannot be loaded.
    """
    paths = [resolve(c) for c in configs] if configs else [s.path for s in studies()]
    rows: list[Compiled] = []
    seen: set[str] = set()
    for path in paths:
        cfg = load_config(path)
        model = cfg.model
        key = json.dumps([model.name, model.params.model_dump(mode="json")], sort_keys=True,
                         default=str)
        if key in seen:
            continue
        seen.add(key)
        choice = model.kernel_choice()
        started, compiled = time.perf_counter(), kernels.compile_seconds()
        started_cpu, compiled_cpu = time.process_time(), kernels.compile_cpu_seconds()
        if choice == "numba":
            # the study's uncertain inputs, as its runs pass them: the arrays' types and
            # memory layouts are what numba specialises on
            nominal = {i.name: i.nominal for i in model.inputs()}
            names = cfg.space.names
            x = np.array([[nominal[nm] for nm in names]] * 2)
            model.evaluate(x, names, cfg.outputs or None)
        rows.append(Compiled(Path(path).stem, model.name, choice or "",
                             kernels.compile_seconds() - compiled,
                             time.perf_counter() - started,
                             kernels.compile_cpu_seconds() - compiled_cpu,
                             time.process_time() - started_cpu))
    rows.append(_statistics_kernel())
    return rows


def _statistics_kernel() -> Compiled:
    # Both kernels (column sums, comoment sums), with the high orders; float64 C arrays are
    # the only types the statistics pass them. They sit below the models' compile clock
    # (stats does not import models), so a cache miss is read from numba's own counters.
    from ..stats.moments import MomentSums

    started, started_cpu = time.perf_counter(), time.process_time()
    MomentSums.of(np.zeros((2, 2)), comoments=True, high=True)
    took, took_cpu = time.perf_counter() - started, time.process_time() - started_cpu
    from ..stats.moment_sums_kernel import column_sums, comoment_sums

    missed = sum(len(k.stats.cache_misses) for k in (column_sums, comoment_sums))
    return Compiled("-", "moment sums", "numba", took if missed else 0.0, took,
                    took_cpu if missed else 0.0, took_cpu)


def format_compiled(rows: Sequence[Compiled]) -> str:
    """The table ``uqguide compile`` prints: one line per study (CPU seconds), then the
    total, in CPU and wall seconds."""
    width = max([len(r.study) for r in rows] + [5])
    lines = [f"{'study':<{width}}  {'model':<14}  {'kernel':<6}  {'compile CPU-s':>13}  "
             f"{'run CPU-s':>9}"]
    for r in rows:
        kernel = r.kernel or "-"
        lines.append(f"{r.study:<{width}}  {r.model:<14}  {kernel:<6}  "
                     f"{r.compile_cpu_s:>13.1f}  {r.total_cpu_s:>9.1f}")
    cpu, wall = sum(r.compile_cpu_s for r in rows), sum(r.compile_s for r in rows)
    lines.append(f"compiled in {cpu:.1f} CPU-s ({wall:.1f} s wall); every kernel is now in the "
                 f"cache ({kernels.cache_dir() or 'beside the package sources'})")
    return "\n".join(lines)
