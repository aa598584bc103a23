"""A Dask run whose cluster is gone (every worker, or the scheduler) stops within a bounded time
with exit 1, one line and the --resume command, its finished chunks kept; the resume gives the
numbers of an uninterrupted run."""

from __future__ import annotations

import os
import re
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import yaml
from click.testing import CliRunner

from uqguide.cli import main
from uqguide.driver.execution import DaskExecutor, SerialExecutor
from uqguide.driver.execution.chunks import ChunkJob, Task
from uqguide.driver.execution.cluster_watch import (NO_WORKERS_TIMEOUT, SCHEDULER_LOST,
                                                    NoWorkerWatch)
from uqguide.errors import ClusterLost

from .failing_models import mc_config
from .test_resume import _assert_same, _chunk_lines, _stats

ROOT = Path(__file__).resolve().parents[1]


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


# ---------------------------------------------------------------------------- the watch
def test_the_watch_stops_after_the_timeout_counted_from_the_first_look_without_a_worker():
    clock, counts = Clock(), iter([2, 0, 0, 0])
    watch = NoWorkerWatch(lambda: next(counts), 60.0, "tcp://h:1", clock)
    watch.check()  # 2 workers
    clock.now += 500  # a long stretch of chunks coming back: not time without a worker
    watch.check()  # none: the clock starts here
    clock.now += 59.9
    watch.check()
    clock.now += 0.1
    with pytest.raises(ClusterLost) as exc:
        watch.check()
    assert str(exc.value) == ("the Dask cluster at tcp://h:1 has had no worker for 60 s "
                              "(--no-workers-timeout)")


def test_a_worker_back_or_a_chunk_back_restarts_the_count():
    clock, counts = Clock(), iter([0, 1, 0, 0, 0])
    watch = NoWorkerWatch(lambda: next(counts), 10.0, "tcp://h:1", clock)
    watch.check()
    clock.now += 9
    watch.check()  # a worker came back
    clock.now += 9
    watch.check()  # gone again: 0 s without one
    clock.now += 9
    watch.check()
    watch.saw_worker()  # a chunk came back
    clock.now += 9
    watch.check()  # counted from here
    assert watch.none_since == clock.now


def test_a_lost_scheduler_stops_at_once():
    watch = NoWorkerWatch(lambda: None, 60.0, "tcp://h:1", Clock())
    with pytest.raises(ClusterLost, match=r"^lost the connection to the Dask scheduler at "
                                          r"tcp://h:1$"):
        watch.check()


def test_the_poll_is_a_twentieth_of_the_timeout_at_most_a_second():
    assert NoWorkerWatch(lambda: 0, NO_WORKERS_TIMEOUT, "").poll_seconds == 1.0
    assert NoWorkerWatch(lambda: 0, 2.0, "").poll_seconds == 0.1


# ---------------------------------------------------------------- the executor, fake cluster
class FakeFuture:
    def __init__(self, error: BaseException | None = None) -> None:
        self.error = error
        self.cancelled = self.released = False

    def result(self):
        raise self.error

    def cancel(self) -> None:
        self.cancelled = True

    def release(self) -> None:
        self.released = True


class FakeClient:
    """A connected client whose cluster has ``workers`` workers and never finishes a chunk."""

    status = "running"

    def __init__(self, workers: int = 2) -> None:
        self.workers = workers
        self.scheduler = type("Rpc", (), {"address": "tcp://10.0.0.5:8786",
                                          "ncores": "ncores"})()
        self.futures: list[FakeFuture] = []
        self.probes = 0

    def nthreads(self) -> dict:
        return {f"w{i}": 1 for i in range(self.workers)}

    def sync(self, func, callback_timeout=None):
        assert func == "ncores" and callback_timeout == 10.0
        self.probes += 1
        return self.nthreads()

    def submit(self, fn, *args, **kwargs) -> FakeFuture:
        self.futures.append(FakeFuture())
        return self.futures[-1]


def _job() -> ChunkJob:
    return ChunkJob(model=None, names=("a",), outputs=("y",), batch_size=10)  # type: ignore


def test_a_cluster_without_workers_stops_the_chunks_after_the_timeout(monkeypatch):
    import distributed

    client, clock = FakeClient(), Clock()
    ex = DaskExecutor(client=client)
    ex.watch.clock = clock
    client.workers = 0  # all gone after the start

    def wait(futures, timeout, return_when):
        assert return_when == "FIRST_COMPLETED" and timeout == ex.watch.poll_seconds
        clock.now += timeout
        raise distributed.TimeoutError()

    monkeypatch.setattr(distributed, "wait", wait)
    t0 = clock.now
    tasks = [Task(i, 10 * i, 10 * i + 10) for i in range(8)]
    with pytest.raises(ClusterLost, match="has had no worker for 60 s"):
        list(ex.map_chunks(_job(), tasks, np.zeros((80, 1))))
    # the first look sees none and starts the clock; 60 s later the run stops
    assert clock.now - t0 == pytest.approx(NO_WORKERS_TIMEOUT + ex.watch.poll_seconds)
    assert client.probes == 61
    # the window (2 x 2 threads) was in flight, and is cancelled on the way out
    assert len(client.futures) == 4 and all(f.cancelled for f in client.futures)


def test_a_lost_scheduler_cancelling_the_chunks_is_one_line(monkeypatch):
    import distributed
    from distributed.client import (CancelledFuturesGroup, FutureCancelledError,
                                    FuturesCancelledError)

    client = FakeClient()
    ex = DaskExecutor(client=client)
    lost = FuturesCancelledError([CancelledFuturesGroup(
        [FutureCancelledError("k", SCHEDULER_LOST, "Client lost the connection")],
        SCHEDULER_LOST)])

    def wait(futures, timeout, return_when):
        client.status = "connecting"
        raise lost

    monkeypatch.setattr(distributed, "wait", wait)
    with pytest.raises(ClusterLost) as exc:
        list(ex.map_chunks(_job(), [Task(0, 0, 10)], np.zeros((10, 1))))
    assert str(exc.value) == "lost the connection to the Dask scheduler at tcp://10.0.0.5:8786"


@pytest.mark.parametrize("error, words", [
    ("closed", "lost the connection to the Dask scheduler at tcp://10.0.0.5:8786 (while "
               "fetching chunk 3)"),
    ("cancelled", "the Dask cluster at tcp://10.0.0.5:8786 cancelled the chunks in flight "
                  "(user-cancel)"),
])
def test_a_result_lost_with_the_scheduler_is_one_line(error, words):
    from distributed.client import FutureCancelledError
    from distributed.comm import CommClosedError

    ex = DaskExecutor(client=FakeClient())
    fut = FakeFuture(CommClosedError("in <TCP ConnectionPool.gather>: Stream is closed")
                     if error == "closed" else FutureCancelledError("k", "user-cancel"))
    with pytest.raises(ClusterLost) as exc:
        list(ex._collect(_job(), fut, Task(3, 30, 40), {}, np.zeros((40, 1))))
    assert str(exc.value) == words
    assert fut.released


# ---------------------------------------------------------------------------- the command
def _config(tmp_path: Path, function: str = "tests.failing_models:clean_sum") -> Path:
    raw = mc_config(function, 1000, 100, bootstrap=20)
    raw["model"]["isolate"] = False  # no guard process: the fake cluster runs in the driver
    path = tmp_path / "lost.yaml"
    path.write_text(yaml.safe_dump(raw))
    return path


class LosesItsCluster(SerialExecutor):
    """The driver's view of a cluster that finishes 3 chunks and then is gone."""

    def map_chunks(self, job, tasks, x):
        for r in list(super().map_chunks(job, tasks[:3], x)):
            yield r
        raise ClusterLost("the Dask cluster at tcp://10.0.0.5:8786 has had no worker for 60 s "
                          "(--no-workers-timeout)")


def test_a_lost_cluster_exits_1_with_the_resume_line_and_the_resume_gives_the_same_bits(
        tmp_path, monkeypatch):
    import uqguide.driver.execution as execution

    cfg, out = _config(tmp_path), tmp_path / "out"
    made = {}

    def make_executor(workers, scheduler, scheduler_file, no_workers_timeout):
        made.update(scheduler=scheduler, timeout=no_workers_timeout)
        return LosesItsCluster()

    monkeypatch.setattr(execution, "make_executor", make_executor)
    res = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "-q", "--scheduler",
                                    "tcp://10.0.0.5:8786"])
    assert res.exit_code == 1, res.output
    assert made == {"scheduler": "tcp://10.0.0.5:8786", "timeout": 60.0}
    assert res.stderr.splitlines() == [
        f"error: the Dask cluster at tcp://10.0.0.5:8786 has had no worker for 60 s "
        f"(--no-workers-timeout); 3 of 10 chunks done; resume with `uqguide run {cfg} "
        f"--resume --out {out} --scheduler tcp://10.0.0.5:8786`"]
    assert _chunk_lines(out / "lost.run" / "manifest.jsonl") == 3
    assert not (out / "lost.h5").exists()

    monkeypatch.undo()  # resumed in this process: only the 7 missing chunks run
    again = CliRunner().invoke(main, ["run", str(cfg), "--out", str(out), "-q", "--resume"])
    assert again.exit_code == 0, again.output
    whole = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "whole"), "-q"])
    assert whole.exit_code == 0, whole.output
    _assert_same(_stats(tmp_path / "whole" / "lost.h5"), _stats(out / "lost.h5"))


def test_the_timeout_is_passed_on_and_refused_without_a_scheduler(tmp_path, monkeypatch):
    import uqguide.driver.execution as execution

    cfg = _config(tmp_path)
    seen = []
    monkeypatch.setattr(execution, "make_executor",
                        lambda *args: seen.append(args) or SerialExecutor())
    ok = CliRunner().invoke(main, ["run", str(cfg), "--out", str(tmp_path / "o"), "-q",
                                   "--scheduler-file", "s.json", "--no-workers-timeout", "300"])
    assert ok.exit_code == 0, ok.output
    assert seen == [(None, None, "s.json", 300)]
    alone = CliRunner().invoke(main, ["run", str(cfg), "--no-workers-timeout", "30"])
    assert alone.exit_code == 2
    assert alone.stderr.strip() == ("error: --no-workers-timeout: only for a Dask cluster (give "
                                    "--scheduler or --scheduler-file)")
    zero = CliRunner().invoke(main, ["run", str(cfg), "--scheduler", "tcp://h:1",
                                     "--no-workers-timeout", "0"])
    assert zero.exit_code == 2 and "Traceback" not in zero.output
    assert "--no-workers-timeout" in zero.stderr


def test_the_executor_refuses_a_timeout_that_is_not_positive():
    from uqguide.errors import ConfigError

    for bad in (0.0, -1.0, float("inf"), float("nan")):
        with pytest.raises(ConfigError, match="--no-workers-timeout: must be a positive"):
            DaskExecutor(client=FakeClient(), no_workers_timeout=bad)


# ------------------------------------------------------------------ a real cluster, killed
def _start_scheduler(tmp_path: Path, env: dict) -> tuple[subprocess.Popen, Path]:
    # every port on 127.0.0.1, the HTTP one (dashboard, health) included
    sfile = tmp_path / "scheduler.json"
    proc = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host",
                             "127.0.0.1", "--port", "0", "--dashboard-address", "127.0.0.1:0",
                             "--scheduler-file", str(sfile)], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    deadline = time.monotonic() + 60
    while not (sfile.is_file() and sfile.stat().st_size):
        assert proc.poll() is None and time.monotonic() < deadline, "no scheduler"
        time.sleep(0.1)
    return proc, sfile


def _start_workers(sfile: Path, env: dict, n: int = 2) -> list[subprocess.Popen]:
    # no nanny: a killed worker stays dead (a nanny would start a new one)
    return [subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--host",
                              "127.0.0.1", "--no-nanny", "--nthreads", "1",
                              "--dashboard-address", "127.0.0.1:0",
                              "--scheduler-file", str(sfile)], env=env, cwd=ROOT,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            for _ in range(n)]


@pytest.fixture
def cluster(tmp_path):
    """A scheduler and two workers on 127.0.0.1 (processes of their own, killed by PID)."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    scheduler, sfile = _start_scheduler(tmp_path, env)
    procs = {"scheduler": scheduler, "workers": _start_workers(sfile, env)}
    procs.update(sfile=sfile, env=env, more=[])
    try:
        yield procs
    finally:
        for p in [scheduler, *procs["workers"], *procs["more"]]:
            if p.poll() is None:
                p.kill()
            p.wait()


def _run_until_chunks(cfg: Path, out: Path, sfile: Path, env: dict,
                      n: int) -> subprocess.Popen:
    proc = subprocess.Popen([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                             str(out), "-q", "--scheduler-file", str(sfile)], cwd=ROOT,
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while _chunk_lines(out / "lost.run" / "manifest.jsonl") < n:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline
        time.sleep(0.05)
    return proc


@pytest.mark.slow  # a Dask cluster of three processes, and a minute without workers
def test_two_killed_workers_end_the_run_within_90_s_and_fresh_workers_resume_it(
        cluster, tmp_path):
    cfg, out = _config(tmp_path, "tests.failing_models:slow_sum"), tmp_path / "out"
    proc = _run_until_chunks(cfg, out, cluster["sfile"], cluster["env"], 3)
    killed = time.monotonic()
    for w in cluster["workers"]:
        os.kill(w.pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    seconds = time.monotonic() - killed
    err = err.decode()
    assert proc.returncode == 1, err
    assert seconds < 90, seconds
    print(f"\nkill -> exit 1: {seconds:.1f} s")
    assert "Traceback" not in err
    done = _chunk_lines(out / "lost.run" / "manifest.jsonl")
    last = err.strip().splitlines()[-1]
    assert last.startswith("error: the Dask cluster at tcp://127.0.0.1:") and last.endswith(
        f"has had no worker for 60 s (--no-workers-timeout); {done} of 10 chunks done; "
        f"resume with `uqguide run {cfg} --resume --out {out} --scheduler-file "
        f"{cluster['sfile']}`"), err
    assert 3 <= done < 10 and not (out / "lost.h5").exists()

    # the printed command, on two fresh workers, finishes the run
    cluster["more"] += _start_workers(cluster["sfile"], cluster["env"])
    command = shlex.split(last.split("`")[1])
    assert command[:2] == ["uqguide", "run"]
    again = subprocess.run([sys.executable, "-m", "uqguide.cli", *command[1:], "-q"], cwd=ROOT,
                           env=cluster["env"], capture_output=True, timeout=300)
    assert again.returncode == 0, again.stderr.decode()
    (tmp_path / "ref").mkdir()  # the same study, its model without the pause
    whole = CliRunner().invoke(main, ["run", str(_config(tmp_path / "ref")), "--out",
                                      str(tmp_path / "whole"), "-q"])
    assert whole.exit_code == 0, whole.output
    _assert_same(_stats(tmp_path / "whole" / "lost.h5"), _stats(out / "lost.h5"))


@pytest.mark.slow  # a Dask cluster of three processes
def test_a_killed_scheduler_ends_the_run_with_one_line_and_keeps_the_checkpoint(
        cluster, tmp_path):
    cfg, out = _config(tmp_path, "tests.failing_models:slow_sum"), tmp_path / "out"
    proc = _run_until_chunks(cfg, out, cluster["sfile"], cluster["env"], 3)
    killed = time.monotonic()
    os.kill(cluster["scheduler"].pid, signal.SIGKILL)
    _, err = proc.communicate(timeout=120)
    seconds = time.monotonic() - killed
    err = err.decode()
    print(f"\nscheduler kill -> exit 1: {seconds:.1f} s")
    assert proc.returncode == 1, err
    done = _chunk_lines(out / "lost.run" / "manifest.jsonl")
    assert re.fullmatch(
        rf"error: lost the connection to the Dask scheduler at tcp://127\.0\.0\.1:\d+"
        rf"( \(while fetching chunk \d+\))?; {done} of 10 chunks done; resume with "
        rf"`uqguide run {re.escape(f'{cfg} --resume --out {out} --scheduler-file')} "
        rf"{re.escape(str(cluster['sfile']))}`", err.strip()), err
    assert 3 <= done < 10 and not (out / "lost.h5").exists()
    assert seconds < 30, seconds
