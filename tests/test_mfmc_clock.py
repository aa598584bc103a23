"""mfmc's clock: the pilot's costs are the CPU of the process that ran the model (a guard
process for a ``callable``), a fallback to plain MC saves nothing, and the model is called
on blocks as large as ``monte_carlo``'s chunks."""

from __future__ import annotations

import os

import numpy as np
import psutil
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.execution.guard import _GUARDS, close_guards
from uqguide.driver.propagate import run
from uqguide.methods.base import RunContext
from uqguide.methods.mfmc import MultiFidelityMC
from uqguide.methods.monte_carlo import CHUNK_ROWS

from .fixtures_models import BURN_S

N_PILOT = 100
#: psutil reads a process's CPU in clock ticks (user and system apart)
TICK = 1.0 / os.sysconf("SC_CLK_TCK")


def _guarded(function: str) -> dict:
    """One level of a ``callable`` at its defaults (its calls in a guard process); the pilot
    alone exceeds the budget, so the level runs its pilot's rows only."""
    return validate_config({
        "model": {"name": "callable", "function": f"tests.fixtures_models:{function}",
                  "inputs": ["x1"], "outputs": ["y"]},
        "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "mfmc", "fidelities": [{}], "n_pilot": N_PILOT,
                     "budget_cpu_s": 1e-3, "bootstrap": 0}],
        "seed": 3})


def _guard_cpu() -> float:
    (guard,) = _GUARDS.values()
    t = psutil.Process(guard._proc.pid).cpu_times()
    return t.user + t.system


def test_the_pilot_times_the_model_in_the_guard_process():
    close_guards()
    try:
        run(_guarded("no_cpu"))  # the guard started and warm
        c0 = _guard_cpu()
        idle = run(_guarded("no_cpu")).runs[0].estimate.diagnostics
        c1 = _guard_cpu()
        busy = run(_guarded("burn_cpu")).runs[0].estimate.diagnostics
        c2 = _guard_cpu()
    finally:
        close_guards()
    spent, overhead = c2 - c1, c1 - c0
    measured = float(busy["cpu_per_level"][0])
    assert busy["runs_per_level"][0] == N_PILOT
    assert float(busy["pilot_seconds_per_run"][0]) * N_PILOT == pytest.approx(measured)
    # the model's own CPU, which the guard spent on top of what it spends on an idle model
    # (unpickling the rows, the replies), each psutil reading good to a tick of user and system
    assert spent - overhead - 4 * TICK <= measured <= spent + 4 * TICK
    assert measured >= BURN_S * N_PILOT
    assert float(idle["cpu_per_level"][0]) <= overhead + 4 * TICK


def _pilot(y: np.ndarray):
    from uqguide.core.types import ModelOutput

    n = y.shape[0]
    return ModelOutput(time=np.zeros(0), scalars={"y": y[:, None]},
                       failed=np.zeros(n, bool), reasons=np.full(n, "", dtype=object))


def test_a_fallback_to_plain_mc_saves_nothing():
    """Plain MC of the highest level is plain MC: its saving is at most 1 whatever the pilot's
    costs said (a dear pilot in small calls and cheaper main runs once read 1.9)."""
    method = MultiFidelityMC({"fidelities": [{}, {"function": "x"}], "n_pilot": 200,
                              "budget_cpu_s": 1.0}, RunContext(outputs=("y",)))
    rng = np.random.default_rng(0)
    pilot = [_pilot(rng.standard_normal(200)), _pilot(rng.standard_normal(200))]
    # the main runs cost a third per run of what the pilot's (in small calls) did
    plan = method.allocate(pilot, [1e-3, 1e-5])
    assert plan.allocation.is_plain_mc
    m0 = int(plan.sizes[0])
    runs = [_pilot(rng.standard_normal(m0))]
    from uqguide.methods.base import Design

    est = method.estimate_levels(runs, plan, Design(x=np.zeros((m0, 1))),
                                 [m0 * 1e-3 / 3, 1e-5 * 200], [1e-3, 1e-5])
    d = est.diagnostics
    assert d["plain_mc"]
    assert d["cpu_saving"] <= 1.0
    # the share of the CPU (the estimate's own included) the highest level's runs took
    top = m0 * 1e-3 / 3
    assert d["cpu_saving"] == pytest.approx(top / (top + 1e-5 * 200 + d["estimate_cpu_s"]))


@pytest.mark.parametrize("chunk_size", [256, 1000, 10_000])
def test_the_model_is_called_on_blocks_of_monte_carlos_chunk(chunk_size):
    method = MultiFidelityMC({"fidelities": [{}], "budget_cpu_s": 1.0,
                              "chunk_size": chunk_size})
    blocks = method.row_chunks(200, 50_000)
    assert blocks[0] == (200, method.block_rows)
    sizes = [b - a for a, b in blocks[1:-1]]
    assert min(sizes) >= CHUNK_ROWS and all(s % chunk_size == 0 for s in sizes)
    assert method.block_rows - chunk_size < CHUNK_ROWS <= method.block_rows


#: a program that spends ``sys.argv[3]`` CPU seconds, then writes ``y = a`` for each row
_BURN = ("import csv, sys, time\n"
         "until = time.process_time() + float(sys.argv[3])\n"
         "while time.process_time() < until: pass\n"
         "rows = list(csv.reader(open(sys.argv[1])))[1:]\n"
         "open(sys.argv[2], 'w').write('y\\n' + ''.join(r[0] + '\\n' for r in rows))\n")


def test_a_command_declares_its_levels_and_its_programs_cpu_is_counted(tmp_path):
    """A ``command`` model's levels are other command lines; the CPU its program spends (a
    child process, waited for) is the level's cost."""
    import shlex
    import sys

    def line(burn: float) -> str:
        return f"{shlex.quote(sys.executable)} -c {shlex.quote(_BURN)} {{inputs}} {{outputs}} " \
               f"{burn}"

    cfg = validate_config({
        "model": {"name": "command", "command": line(0.1), "inputs": ["a"], "outputs": ["y"],
                  "workdir": str(tmp_path)},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "mfmc", "fidelities": [{}, {"command": line(0.0)}],
                     "n_pilot": 20, "budget_cpu_s": 1e-3, "bootstrap": 0}],
        "seed": 1})
    d = run(cfg).runs[0].estimate.diagnostics
    # one call per level (the pilot alone exceeds the budget): the program's 0.1 s counted
    assert list(d["runs_per_level"]) == [20, 20]
    assert d["cpu_per_level"][0] >= 0.1
    assert d["cpu_per_level"][0] - d["cpu_per_level"][1] >= 0.1 - 4 * TICK
    with pytest.raises(Exception, match="fidelities\\[1\\].*inputs"):
        validate_config({**cfg.raw.model_dump(), "methods": [{
            "name": "mfmc", "fidelities": [{}, {"inputs": "b"}], "budget_cpu_s": 1.0}]})


#: :func:`burn_per_call`'s CPU seconds per call and per row: a vectorised model's call costs
#: as much as 2,000 of its rows, so a pilot's call of ``N_SMALL`` rows costs it 100 times more
#: per run than a block of ``monte_carlo``'s chunk
CALL_S, ROW_S, N_SMALL = 0.02, 1e-5, 20


def burn_per_call(x):
    """``y = x1`` after ``CALL_S + ROW_S n`` CPU seconds for a call of ``n`` rows."""
    import time

    until = time.process_time() + CALL_S + ROW_S * x.shape[0]
    while time.process_time() < until:
        pass
    return x[:, 0]


def test_the_budget_is_spent_at_the_prices_the_runs_pay():
    """The runs are priced at what the latest round paid, not at the pilot's one small call.
    At the pilot's price (1 ms a run) a budget of 0.3 CPU-s bought 300 runs for 0.043 CPU-s.
    The rounds pay 1 ms, then 164 us (a call of 128 rows), then about 24 us a run (1,400
    rows), and the last round's two calls cost about 0.13 CPU-s: 0.21 in all."""
    from uqguide.driver.execution import SerialExecutor
    from uqguide.driver.propagate import propagate

    budget = 0.3
    cfg = validate_config({
        "model": {"name": "callable", "function": "tests.test_mfmc_clock:burn_per_call",
                  "isolate": False, "inputs": ["x1"], "outputs": ["y"]},
        "inputs": [{"name": "x1", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "mfmc", "fidelities": [{}], "n_pilot": N_SMALL,
                     "budget_cpu_s": budget, "bootstrap": 0}],
        "seed": 3})
    r = propagate(cfg.methods[0], cfg.model, cfg.space, cfg.outputs, cfg.seed,
                  SerialExecutor(100_000))
    d = r.estimate.diagnostics
    # the method's whole CPU: the models', the estimate's and the rest (its pricing, the
    # allocations, the driver's part of the runs beyond the model's)
    spent = float(np.sum(d["cpu_per_level"])) + d["estimate_cpu_s"] + d["overhead_cpu_s"]
    # what is left unspent is the last round's per-call part, which a price per run of the
    # round before (1,400 rows in one call) spreads over its rows: at most CALL_S a call of
    # the last round and the round before's CALL_S / 1,400 a run, well within half the budget;
    # never more than the budget and a run's rounding and the timer's tick
    assert budget / 2 <= spent <= budget + ROW_S + TICK
    assert d["rounds"] == 3 and d["costs"].startswith("measured (the runs of the round")


def test_a_level_the_first_round_ran_is_never_dropped():
    """At the first round's prices a dearer estimate (its bootstrap costs per row, as a cheap
    run does) may make the cheapest level not worth its rows: the rows it ran stay in, and
    the second round keeps it, where it once dropped it (the CPU of its runs lost)."""
    method = MultiFidelityMC({"fidelities": [{}, {"function": "x"}, {"function": "z"}],
                              "n_pilot": 200, "budget_cpu_s": 1.0},
                             RunContext(outputs=("y",)))
    rng = np.random.default_rng(0)
    y = rng.standard_normal(200)
    pilot = [_pilot(y + e * rng.standard_normal(200)) for e in (0.0, 0.05, 0.3)]
    cheap = [1e-3, 1e-5, 1e-6]
    plan = method.allocate(pilot, cheap, share=0.5)
    assert plan.levels == (0, 1, 2)
    done = {i: int(plan.sizes[plan.levels.index(i)]) for i in range(3)}
    # the estimate at 2e-5 a row: at that price alone the cheapest level gains nothing
    alone = method.top_up(pilot, plan, np.array(cheap), (0.0, 2e-5), 0.5,
                          {i: 200 for i in range(3)})
    assert 2 not in alone.levels
    kept = method.top_up(pilot, plan, np.array(cheap), (0.0, 2e-5), 0.5, done)
    assert kept.levels == (0, 1, 2)
    assert all(kept.sizes[j] >= done[i] for j, i in enumerate(kept.levels))


def test_the_rows_moving_between_processes_are_counted():
    from uqguide.methods.mfmc import _moving_cpu

    # a model in the driver's process: its CPU is in the driver's, the excess is the moving
    assert _moving_cpu(1.25, 1.0) == pytest.approx(0.25)
    # a model in a guard: the driver's CPU is all moving, and the guard's side as much again
    assert _moving_cpu(0.1, 1.0) == pytest.approx(0.2)


def test_the_last_round_keeps_a_reserve_for_the_prices_moving():
    from uqguide.methods.mfmc import _price_drift

    prices = np.array([60e-6, 15e-6, 4e-6])
    # the pilot's prices are no drift (a small call is dearer per run)
    assert _price_drift(prices, np.full(3, np.nan), (0, 1, 2)) == 0.0
    # the largest move of a used level between the two rounds before: level 2's 25%, level
    # 1 unused
    earlier = np.array([50e-6, 30e-6, 3.2e-6])
    assert _price_drift(prices, earlier, (0, 2)) == pytest.approx(0.25)
