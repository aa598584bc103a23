"""Adaptive PCE of the Ishigami function from a data file of iid rows (issue 28's acceptance).

    python benchmarks/data_ishigami.py [--rows 500] [--seeds 0,1,2,3,4] [--sampling random]

For each seed: ``--rows`` iid uniform rows on [-pi, pi]^3 (or a scrambled Sobol' design,
``--sampling sobol``) with y = sin x1 + 7 sin^2 x2 + 0.1 x3^4 sin x1, written to a CSV with
``repr`` precision and run through a ``data:`` config with ``pce_adaptive`` at its defaults.
Columns: the errors of the four moments against the exact values (mean and variance in closed
form, skewness 0 by symmetry, kurtosis by an 80^3-point Gauss-Legendre rule, exact to
round-off), the fit's degree, terms and LOO error, its CPU seconds, and whether
``uqguide.fit`` on the same arrays gives the same four numbers bit for bit.
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

import uqguide
from uqguide.models.benchmarks import Ishigami

INPUTS = [{"name": f"x{i}", "dist": "uniform", "low": -math.pi, "high": math.pi}
          for i in (1, 2, 3)]


def exact() -> np.ndarray:
    ex = Ishigami().exact()
    g, w = np.polynomial.legendre.leggauss(80)
    g, w = g * math.pi, w / 2
    X1, X2, X3 = np.meshgrid(g, g, g, indexing="ij")
    W = w[:, None, None] * w[None, :, None] * w[None, None, :]
    c = np.sin(X1) + 7 * np.sin(X2) ** 2 + 0.1 * X3**4 * np.sin(X1) - ex["mean"]
    return np.array([ex["mean"], math.sqrt(ex["variance"]), 0.0,
                     float((W * c**4).sum()) / ex["variance"] ** 2])


def moments(result: uqguide.Result) -> np.ndarray:
    st = result.run("pce_adaptive").estimate.stats["y"]
    return np.array([float(np.ravel(st.stat(k))[0])
                     for k in ("mean", "std", "skewness", "kurtosis")])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", type=int, default=500)
    ap.add_argument("--seeds", default="0,1,2,3,4")
    ap.add_argument("--sampling", choices=("random", "sobol"), default="random")
    args = ap.parse_args()
    ref = exact()
    print(f"{args.rows} {args.sampling} rows; exact mean {ref[0]:.15g}, std {ref[1]:.15g}, "
          f"skewness 0, kurtosis {ref[3]:.15g}")
    print(f"{'seed':>4} {'d mean':>9} {'d std':>9} {'d skew':>9} {'d kurt':>9} {'degree':>6} "
          f"{'terms':>5} {'loo':>9} {'cpu s':>6} fit==config")
    worst = 0.0
    for seed in (int(s) for s in args.seeds.split(",")):
        if args.sampling == "sobol":
            from scipy.stats import qmc

            u = qmc.Sobol(3, seed=seed).random(args.rows)
        else:
            u = np.random.default_rng(seed).random((args.rows, 3))
        x = -math.pi + 2 * math.pi * u
        y = np.sin(x[:, 0]) + 7 * np.sin(x[:, 1]) ** 2 + 0.1 * x[:, 2] ** 4 * np.sin(x[:, 0])
        with tempfile.TemporaryDirectory() as tmp:
            cells = np.column_stack([x, y]).tolist()
            (Path(tmp) / "runs.csv").write_text("x1,x2,x3,y\n" + "\n".join(
                ",".join(repr(v) for v in r) for r in cells) + "\n")
            cfg = Path(tmp) / "ish.yaml"
            cfg.write_text(yaml.safe_dump({"data": "runs.csv", "inputs": INPUTS,
                                           "methods": [{"name": "pce_adaptive"}]}))
            t0 = time.process_time()
            result = uqguide.run(cfg)
            cpu = time.process_time() - t0
        got = moments(result)
        same = np.array_equal(moments(uqguide.fit(x, y, inputs=INPUTS)), got)
        err = np.abs(got - ref)
        worst = max(worst, float(err.max()))
        d = result.run("pce_adaptive").estimate.diagnostics
        print(f"{seed:>4} {err[0]:9.1e} {err[1]:9.1e} {err[2]:9.1e} {err[3]:9.1e} "
              f"{d['degree']:>6} {d['n_terms']:>5} {d['loo_error']:9.1e} {cpu:6.2f} {same}")
    print(f"largest error of the four moments: {worst:.1e}")


if __name__ == "__main__":
    main()
