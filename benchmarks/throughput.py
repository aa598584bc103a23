"""Throughput of the simulators: samples per second of "simulation plus statistics".

For each case and batch size: draw the inputs, evaluate the model on the whole batch, then
reduce it as the Monte Carlo method reduces a chunk (:class:`MonteCarloReducer`: moment sums,
intervals at the report times and the last step, delta method or ``--intervals bootstrap``)
and compute the statistics from the sums.
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
    python benchmarks/throughput.py --model ftcapn --param threads=1

The structure (cases -> ``run_case`` -> rows) is meant to be routed through the real Monte
Carlo pipeline later: only ``run_case`` knows how a batch is evaluated and reduced.

Roofline
--------
A second table puts each case's simulation beside the floor its arithmetic allows. Columns:
samples per CPU-second of the simulation alone (``time.process_time``: every thread's CPU time,
so a threaded kernel is not flattered by the cores it borrows), ns of CPU time per
sample-step, the floor in ns per sample-step and the ratio measured / floor (1 would be a
kernel at the machine's peak). Load (``os.getloadavg``) is printed beside: on a shared machine
CPU time still grows with contention (caches, SMT), so acceptance figures are for an idle one.

The floor of one sample-step is ``max(F / peak_flops, B / bandwidth)`` with ``F`` the
flop-equivalents and ``B`` the bytes of main-memory traffic of one step of one sample
(:data:`LOOP_COUNTS`), ``peak_flops`` the fused-multiply-add throughput of one core measured by
:func:`calibrate` (a compiled loop of independent ``y = a y + b`` chains across a vector in L1:
what the SIMD units deliver when nothing else limits them) and ``bandwidth`` one core's
streaming write-and-read rate over 256 MB (NumPy ``multiply`` into a preallocated array).
Flop-equivalents: an add, a multiply, a compare-and-select or a fused multiply-add half counts
1; a division or a square root counts 8 (their vector throughput on x86 cores of the last
decade is 4-8x below an FMA's per lane); ``exp``, ``log`` and ``pow`` count 20 each (a vector
polynomial of ~10 FMAs plus range reduction). Counts, per sample-step (derived from the loops
of each kernel; they round to the nearest ten and are good to about +-30 %):

- ``ftcapn`` (a step = one ``dt`` of the discrete-time loop, the steps a sample takes until it
  stops): range and its rate, LOS unit vector, transverse velocity and LOS rate (~35 add/mul,
  2 sqrt, 1 div); sliding variable, saturated sign, reaching law with ``|s|^eta`` (~15 add/mul,
  1 pow); radial/transverse command and its vector (~20, 1 div, 1 sqrt for ``|a_c|``); exact
  double-integrator update (12); stop and pass tests (~15); delta-v and peak (3). About 100
  add/mul + 5 div/sqrt (40) + 1 pow (20) = 160. Memory: the series written per step (8 bytes
  per recorded component, ``omega_s`` and ``R`` in Table 3: 16 B); the state lives in cache.
- ``gmm_proximity`` (a step = one RK4 sub-step, 10 per 1 s control period). Per sub-step: the
  three position rows of the sub-step map ``phi (6x6) x + gam (6x3) u`` (51; the velocity rows
  only at the period's end, 5 per sub-step), the squared range and its minimum (6), per chief
  part (5) the squared box distance and its minimum (~18), the body's depth (13), the period's
  bounding box (6) and the swept-box overlap tests amortised (3): about 175. Per control
  period, shared by its 10 sub-steps: the potential's 10 Gaussian kernels at ~80 each (3x3
  quadratic form, ``exp``, gradient and Hessian: 800) and the NTSMC law (~250 add/mul, 6 ``pow``,
  3 ``sqrt``, 3 divisions, the saturation's and delta-v's 2 ``sqrt`` and a division: ~440),
  so 125 per sub-step. About 300. Memory: 8 B per recorded state component every 100
  sub-steps: negligible. (An earlier count, 450, charged all six map rows and a ``sqrt`` per
  part at every sub-step; the loop needs neither: intermediate velocities are never used, and
  the minimum of square roots is the square root of the minimum. Every Gaussian kernel is
  counted although the kernel skips the ``exp`` and the sums where it underflows to zero: 93 %
  of them along case E's paths, 3 % along F2's.)
- ``gmm_ftc`` (a step = one 0.1 s control period = one RK4 step), recounted on the blocked
  kernel's loop: the 12-kernel potential with its third derivative along ``v`` (axis-aligned
  kernels, as in Table 2: quadratic form 11, ``exp`` 20, value, gradient, Hessian and third
  derivative sums ~60: ~90 per kernel, 1,100); the law (matrix-vector products, ``g``, ``H``,
  ``gamma``, ``s1``, ``s2``: ~275; the reaching law's 3 ``pow`` and 3 ``x sqrt(x)``: ~100;
  the 3x3 Cramer solve with 3 divisions: ~85; 460); five plant right-hand sides (one for the
  law, four RK4 stages; crosses and four 3x3 products: ~108 each, 540) and the RK4
  combinations (~65); the attitude at two half-steps (per-sample spin: sqrt, 3 divisions,
  sin, cos, Rodrigues and ``C0 R``: ~150 each, 300; a common spin: computed once per block,
  ~0); geometry per sub-step (5 box distances with a sqrt ~29 each, segment half-length and
  range: ~175) and metrics (4 norms, threshold and extremum updates: ~80). About 2,400 (common
  spin) to 2,700 (per-sample spin); the count of 2,600 made before the kernel was rewritten
  (with a general 3x3 ``L`` per kernel, ~150 each) is inside that range and stays. The ``exp``
  of a kernel whose weight underflows is skipped at run time (most of the 12 for most
  samples), which the count ignores: a floor without the 12 exps would be about 2,350.
- ``ft_as`` (a step = one RK4 step of the 6-DOF loop of the FT-AS controller), counted on the
  kernel's loop: four right-hand sides, each the MRP kinematics and tracking terms (~180),
  the differential gravity (~30 + 1 sqrt + 2 div = 55), the true body accelerations with the
  adjugate solve (~90 + 1 div = 100), mass and force (~15 + 1 div = 25) and the observer (M u
  with 3 div, norms, ``lam1 |eps|^(1/2) + lam2 |eps|^p`` with 2 sqrt + log + exp, 1 div,
  ~90 add/mul = 175): ~530, so 2,120; the law once per step, per channel 4 log + 5 exp (the
  fractional powers share their logarithms), 5 div and ~30 add/mul = 250, so 1,500 with ~60
  for ``M^-1``; the input saturation (6 tanh + 6 div = 170); the stage combination and the
  finiteness test (3 x 72 + 180 + 36 = ~430); metrics (7 norms, 35 tolerance tests, peaks,
  envelope: ~220); the time-only terms, once per step for a block of samples (~500 per block,
  ~40 per sample). About 4,500. (This count replaced one of 1,650 on 2026-11-23 that had
  the law at 12 pow where the loop then made 54, and left out the divisions, the gravity and
  the observer's powers; with either count, issue 16's "3x the samples per CPU-second" comes
  before its "within a factor 2 of the floor".)

The floor ignores the branches, the data-dependent stopping and the transcendental functions'
latency chains that a real loop carries: it is a bound, not a forecast.
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path
from typing import Any

import numpy as np
import yaml
from pydantic import TypeAdapter

from uqguide.config.run_config import load_yaml
from uqguide.core.inputs import InputSpace, Marginal
from uqguide.config.registry import model_class
from uqguide.methods.monte_carlo import MonteCarloReducer, split_summary
from uqguide.stats.moments import statistics_from_sums

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

LOOP_COUNTS: dict[str, tuple[float, float]] = {
    # model: (flop-equivalents, bytes of memory traffic) per sample-step; derivation in the
    # module docstring
    "ftcapn": (160.0, 16.0),
    "gmm_proximity": (300.0, 0.0),
    "gmm_ftc": (2600.0, 0.0),
    "ft_as": (4500.0, 0.0),
}

_MACHINE: dict[str, float] = {}


def calibrate() -> dict[str, float]:
    """One core's peak FMA rate (flop/s) and streaming bandwidth (bytes/s), measured once.

    Returns
    -------
    dict
        ``peak_flops`` [flop/s] and ``bandwidth`` [B/s] of one core.
    """
    if _MACHINE:
        return _MACHINE
    import numba

    @numba.njit(fastmath=True, cache=False)
    def fma_chains(y: np.ndarray, a: float, b: float, reps: int) -> float:
        # 512 independent chains across the vector: the compiler unrolls and vectorises the
        # inner loop, so latency is hidden and only the FMA ports limit the rate
        for _ in range(reps):
            for i in range(y.shape[0]):
                y[i] = a * y[i] + b
        return y[0]

    y = np.ones(512)
    reps = 20_000
    fma_chains(y, 0.999, 1e-3, 10)
    best = np.inf
    for _ in range(3):
        c0 = time.process_time()
        fma_chains(y, 0.999, 1e-3, reps)
        best = min(best, time.process_time() - c0)
    peak = 2.0 * y.size * reps / best
    big = np.ones(2**25)  # 256 MB
    out = np.empty_like(big)
    np.multiply(big, 1.0, out=out)
    best = np.inf
    for _ in range(3):
        c0 = time.process_time()
        np.multiply(big, 1.0, out=out)
        best = min(best, time.process_time() - c0)
    _MACHINE.update(peak_flops=peak, bandwidth=2.0 * big.nbytes / best)
    return _MACHINE


def steps_per_sample(model, out) -> float:
    """Integration steps one sample takes: FTCAPN's until it stops (mean over the batch, from
    ``t_stop``), the others' fixed count (:meth:`step_count`)."""
    if model.name == "ftcapn" and "t_stop" in out.scalars:
        t = out.scalars["t_stop"][:, 0]
        t = t[np.isfinite(t)]
        if t.size:
            return float(np.mean(t)) / model.params.dt + 1.0
    return float(model.step_count().steps)


def roofline_row(row: dict[str, Any]) -> dict[str, Any]:
    """Samples per CPU-second, ns per sample-step, its floor and the ratio, for a run row."""
    machine = calibrate()
    flops, nbytes = LOOP_COUNTS.get(row["model"], (float("nan"), 0.0))
    floor_ns = 1e9 * max(flops / machine["peak_flops"], nbytes / machine["bandwidth"])
    per_cpu = row["batch"] / row["sim_cpu_s"]
    ns_step = 1e9 * row["sim_cpu_s"] / (row["batch"] * row["steps"])
    return {**row, "samples_per_cpu_s": per_cpu, "ns_per_step": ns_step, "floor_ns": floor_ns,
            "floor_samples_per_s": 1e9 / (floor_ns * row["steps"]),
            "ratio": ns_step / floor_ns}


def format_roofline(rows: list[dict[str, Any]]) -> str:
    machine = calibrate()
    head = (f"{'case':<24} {'batch':>8} {'steps':>8} {'samples/cpu-s':>13} {'ns/smp-step':>11} "
            f"{'floor ns':>8} {'floor smp/s':>11} {'ratio':>6} {'load':>5}")
    lines = [f"roofline: peak {machine['peak_flops'] / 1e9:.1f} Gflop/s and "
             f"{machine['bandwidth'] / 1e9:.1f} GB/s per core (measured)", head,
             "-" * len(head)]
    for r in rows:
        lines.append(
            f"{r['label']:<24} {r['batch']:>8d} {r['steps']:>8.0f} {r['samples_per_cpu_s']:>13.4g} "
            f"{r['ns_per_step']:>11.3g} {r['floor_ns']:>8.3g} {r['floor_samples_per_s']:>11.3g} "
            f"{r['ratio']:>6.1f} {r['load']:>5.2f}")
    return "\n".join(lines)


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


def _evaluate_and_reduce(model, x, names, outputs, report_times, bootstrap, seed,
                         intervals="delta"):
    """One batch: the model, then the statistics the Monte Carlo method computes (its chunk
    reduction, one chunk, and the statistics of the merged sums)."""
    t0 = time.perf_counter()
    c0 = time.process_time()
    out = model.evaluate(x, names, outputs)
    sim_cpu = time.process_time() - c0
    t1 = time.perf_counter()
    reduce = MonteCarloReducer(bootstrap, seed, tuple(report_times or ()), "report",
                               intervals=intervals)
    acc = split_summary(reduce(out, 0))
    idx = _ci_index(out.time, report_times)
    for (kind, name), sums in acc.items():
        if kind == "m" and name:
            statistics_from_sums(sums, acc.get(("b", name)),
                                 idx if sums.mean.ndim == 2 else None,
                                 delta=acc.get(("h", name)))
    return out, t1 - t0, time.perf_counter() - t1, sim_cpu


def run_case(case: dict[str, Any], n: int, seed: int = 1, bootstrap: int = BOOTSTRAP,
             memory: bool = True, intervals: str = "delta") -> dict[str, Any]:
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
    args = (model, x, space.names, outputs, case.get("report_times"), bootstrap, seed,
            intervals)
    _evaluate_and_reduce(model, x[:2], *args[2:])  # JIT compilation, nominal grid, caches
    load = os.getloadavg()[0]
    c0 = time.process_time()
    out, sim_s, stats_s, sim_cpu_s = _evaluate_and_reduce(*args)
    cpu_s = time.process_time() - c0
    failed = int(out.failed.sum())
    steps = steps_per_sample(model, out)
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
        "sim_cpu_s": sim_cpu_s, "steps": steps, "load": load,
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
                    help="override a model parameter (YAML value), e.g. threads=1")
    ap.add_argument("--bootstrap", type=int, default=BOOTSTRAP, help="bootstrap resamples")
    ap.add_argument("--intervals", choices=["delta", "bootstrap"], default="delta",
                    help="interval method of the statistics (the Monte Carlo setting)")
    ap.add_argument("--no-memory", action="store_true", help="do not trace memory")
    ap.add_argument("--no-scale", action="store_true",
                    help="skip the 1e6-sample FTCAPN runs on 1 and 2 processes "
                         "(benchmarks/scale.py)")
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
            rows.append(run_case(case, n, bootstrap=args.bootstrap, memory=not args.no_memory,
                                 intervals=args.intervals))
            print(format_table(rows[-1:]).splitlines()[-1], file=sys.stderr, flush=True)
    print(format_table(rows))
    print("")
    print(format_roofline([roofline_row(r) for r in rows]))
    if not args.no_scale and (not args.model or "ftcapn" in args.model):
        # The campaign-scale figures (1e6 samples: wall time, peak memory, 2-process speed-up)
        # run in fresh processes so their memory peaks are their own.
        print("", flush=True)
        subprocess.run([sys.executable, str(Path(__file__).with_name("scale.py"))], check=False)
    return 0


if __name__ == "__main__":
    sys.exit(main())
