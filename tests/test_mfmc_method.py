"""The ``mfmc`` method on fidelity levels of a model: against the closed form of its highest
level, plain MC when the cheap level is useless, the same numbers whatever the batches, and
config errors. (The method contract, pool and resume included, is tests/test_conformance.py.)

The model is ``euler_decay`` (explicit Euler on ``y' = -k y``): with ``k ~ U(a, b)``
independent of ``y0``, its level with step ``dt`` has the exact mean
``E[y0] ((1 - a dt)^(n+1) - (1 - b dt)^(n+1)) / ((n + 1) dt (b - a))`` at ``t = n dt``.
"""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.core.types import ModelOutput
from uqguide.driver.execution import SerialExecutor
from uqguide.driver.propagate import propagate
from uqguide.errors import ConfigError
from uqguide.methods.base import RunContext
from uqguide.methods.mfmc import MultiFidelityMC
from uqguide.methods.mfmc import on_grid

K_LOW, K_HIGH, T_END = 0.5, 1.5, 2.0
LEVELS = [{"dt": 0.01}, {"dt": 0.1}, {"dt": 0.4}]
# seconds per run pinned (a function of the config alone): 1/dt steps, so 1 : 0.1 : 0.025
COSTS = [1e-4, 1e-5, 2.5e-6]


def _config(**method):
    return validate_config({
        "model": {"name": "euler_decay", "dt": 0.01, "t_end": T_END},
        "inputs": [{"name": "k", "dist": "uniform", "low": K_LOW, "high": K_HIGH},
                   {"name": "y0", "dist": "normal", "mean": 1.0, "std": 0.1}],
        "outputs": ["y_end", "y"], "report_times": [1.0, 2.0],
        "methods": [{"name": "mfmc", "fidelities": LEVELS, "costs": COSTS, "n_pilot": 50,
                     "chunk_size": 1024, "bootstrap": 0, **method}],
        "seed": 11})


def _exact_mean(dt: float) -> float:
    n = round(T_END / dt)
    return ((1 - K_LOW * dt) ** (n + 1) - (1 - K_HIGH * dt) ** (n + 1)) / \
        ((n + 1) * dt * (K_HIGH - K_LOW))


def _run(cfg, executor=None, seed=None):
    return propagate(cfg.methods[0], cfg.model, cfg.space, cfg.outputs,
                     cfg.seed if seed is None else seed, executor or SerialExecutor(4096))


@pytest.mark.parametrize("seed", [11, pytest.param(12, marks=pytest.mark.slow),
                                  pytest.param(13, marks=pytest.mark.slow)])
def test_mean_matches_the_highest_levels_closed_form_for_less_cpu(seed):
    run = _run(_config(budget_cpu_s=0.05), seed=seed)
    st, d = run.estimate.stats["y_end"], run.estimate.diagnostics
    assert run.success, run.message
    assert abs(st.mean[0] - _exact_mean(0.01)) < 4 * st.sem[0]
    # the cheap levels pay: a smaller error than plain MC of the same (pinned) cost
    spent = float(np.dot(d["runs_per_level"], COSTS))
    assert spent <= 0.05 * (1 + 1e-9)
    mc_sem = st.std[0] / np.sqrt(spent / COSTS[0])
    assert st.sem[0] < mc_sem / 2
    assert d["equivalent_mc_runs"] > 4 * d["runs_per_level"][0]
    assert not d["plain_mc"] and d["levels_used"].startswith("0")
    # what the highest level's own rows cannot see (rule of three over its runs)
    assert d["unseen_difference_rate"] == pytest.approx(3 / d["runs_per_level"][0])


def test_same_numbers_whatever_the_batches():
    a = _run(_config(budget_cpu_s=0.02, bootstrap=20), SerialExecutor(4096))
    b = _run(_config(budget_cpu_s=0.02, bootstrap=20), SerialExecutor(300))
    for name in ("y_end", "y"):
        for stat in ("mean", "std", "skewness", "kurtosis", "sem"):
            np.testing.assert_array_equal(getattr(a.estimate.stats[name], stat),
                                          getattr(b.estimate.stats[name], stat))
        np.testing.assert_array_equal(a.estimate.stats[name].ci["std"],
                                      b.estimate.stats[name].ci["std"])


def _pilot(y: np.ndarray) -> ModelOutput:
    n = y.shape[0]
    return ModelOutput(time=np.zeros(0), scalars={"y_end": y[:, None]},
                       failed=np.zeros(n, bool), reasons=np.full(n, "", dtype=object))


def test_an_uncorrelated_level_gives_plain_monte_carlo_at_its_cost():
    method = MultiFidelityMC({"fidelities": [{"dt": 0.01}, {"dt": 0.4}], "n_pilot": 200,
                              "budget_cpu_s": 1.0},
                             RunContext(outputs=("y_end",)))
    rng = np.random.default_rng(0)
    plan = method.allocate([_pilot(rng.standard_normal(200)), _pilot(rng.standard_normal(200))],
                           [1e-3, 1e-5])
    assert plan.allocation.is_plain_mc and plan.levels == (0,)
    assert "plain Monte Carlo" in plan.note
    # the budget less the cheap level's pilot, all on the highest level
    assert list(plan.sizes) == [int((1.0 - 200 * 1e-5) / 1e-3)]


def test_a_target_standard_error_sets_the_runs():
    run = _run(_config(target_se={"y_end": 1e-3}))
    st = run.estimate.stats["y_end"]
    # the allocation was made with the pilot's correlations: the final error lands near it
    assert st.sem[0] < 1e-3 * 1.3


def test_series_on_another_grid_are_interpolated_and_said_so():
    grid = np.array([0.0, 0.5, 1.0, 1.5, 2.0])
    s = np.broadcast_to(grid[None, :, None] * 2.0, (3, 5, 1))
    same, how = on_grid(s, grid, grid)
    assert how == "same" and same is s
    picked, how = on_grid(s, grid, np.array([0.0, 1.0, 2.0]))
    assert how == "sampled" and picked[0, :, 0].tolist() == [0.0, 2.0, 4.0]
    between, how = on_grid(s, grid, np.array([0.25, 1.75, 3.0]))
    assert how == "interpolated" and between[0, :, 0].tolist() == [0.5, 3.5, 4.0]


@pytest.mark.parametrize("method, message", [
    ({"fidelities": [{"t_end": 1.0}], "costs": None},
     "methods[0].fidelities[0]: {'t_end': 1.0}: 't_end' does not set the fidelity of model "
     "'euler_decay'; its fidelity parameters: dt"),
    ({"fidelities": [{"dt": -1.0}], "costs": None},
     "methods[0].fidelities[0]: {'dt': -1.0}: dt: Input should be greater than 0"),
    ({"optimise_for": ["zem"]}, "methods[0].optimise_for: 'zem' is not an output of the run; "
     "allowed: y_end, y"),
])
def test_config_errors_name_the_field_and_what_is_allowed(method, message):
    with pytest.raises(ConfigError) as err:
        _config(budget_cpu_s=1.0, **method)
    assert str(err.value) == message


def test_a_budget_or_a_target_but_not_both():
    with pytest.raises(ConfigError, match="give exactly one of budget_cpu_s"):
        _config()


def _result(seed: int, **method):
    from uqguide.driver.propagate import run

    raw = _config(budget_cpu_s=0.01, bootstrap=20, **method).raw.model_dump()
    raw.update(seed=seed)
    return run(validate_config(raw))


def test_the_gate_takes_an_mfmc_baseline_and_passes_a_reseeded_run():
    from uqguide.gate.baseline import make_baseline, parse_baseline
    from uqguide.gate.check import check_result
    from uqguide.report.tables import cost_table

    first = _result(1)
    base = parse_baseline(make_baseline(first))
    assert check_result(first, base).passed
    # a reseeded run differs by its standard errors only: each statistic fails with
    # probability ~6e-5 at the gate's 4 sigma, so none of these should
    again = check_result(_result(2), base)
    assert again.passed, [r for r in again.failures]
    row = cost_table(first).iloc[0]
    runs = [int(v) for v in row["runs per level"].split(" / ")]
    assert len(runs) == 3 and runs[0] < runs[1] < runs[2]
    assert row["equivalent MC runs"] > runs[0] and row["variance reduction"] > 1


def _same_statistics(a, b):
    for name, st in a.estimate.stats.items():
        other = b.estimate.stats[name]
        for stat in ("mean", "std", "skewness", "kurtosis", "sem"):
            np.testing.assert_array_equal(getattr(st, stat), getattr(other, stat))
        for stat, ci in st.ci.items():
            np.testing.assert_array_equal(ci, other.ci[stat])
    np.testing.assert_array_equal(a.estimate.diagnostics["runs_per_level"],
                                  b.estimate.diagnostics["runs_per_level"])


@pytest.mark.slow
def test_two_workers_dask_and_a_resume_give_the_bits_of_a_serial_run(tmp_path):
    from distributed import Client, LocalCluster

    from uqguide.driver.run_folder import RunStore, run_identity
    from uqguide.driver.execution import DaskExecutor, ProcessExecutor
    from uqguide.testing import _StopAfterFirstChunk

    cfg = _config(budget_cpu_s=0.02, bootstrap=50)
    serial = _run(cfg)
    pool = ProcessExecutor(2, batch_size=100)
    try:
        _same_statistics(serial, _run(cfg, pool))
    finally:
        pool.close()
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        _same_statistics(serial, _run(cfg, DaskExecutor(client=client)))
    identity = run_identity({"check": "mfmc resume"}, cfg.model)
    store = RunStore.open(tmp_path / "run", identity, resume=False)
    with pytest.raises(KeyboardInterrupt):
        try:
            propagate(cfg.methods[0], cfg.model, cfg.space, cfg.outputs, cfg.seed,
                      _StopAfterFirstChunk(SerialExecutor(4096)), store=store)
        finally:
            store.close()
    store = RunStore.open(tmp_path / "run", identity, resume=True)
    try:
        resumed = propagate(cfg.methods[0], cfg.model, cfg.space, cfg.outputs, cfg.seed,
                            SerialExecutor(4096), store=store)
    finally:
        store.close()
    _same_statistics(serial, resumed)


def test_the_docs_config_validates():
    """docs/multifidelity.md's config (its run is a slow doc example)."""
    import yaml
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "multifidelity.md").read_text()
    block = page.split("# file: mfmc_decay.yaml\n", 1)[1].split("```", 1)[0]
    cfg = validate_config(yaml.safe_load(block))
    assert cfg.methods[0].name == "mfmc" and len(cfg.methods[0].settings.fidelities) == 3


def test_a_value_left_nan_by_the_model_is_left_out_not_propagated():
    method = MultiFidelityMC({"fidelities": [{"dt": 0.01}, {"dt": 0.4}], "n_pilot": 200,
                              "budget_cpu_s": 1.0, "costs": [1e-3, 1e-5]},
                             RunContext(outputs=("y_end",)))
    rng = np.random.default_rng(1)
    y = rng.standard_normal(200)
    cheap = y + 0.1 * rng.standard_normal(200)
    cheap[:20] = np.nan  # e.g. a settling time the coarse level never reached
    plan = method.allocate([_pilot(y), _pilot(cheap)], [1e-3, 1e-5])
    # correlation ~0.995 on the 180 finite rows: the cheap level is kept
    assert plan.levels == (0, 1) and plan.allocation.variance_ratio < 0.5
