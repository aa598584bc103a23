"""Requirement verdicts over many seeds: rates of wrong pass and wrong fail, runs to a decision.

Models with a known success probability: ``y = x1``, one standard normal, and the requirement
``P(y < b) >= p`` at confidence ``c`` with ``b = Phi^-1(p_true)``, for ``p_true`` just inside
(failure probability ``(1 - p) / 2``), at the boundary (``p``) and just outside (``2 (1 - p)``)
of each requirement: the 3-sigma rule (0.9973 at 90%) and 95/95. Each seed runs the whole
pipeline (``monte_carlo``, verdicts as ``uqguide run`` gives them):

- ``fixed``: ``n_samples`` the zero-failure plan (852, 59), Clopper-Pearson verdicts;
- ``sequential``: ``stop_when: decided``, chunks of ``--chunk`` runs, capped at ``--cap``.

Per case the table gives the share of ``pass``, ``fail`` and ``undecided`` verdicts with the
95% Clopper-Pearson interval of the rate that the guarantee bounds by ``1 - c`` (``pass``
outside and at the boundary, ``fail`` inside and at the boundary), and the mean runs (of the
decided runs: runs to a decision).

    python benchmarks/requirements.py [--seeds 2000] [--cap 20000] [--chunk 128]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
from scipy import stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from uqguide.config.run_config import validate_config  # noqa: E402
from uqguide.core.events import clopper_pearson  # noqa: E402
from uqguide.driver.propagate import run  # noqa: E402
from uqguide.stats.verdicts import runs_to_pass  # noqa: E402

#: (probability, confidence) of each requirement.
REQUIREMENTS = ((0.9973, 0.9), (0.95, 0.95))


def config(p_true: float, target: float, confidence: float, n: int, sequential: bool,
           chunk: int) -> object:
    """One standard normal ``y`` and the requirement ``P(y < Phi^-1(p_true)) >= target``."""
    method = {"name": "monte_carlo", "label": "mc", "n_samples": n, "chunk_size": chunk,
              "bootstrap": 0, "sensitivity": "off", "intervals": "delta"}
    if sequential:
        method["stop_when"] = "decided"
    return validate_config({
        "model": {"name": "linear_gaussian", "coefficients": [[1.0]]},
        "inputs": [{"name": "x1", "dist": "normal", "mean": 0.0, "std": 1.0}],
        "requirements": [{"name": "r", "output": "y", "below": float(stats.norm.ppf(p_true)),
                          "probability": target, "confidence": confidence}],
        "methods": [method]})


def _rate(k: int, n: int) -> str:
    lo, hi = clopper_pearson(k, n)
    return f"{k / n:.4f} [{lo:.4f}, {hi:.4f}]"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2000)
    ap.add_argument("--cap", type=int, default=20_000)
    ap.add_argument("--chunk", type=int, default=128)
    args = ap.parse_args()
    head = ("requirement", "p_true", "mode", "n", "pass", "fail", "undecided",
            "bounded rate [95% CI]", "<= 1-c", "mean runs", "runs to decision", "CPU s")
    rows = []
    for target, c in REQUIREMENTS:
        plan = runs_to_pass(target, c)
        q = 1.0 - target
        for where, p_true in (("inside", 1 - q / 2), ("boundary", target),
                              ("outside", 1 - 2 * q)):
            for mode in ("fixed", "sequential"):
                n = plan if mode == "fixed" else args.cap
                cfg = config(p_true, target, c, n, mode == "sequential", args.chunk)
                t0 = time.process_time()
                verdicts, runs = [], []
                for seed in range(args.seeds):
                    r = run(cfg.with_seed(seed)).runs[0]  # type: ignore[attr-defined]
                    verdicts.append(r.verdicts["r"].verdict)
                    runs.append(r.n_runs)
                v, m = np.array(verdicts), np.array(runs)
                k = {x: int(np.sum(v == x)) for x in ("pass", "fail", "undecided")}
                bounded = {"inside": ["fail"], "outside": ["pass"],
                           "boundary": ["pass", "fail"]}[where]
                rate = "; ".join(f"{b} {_rate(k[b], args.seeds)}" for b in bounded)
                ok = all(clopper_pearson(k[b], args.seeds)[0] <= 1 - c for b in bounded)
                decided = m[v != "undecided"]
                rows.append((f"{target} at {c:g}", f"{p_true:.5g} ({where})", mode, str(n),
                             f"{k['pass'] / args.seeds:.4f}", f"{k['fail'] / args.seeds:.4f}",
                             f"{k['undecided'] / args.seeds:.4f}", rate,
                             "yes" if ok else "NO", f"{m.mean():.0f}",
                             f"{decided.mean():.0f}" if decided.size else "-",
                             f"{time.process_time() - t0:.1f}"))
                print(" | ".join(rows[-1]), flush=True)
    print()
    print("| " + " | ".join(head) + " |")
    print("|" + "---|" * len(head))
    for row in rows:
        print("| " + " | ".join(row) + " |")


if __name__ == "__main__":
    main()
