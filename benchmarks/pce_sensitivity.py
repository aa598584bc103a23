"""Sobol' indices of an adaptive PCE against the exact values, and the coverage of their 95%
intervals (:mod:`uqguide.pce.sobol_indices`), over seeds.

Cases (``--cases``):

- ``ishigami-N``: ``sin x1 + 7 sin^2 x2 + 0.1 x3^4 sin x1``, ``x ~ U(-pi, pi)^3``; exact first
  (0.3139, 0.4424, 0), total (0.5576, 0.4424, 0.2437);
- ``gfun-N``: the 8-input Sobol' G-function, ``a = (0, 1, 4.5, 9, 99, 99, 99, 99)``,
  ``x ~ U(0, 1)^8``: ``V_i = 1 / (3 (1 + a_i)^2)``, ``S_i = V_i / V``,
  ``S_Ti = V_i prod_{j != i} (1 + V_j) / V``, ``V = prod (1 + V_j) - 1``; non-smooth (a kink in
  every factor), the hard case for a polynomial;

with ``N`` the runs of the adaptive PCE's design (scrambled Sobol', default settings, no
enrichment), and with ``--validation M`` as many random validation runs after the fit (whose
out-of-sample error then sets the truncation bound instead of the LOO error). For each seed
the method runs end to end (design, runs, fit, indices with their
bootstrap-and-truncation intervals); the table gives per index the mean error (bias), its
standard deviation over the seeds, the largest absolute error, the coverage of the 95%
interval, its mean width, and the median CPU seconds of the estimate: the fit with its indices
(with ``--validation`` the fit made to place the validation runs is reused, and the column is
the indices' and statistics' cost alone).

    python benchmarks/pce_sensitivity.py [--cases ishigami-60 gfun-300] [--seeds 50]
                                         [--validation M]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from uqguide.core.inputs import InputSpace, Uniform
from uqguide.methods.pce_adaptive import AdaptivePCE
from uqguide.models.benchmarks import Ishigami
from uqguide.models.sobol_g import SobolG

G_A = np.array([0.0, 1.0, 4.5, 9.0, 99.0, 99.0, 99.0, 99.0])


def g_exact(a: np.ndarray = G_A) -> tuple[np.ndarray, np.ndarray]:
    """Exact first-order and total indices of the G-function with ``x ~ U(0, 1)``."""
    v = 1.0 / (3.0 * (1.0 + a) ** 2)
    var = np.prod(1.0 + v) - 1.0
    return v / var, v * np.prod(1.0 + v) / (1.0 + v) / var


def case(name: str):
    kind, runs = name.rsplit("-", 1)
    if kind == "ishigami":
        model = Ishigami()
        space = InputSpace([Uniform(name=f"x{i + 1}", dist="uniform", low=-np.pi, high=np.pi)
                            for i in range(3)])
        ex = model.exact()
        return model, space, int(runs), np.asarray(ex["first"]), np.asarray(ex["total"])
    if kind == "gfun":
        model = SobolG({"a": G_A.tolist()})
        space = InputSpace([Uniform(name=f"x{i + 1}", dist="uniform", low=0.0, high=1.0)
                            for i in range(G_A.size)])
        first, total = g_exact()
        return model, space, int(runs), first, total
    raise SystemExit(f"unknown case '{name}' (ishigami-N or gfun-N)")


def one(model, space: InputSpace, runs: int, seed: int, validation: int = 0):
    """(first, first_ci, total, total_ci, cpu_s) of one seed."""
    settings: dict = {"n_samples": runs, "surrogate_draws": 20_000}
    if validation:
        settings["validation"] = {"n_samples": validation, "design": "random"}
    method = AdaptivePCE(settings)
    design = method.design(space, seed)
    out = model.evaluate(design.x, space.names)
    bigger = method.refine(space, design, out)  # the validation runs, when asked for
    if bigger is not None:
        more = model.evaluate(bigger.x[design.n_runs:], space.names)
        design, out = bigger, type(out).concatenate([out, more])
    t0 = time.process_time()
    s = method.estimate(space, design, out).stats["y"]
    cpu = time.process_time() - t0
    return s.sobol_first[0], s.sobol_first_ci[:, 0], s.sobol_total[0], s.sobol_total_ci[:, 0], cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cases", nargs="+", default=["ishigami-60", "ishigami-200", "gfun-300"])
    ap.add_argument("--seeds", type=int, default=50)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--validation", type=int, default=0,
                    help="random validation runs after the fit (their error, not the LOO "
                         "error, then sets the truncation bound)")
    args = ap.parse_args()
    head = (f"{'case':14s} {'index':6s} {'exact':>6s} {'bias':>8s} {'sd':>7s} {'max|err|':>8s} "
            f"{'cover95':>7s} {'width':>6s} {'cpu_s':>6s}")
    print(head)
    print("-" * len(head))
    for name in args.cases:
        model, space, runs, ex_first, ex_total = case(name)
        rows = [one(model, space, runs, s, args.validation)
                for s in range(args.first_seed, args.first_seed + args.seeds)]
        cpu = float(np.median([r[4] for r in rows]))
        if args.validation:
            name = f"{name}+v{args.validation}"
        for kind, exact, val, ci in (("S", ex_first, 0, 1), ("ST", ex_total, 2, 3)):
            est = np.array([r[val] for r in rows])          # (seeds, d)
            band = np.array([r[ci] for r in rows])          # (seeds, 2, d)
            err = est - exact
            cover = (band[:, 0] <= exact) & (exact <= band[:, 1])
            for i in range(exact.size):
                print(f"{name:14s} {kind + str(i + 1):6s} {exact[i]:6.3f} "
                      f"{err[:, i].mean():8.4f} {err[:, i].std(ddof=1):7.4f} "
                      f"{np.abs(err[:, i]).max():8.4f} {100 * cover[:, i].mean():6.0f}% "
                      f"{(band[:, 1, i] - band[:, 0, i]).mean():6.3f} {cpu:6.2f}")


if __name__ == "__main__":
    main()
