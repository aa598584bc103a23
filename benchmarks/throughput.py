"""Throughput of the simulators: samples per second of "simulation plus statistics".

For each case and batch size: draw the inputs, evaluate the model on the whole batch, then
compute ``uqguide.stats.sample_statistics`` of every requested series (bootstrapped at the
report times and the last step, as the Monte Carlo method does) and of the scalar outputs
stacked into one vector (one set of bootstrap resamples for all of them).
Prints one table row per (case, batch): samples/s, model runs, failures, simulation and
statistics seconds, wall seconds, CPU seconds of the process (all threads; on a shared machine
the wall time depends on the other jobs, the CPU time much less) and the peak traced memory
(tracemalloc, in a second untimed run of the same batch: NumPy buffers and Python objects;
memory allocated inside compiled kernels is not traced).

Cases are dicts with keys ``label``, ``model`` (registered name), ``params`` (model parameters),
``inputs`` (marginal dicts as in a config's ``inputs``), ``outputs`` (list; empty: the model's
defaults), ``batches`` (list of ints) and optionally ``report_times``. The built-in FTCAPN case
is below; every ``benchmarks/cases_*.py`` module found next to this file adds its ``CASES``.

Usage::

    python benchmarks/throughput.py                       # every case, its own batch sizes
    python benchmarks/throughput.py --model ftcapn --batches 1000 100000
    python benchmarks/throughput.py --model ftcapn --param kernel=numpy --param threads=1

The structure (cases -> ``run_case`` -> rows) is meant to be routed through the real Monte
Carlo pipeline later: only ``run_case`` knows how a batch is evaluated and reduced.
"""

from __future__ import annotations

import argparse
import importlib.util
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import TypeAdapter

from uqguide.config import load_yaml
from uqguide.inputs import InputSpace, Marginal
from uqguide.registry import model_class
from uqguide.stats import sample_statistics

HERE = Path(__file__).resolve().parent

# the inputs of configs/ftcapn_table3.yaml, read from it so they cannot drift
FTCAPN_TABLE3 = load_yaml(HERE.parent / "configs" / "ftcapn_table3.yaml")["inputs"]

CASES: list[dict[str, Any]] = [
    {
        "label": "ftcapn table3",
        "model": "ftcapn",
        "params": {},
        "inputs": FTCAPN_TABLE3,
        # the LOS-rate series of the paper's Figures 6-17 and the default scalars at the stop
        "outputs": ["omega_s", "t_stop", "Rdot_stop", "speed_stop", "dv_total", "zem_eq15",
                    "zem"],
        "report_times": [0.0, 20.0, 40.0, 60.0],
        "batches": [1_000, 10_000, 100_000],
    },
]

BOOTSTRAP = 200


def discover_cases() -> list[dict[str, Any]]:
    """The built-in cases plus ``CASES`` of every ``benchmarks/cases_*.py`` module."""
    cases = list(CASES)
    for path in sorted(HERE.glob("cases_*.py")):
        spec = importlib.util.spec_from_file_location(f"benchmarks_{path.stem}", path)
        if spec is None or spec.loader is None:
            continue
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        cases.extend(getattr(module, "CASES", []))
    return cases


def _ci_index(time_grid: np.ndarray, report_times: list[float] | None) -> np.ndarray | None:
    if time_grid.size == 0:
        return None
    idx = [int(np.argmin(np.abs(time_grid - t))) for t in (report_times or [])]
    return np.unique(idx + [time_grid.size - 1])


def _evaluate_and_reduce(model, x, names, outputs, report_times, bootstrap, seed):
    """One batch: the model, then the statistics the Monte Carlo method computes."""
    t0 = time.perf_counter()
    out = model.evaluate(x, names, outputs)
    t1 = time.perf_counter()
    ok = ~out.failed
    keep = slice(None) if ok.all() else ok  # a boolean mask would copy every series
    idx = _ci_index(out.time, report_times)
    for y in out.series.values():
        sample_statistics(y[keep], bootstrap=bootstrap, seed=seed, ci_index=idx)
    if out.scalars:
        # the scalars as one stacked vector (uq-methods.md section 3): one set of resamples
        stacked = np.concatenate([y[keep] for y in out.scalars.values()], axis=1)
        sample_statistics(stacked, bootstrap=bootstrap, seed=seed)
    return out, t1 - t0, time.perf_counter() - t1


def run_case(case: dict[str, Any], n: int, seed: int = 1, bootstrap: int = BOOTSTRAP,
             memory: bool = True) -> dict[str, Any]:
    """Evaluate one batch of ``n`` samples and reduce it to statistics; timings and memory.

    The timed run is not traced: tracemalloc costs microseconds per allocation, which would
    distort a kernel that allocates many small temporaries. The peak memory comes from a
    second, traced, untimed run of the same batch.
    """
    model = model_class(case["model"])(case.get("params") or {})
    adapter = TypeAdapter(Marginal)
    space = InputSpace([adapter.validate_python(m) for m in case["inputs"]])
    outputs = case.get("outputs") or list(model.default_outputs())
    x = space.from_unit(np.random.default_rng(seed).random((n, space.dim)))
    args = (model, x, space.names, outputs, case.get("report_times"), bootstrap, seed)
    _evaluate_and_reduce(model, x[:2], *args[2:])  # JIT compilation, nominal grid, caches
    c0 = time.process_time()
    out, sim_s, stats_s = _evaluate_and_reduce(*args)
    cpu_s = time.process_time() - c0
    failed = int(out.failed.sum())
    del out
    peak = float("nan")
    if memory:
        tracemalloc.start()
        _evaluate_and_reduce(*args)
        peak = tracemalloc.get_traced_memory()[1] / 2**20
        tracemalloc.stop()
    wall = sim_s + stats_s
    return {
        "label": case["label"], "model": case["model"], "batch": n,
        "samples_per_s": n / wall, "runs": n, "failed": failed,
        "sim_s": sim_s, "stats_s": stats_s, "wall_s": wall, "cpu_s": cpu_s, "peak_mb": peak,
    }


def format_table(rows: list[dict[str, Any]]) -> str:
    head = (f"{'case':<24} {'model':<12} {'batch':>8} {'samples/s':>10} {'runs':>8} "
            f"{'failed':>6} {'sim s':>7} {'stats s':>7} {'wall s':>7} {'cpu s':>7} {'peak MB':>8}")
    lines = [head, "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['label']:<24} {r['model']:<12} {r['batch']:>8d} {r['samples_per_s']:>10.4g} "
            f"{r['runs']:>8d} {r['failed']:>6d} {r['sim_s']:>7.3f} {r['stats_s']:>7.3f} "
            f"{r['wall_s']:>7.3f} {r['cpu_s']:>7.3f} {r['peak_mb']:>8.1f}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--model", action="append", help="only cases of this model (repeatable)")
    ap.add_argument("--batches", type=int, nargs="+", help="batch sizes (default: per case)")
    ap.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                    help="override a model parameter (YAML value), e.g. kernel=numpy")
    ap.add_argument("--bootstrap", type=int, default=BOOTSTRAP, help="bootstrap resamples")
    ap.add_argument("--no-memory", action="store_true", help="do not trace memory")
    ap.add_argument("--no-scale", action="store_true",
                    help="skip the 1e6-sample FTCAPN runs on 1 and 2 processes (benchmarks/scale.py)")
    args = ap.parse_args(argv)
    overrides = {}
    for item in args.param:
        key, sep, value = item.partition("=")
        if not sep:
            ap.error(f"--param expects KEY=VALUE, got {item!r}")
        overrides[key] = yaml.safe_load(value)
    cases = [c for c in discover_cases() if not args.model or c["model"] in args.model]
    if not cases:
        ap.error(f"no benchmark case for model(s) {args.model}")
    rows = []
    for case in cases:
        case = {**case, "params": {**(case.get("params") or {}), **overrides}}
        for n in args.batches or case["batches"]:
            rows.append(run_case(case, n, bootstrap=args.bootstrap, memory=not args.no_memory))
            print(format_table(rows[-1:]).splitlines()[-1], file=sys.stderr, flush=True)
    print(format_table(rows))
    if not args.no_scale and (not args.model or "ftcapn" in args.model):
        # The campaign-scale figures (1e6 samples: wall time, peak memory, 2-process speed-up)
        # run in fresh processes so their memory peaks are their own.
        print("", flush=True)
        subprocess.run([sys.executable, str(Path(__file__).with_name("scale.py"))], check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
