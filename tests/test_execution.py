"""Executors: the same numbers in this process, in a process pool and on a Dask cluster;
a crashed worker fails its chunk only."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.driver.execution import DaskExecutor, ProcessExecutor, SerialExecutor
from uqguide.driver.propagate import run

FLAKY = {
    "model": {"name": "callable", "function": "tests.failing_models:flaky", "inputs": ["a", "b"],
              "outputs": [{"name": "path", "kind": "series"}, "y",
                          {"name": "ab", "components": 2}]},
    "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
               {"name": "b", "dist": "lognormal", "mu": 0.0, "sigma": 0.5}],
    # 7 chunks (the last one short), model calls of 300 samples inside each
    "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 6500, "chunk_size": 1000,
                 "bootstrap": 50}],
    "report_times": [0.5],
    "batch_size": 300,
    "max_failed_fraction": 0.1,
    "seed": 3,
    # order statistics and event counts must be worker-independent too
    "quantiles": [0.01, 0.5, 0.99],
    "events": [{"name": "high", "output": "ab", "component": 1, "above": 1.5}],
}


def _arrays(result):
    """Every number of the method's result: statistics, intervals, joint, samples."""
    r = result.run("mc")
    e = r.estimate
    out = {"x": r.x, "failed": r.failed, "scalar_mean": e.scalar_mean,
           "scalar_cov": e.scalar_cov, "reasons": np.array([str(v) for v in r.reasons])}
    out.update({f"scalars/{k}": v for k, v in r.scalars.items()})
    for name, s in e.stats.items():
        for k in ("mean", "std", "skewness", "kurtosis", "cov", "sem"):
            out[f"{name}/{k}"] = getattr(s, k)
        out.update({f"{name}/ci_{k}": v for k, v in s.ci.items()})
        out[f"{name}/quantiles"], out[f"{name}/ci_quantiles"] = s.quantiles, s.ci_quantiles
    out.update({f"event/{k}": np.array([v.probability, *v.ci, v.n_in, v.n_used])
                for k, v in e.events.items()})
    return out


def _assert_identical(a, b):
    assert a.keys() == b.keys()
    for k in a:
        nan_ok = a[k] is not None and np.asarray(a[k]).dtype.kind == "f"
        assert np.array_equal(a[k], b[k], equal_nan=nan_ok), k


@pytest.fixture(scope="module")
def serial_result():
    return run(validate_config(FLAKY))


@pytest.mark.slow
def test_serial_and_process_pool_give_identical_statistics(serial_result):
    cfg = validate_config(FLAKY)
    serial = _arrays(serial_result)
    assert 0 < serial["failed"].sum() < 0.1 * 6500  # the chunks hold both kinds of failure
    pool = ProcessExecutor(2)
    try:
        _assert_identical(serial, _arrays(run(cfg, pool)))
    finally:
        pool.close()


def test_dask_on_threads_gives_the_serial_statistics(serial_result):
    # the DaskExecutor's submit/gather/order in-process (two worker threads): the cheap version
    # of the worker-process cluster below
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        got = run(validate_config(FLAKY), DaskExecutor(client=client))
    _assert_identical(_arrays(serial_result), _arrays(got))


# slow: a cluster of two worker processes costs ~10 CPU-s to start; the default suite keeps
# Dask on threads (above) and the process pool
@pytest.mark.slow
def test_dask_on_worker_processes_gives_the_serial_statistics(serial_result):
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        assert len(client.nthreads()) == 2
        got = run(validate_config(FLAKY), DaskExecutor(client=client))
    _assert_identical(_arrays(serial_result), _arrays(got))


def test_batch_size_does_not_change_a_number(serial_result):
    other = run(validate_config(FLAKY), SerialExecutor(batch_size=77))
    _assert_identical(_arrays(serial_result), _arrays(other))


def test_estimate_on_outputs_in_memory_equals_the_streamed_estimate(serial_result):
    # The Method contract's estimate(outputs) reduces chunk by chunk like the executors: one
    # code path, the same bits.
    cfg = validate_config(FLAKY)
    method = cfg.methods[0]
    design = method.design(cfg.space, cfg.seed)
    out = SerialExecutor(300).evaluate(cfg.model, design.x, cfg.space.names, cfg.outputs)
    e = method.estimate(cfg.space, design, out)
    s = serial_result.run("mc").estimate
    for name in ("path", "y", "ab"):
        for k in ("mean", "std", "skewness", "kurtosis", "cov"):
            assert np.array_equal(getattr(e.stats[name], k), getattr(s.stats[name], k),
                                  equal_nan=True)
        assert np.array_equal(e.stats[name].ci["kurtosis"], s.stats[name].ci["kurtosis"],
                              equal_nan=True)
        assert np.array_equal(e.stats[name].ci_quantiles, s.stats[name].ci_quantiles,
                              equal_nan=True)


@pytest.mark.slow
def test_a_crashed_worker_fails_only_its_crashing_samples_and_the_pool_goes_on():
    cfg = validate_config({
        "model": {"name": "callable", "function": "tests.failing_models:crash_worker",
                  "inputs": ["a", "b"], "outputs": ["y"]},
        "inputs": [{"name": "a", "dist": "normal", "std": 1.0},
                   {"name": "b", "dist": "normal", "std": 1.0}],
        "methods": [{"name": "monte_carlo", "label": "mc", "n_samples": 32,
                     "chunk_size": 4, "bootstrap": 0}],
        # seed 18: the second of the eight chunks crashes, on one of its 4 samples; the six
        # after it run on the rebuilt pool (each crashing chunk costs ~6 CPU-s of respawned
        # workers and guard processes, so one is enough)
        "seed": 18,
    })
    pool = ProcessExecutor(2)
    try:
        r = run(cfg, pool).run("mc")
    finally:
        pool.close()
    chunks = r.x[:, 0].reshape(8, 4)
    bad = (chunks > 2.5).any(axis=1)
    assert bad.sum() == 1 and bad[1]  # a chunk kills its worker; the pool goes on
    # the chunk is bisected in guard processes: only the crashing samples fail
    np.testing.assert_array_equal(r.failed, r.x[:, 0] > 2.5)
    assert all(str(v).startswith("model process crashed") for v in r.reasons[r.failed])
    ok = ~r.failed
    np.testing.assert_array_equal(r.scalars["y"][ok, 0], r.x[ok, 0] + r.x[ok, 1])
    assert r.estimate.stats["y"].n_used == ok.sum()


@pytest.mark.slow
def test_cli_workers_gives_the_serial_result_and_executor_options_are_checked(write_config,
                                                                              tmp_path):
    import yaml
    from click.testing import CliRunner

    from uqguide.cli import main
    from uqguide.results.result import read_hdf5

    cfg = dict(FLAKY, methods=[dict(FLAKY["methods"][0], n_samples=2500)])
    path = write_config(yaml.safe_dump(cfg), "flaky.yaml")
    runner = CliRunner()
    serial = runner.invoke(main, ["run", str(path), "--out", str(tmp_path / "s")])
    pooled = runner.invoke(main, ["run", str(path), "--out", str(tmp_path / "p"),
                                  "--workers", "2"])
    assert serial.exit_code == 0 and pooled.exit_code == 0, (serial.output, pooled.output)
    _assert_identical(_arrays(read_hdf5(tmp_path / "s" / "flaky.h5")),
                      _arrays(read_hdf5(tmp_path / "p" / "flaky.h5")))
    both = runner.invoke(main, ["run", str(path), "--workers", "2", "--scheduler",
                                "tcp://127.0.0.1:1"])
    assert both.exit_code == 2
    assert both.stderr.strip() == ("error: --workers: not used with a Dask scheduler (the "
                                   "cluster has its own workers)")
    zero = runner.invoke(main, ["run", str(path), "--workers", "0"])
    assert zero.exit_code == 2 and "Invalid value for '--workers'" in zero.stderr
