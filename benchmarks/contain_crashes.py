"""Crash containment without workers: segfaulting samples, kills mid-run, resumes, isolation cost.

Three measurements (issue 26, "a crashing sample costs that sample, even serially"):

1. **Segfaults.** A serial ``uqguide run`` of a ``callable`` whose 4 samples of 1000 die of a
   real segmentation fault (a NULL read): exactly those 4 fail, the run exits 0.
2. **Kill and resume.** The same run, slowed down, is killed (SIGKILL) at several moments,
   some of them while a crashing chunk is being bisected, then ``--resume`` d: each resumed
   result must hash equal to the uninterrupted one (statistics, samples, failure mask and
   reasons), and no sample the run folder already lists as a crasher may run again.
3. **Isolation overhead.** A cheap callable (``a + b``) in a guard process (the default) and in
   the driver (``isolate: false``), serially, at a few sizes: the wall-time difference.

Usage::

    python benchmarks/contain_crashes.py            # all three, prints the tables
    python benchmarks/contain_crashes.py --quick    # fewer kill points and sizes
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # the test models live in tests/
    sys.path.insert(0, str(ROOT))

import uqguide  # noqa: E402
from uqguide.results.result import read_hdf5  # noqa: E402
from tests.failing_models import mc_config  # noqa: E402

ENV = {**os.environ, "PYTHONPATH": str(ROOT)}


def result_hash(h5: Path) -> str:
    """SHA-256 of everything a run computed: each method's statistics, samples, outputs,
    failure mask and reasons (not its timings)."""
    h = hashlib.sha256()
    for r in read_hdf5(h5).runs:
        for out in sorted(r.estimate.stats):
            s = r.estimate.stats[out]
            for k in ("mean", "std", "skewness", "kurtosis", "cov"):
                h.update(np.ascontiguousarray(getattr(s, k)).tobytes())
            for k in sorted(s.ci):
                h.update(np.ascontiguousarray(s.ci[k]).tobytes())
        h.update(np.ascontiguousarray(r.x).tobytes())
        for k in sorted(r.scalars):
            h.update(np.ascontiguousarray(r.scalars[k]).tobytes())
        h.update(np.ascontiguousarray(r.failed).tobytes())
        h.update("\n".join(map(str, r.reasons[r.failed])).encode())
    return h.hexdigest()


def crash_config(n: int, chunk: int, k: int, seed: int = 11) -> tuple[dict, float]:
    """A Monte Carlo config over ``segfault_above`` and the threshold above which exactly ``k``
    of its ``n`` samples segfault."""
    cfg = {**mc_config("tests.failing_models:segfault_above", n, chunk, seed),
           "name": "seg", "max_failed_fraction": 0.5}
    x = uqguide.load_config(cfg).methods[0].design(
        uqguide.load_config(cfg).space, seed).x
    return cfg, float(np.sort(x[:, 0])[-k - 1])


def _cli(cfg: Path, out: Path, env: dict, *args: str) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "uqguide.cli", "run", str(cfg), "--out",
                             str(out), "-q", *args], cwd=ROOT, env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)


def _manifest(out: Path) -> list[dict]:
    f = out / "seg.run" / "manifest.jsonl"
    lines = []
    for line in f.read_text().splitlines() if f.is_file() else []:
        try:
            lines.append(json.loads(line))
        except json.JSONDecodeError:
            pass
    return lines


def segfaults(n: int = 1000, k: int = 4) -> dict:
    """Measurement 1."""
    with tempfile.TemporaryDirectory() as tmp:
        cfg, thr = crash_config(n, 8192, k)
        path = Path(tmp) / "seg.yaml"
        path.write_text(yaml.safe_dump(cfg))
        env = {**ENV, "UQGUIDE_TEST_SEGFAULT_ABOVE": repr(thr)}
        t0 = time.perf_counter()
        p = _cli(path, Path(tmp) / "o", env)
        _, err = p.communicate(timeout=600)
        wall = time.perf_counter() - t0
        r = read_hdf5(Path(tmp) / "o" / "seg.h5").run("mc") if p.returncode == 0 else None
        return {"n": n, "segfaulting": k, "exit": p.returncode,
                "failed": None if r is None else r.n_failed,
                "reasons": sorted(set(map(str, r.reasons[r.failed]))) if r else err[-300:],
                "wall_s": wall}


def kill_and_resume(kill_points: list[int], n: int = 1000, chunk: int = 100, k: int = 4
                    ) -> list[dict]:
    """Measurement 2: kill after ``m`` manifest lines for each ``m`` of ``kill_points``."""
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        cfg, thr = crash_config(n, chunk, k)
        path = Path(tmp) / "seg.yaml"
        path.write_text(yaml.safe_dump(cfg))
        env = {**ENV, "UQGUIDE_TEST_SEGFAULT_ABOVE": repr(thr), "UQGUIDE_TEST_SLEEP_S": "0.02"}
        ref = Path(tmp) / "ref"
        p = _cli(path, ref, env)
        p.communicate(timeout=600)
        want = result_hash(ref / "seg.h5")
        for m in kill_points:
            out = Path(tmp) / f"k{m}"
            p = _cli(path, out, env)
            deadline = time.monotonic() + 300
            while len(_manifest(out)) < m + 1 and p.poll() is None \
                    and time.monotonic() < deadline:
                time.sleep(0.01)
            p.send_signal(signal.SIGKILL)
            p.communicate(timeout=60)
            before = _manifest(out)
            known = {str(e["row"]) for e in before if e.get("kind") == "isolated"}
            calls = Path(tmp) / f"calls{m}.log"
            q = _cli(path, out, {**env, "UQGUIDE_TEST_CALL_LOG": str(calls)}, "--resume")
            _, err = q.communicate(timeout=600)
            rerun = len(calls.read_text().splitlines()) if calls.is_file() else 0
            same = q.returncode == 0 and result_hash(out / "seg.h5") == want
            rows.append({"killed after lines": m,
                         "chunks done": sum(e.get("kind") == "chunk" for e in before),
                         "crashers known": len(known), "resume exit": q.returncode,
                         "crashers run again": rerun - (k - len(known)),
                         "bit-identical": same})
    return rows


def overhead(sizes: list[int], repeats: int = 3) -> list[dict]:
    """Measurement 3 (in this process: the driver is this one)."""
    rows = []
    for n in sizes:
        times = {}
        for isolate in (False, True):
            cfg = mc_config("tests.failing_models:clean_sum", n, 8192)
            cfg["model"]["isolate"] = isolate
            c = uqguide.load_config(cfg)
            best = np.inf
            for _ in range(repeats):
                t0 = time.perf_counter()
                uqguide.run(c)
                best = min(best, time.perf_counter() - t0)
            times[isolate] = best
        rows.append({"n_samples": n, "in the driver s": times[False],
                     "in a guard process s": times[True],
                     "overhead s": times[True] - times[False],
                     "overhead us/sample": 1e6 * (times[True] - times[False]) / n})
    return rows


def table(rows: list[dict]) -> str:
    keys = list(rows[0])
    fmt = [lambda v: f"{v:.3g}" if isinstance(v, float) else str(v)] * len(keys)
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    lines += ["| " + " | ".join(f(r[k]) for f, k in zip(fmt, keys)) + " |" for r in rows]
    return "\n".join(lines)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args()
    print("1. serial run, segfaulting samples")
    one = segfaults()
    print(table([one]))
    points = [2, 6] if args.quick else [1, 2, 3, 4, 5, 6, 7, 8, 10, 12]
    print("\n2. SIGKILL mid-run, then --resume (1000 samples, chunks of 100, 4 segfaulting)")
    two = kill_and_resume(points)
    print(table(two))
    sizes = [1000, 100_000] if args.quick else [1000, 10_000, 100_000, 1_000_000]
    print("\n3. isolation overhead, cheap callable y = a + b, one process, best of 3")
    print(table(overhead(sizes)))
    ok = one["failed"] == 4 and one["exit"] == 0 and all(
        r["bit-identical"] and r["crashers run again"] == 0 for r in two)
    print("\nOK" if ok else "\nFAILED")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
