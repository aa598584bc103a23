"""Accuracy of the PCE methods against closed forms, budget by budget.

For each benchmark model (``linear_gaussian``, ``lognormal``, ``ishigami``, ``borehole``) and each
budget of model runs (default 50, 100, 200, 500, 1000), every method is given the largest design
that fits the budget, and the relative errors of its mean, std, skewness and kurtosis against
the reference are printed as one table per model:

- ``tensor``: full-tensor PCE, the largest ``m`` with ``m^d <= budget`` (skipped below m = 2);
- ``smolyak``: Smolyak PCE with Gauss rules, the largest level whose grid fits;
- ``smolyak-nested``: the same with nested rules (Genz-Keister / Gauss-Patterson);
- ``adaptive``: adaptive sparse PCE at its defaults on a Sobol' design of ``budget`` runs (no
  enrichment, so every regression method sees the same number of runs; q-norm, degree and
  terms chosen by corrected LOO);
- ``chaospy-pc``: chaospy's own point collocation as the baseline: ``fit_regression`` of the
  total-degree expansion of ``InputSpace.joint`` on ``budget`` Sobol' points, the largest
  degree with at most ``budget / 2`` terms (oversampling 2); mean by ``chaospy.E``, std,
  skewness and kurtosis from 2^17 Sobol' draws of the chaospy surrogate (``chaospy.Std / Skew
  / Kurt`` expand the polynomial's powers symbolically: minutes for the 8-input borehole).

Where a method's skewness / kurtosis are sampled from its surrogate (``moments_method``
``surrogate-sampling``: the exact rule would exceed 250,000 nodes), it samples 2^20 scrambled
Sobol' points (``surrogate_sampling: sobol``), so the table shows the surrogate's accuracy, not
the sampling noise of 10^6 random draws (2e-3 in skewness).

References: ``linear_gaussian`` (first component) and ``lognormal`` in closed form; ``ishigami``:
mean and variance in closed form, skewness 0 (sum of independent symmetric parts), kurtosis by
a 60^3-node Gauss-Legendre rule on the function; ``borehole``: all four by a tensor Gauss rule
on the function (Gauss-Hermite in ``rw`` and ``log r``, Gauss-Legendre in the rest), 8 nodes per
input, whose difference from 7 nodes is printed as the reference's own accuracy. A reference of
zero (skewness of ``linear_gaussian`` and ``ishigami``) is compared by absolute error (marked
``abs``).

    python benchmarks/pce_accuracy.py [--budgets 50 100 200 500 1000] [--models ishigami ...]

Runs in a few minutes on two cores (under 10).
"""

from __future__ import annotations

import argparse
import logging
import math
import time
import warnings
from typing import Any

import chaospy
import numpy as np

from uqguide.core.inputs import InputSpace, LogNormal, Normal, Uniform
from uqguide.methods.base import Method
from uqguide.methods.pce_adaptive import AdaptivePCE
from uqguide.methods.pce_smolyak import SmolyakPCE
from uqguide.methods.pce_tensor import TensorPCE
from uqguide.models.base import Model
from uqguide.core.types import STAT_NAMES, ModelOutput
from uqguide.models.benchmarks import Borehole, Ishigami, LinearGaussian, Lognormal
from uqguide.pce.germ import Germ
from uqguide.pce.quadrature import gauss_rule, smolyak_grid

BUDGETS = (50, 100, 200, 500, 1000)
SEED = 2024


# ---------------------------------------------------------------------- cases
def _normals(d: int, mean: float = 0.0, std: float = 1.0) -> InputSpace:
    return InputSpace([Normal(name=f"x{i + 1}", dist="normal", mean=mean, std=std)
                       for i in range(d)])


def _borehole_space() -> InputSpace:
    u = [("Tu", 63070, 115600), ("Hu", 990, 1110), ("Tl", 63.1, 116), ("Hl", 700, 820),
         ("L", 1120, 1680), ("Kw", 9855, 12045)]
    return InputSpace([Normal(name="rw", dist="normal", mean=0.10, std=0.0161812),
                       LogNormal(name="r", dist="lognormal", mu=7.71, sigma=1.0056)]
                      + [Uniform(name=n, dist="uniform", low=lo, high=hi) for n, lo, hi in u])


def _moments(y: np.ndarray, w: np.ndarray) -> dict[str, float]:
    """Weighted mean, std, skewness, kurtosis of values ``y`` with weights ``w`` (sum 1)."""
    m = w @ y
    d = y - m
    mu2, mu3, mu4 = (w @ d**k for k in (2, 3, 4))
    return {"mean": m, "std": math.sqrt(mu2), "skewness": mu3 / mu2**1.5,
            "kurtosis": mu4 / mu2**2}


def _tensor_gauss_moments(model: Model, space: InputSpace, output: str, nodes: int
                          ) -> dict[str, float]:
    """Moments of ``model`` by a tensor Gauss rule on the germ, evaluated chunk by chunk."""
    germ = Germ.of(space)
    rules = [gauss_rule(germ.kind(j), nodes) for j in range(space.dim)]
    sizes = (nodes,) * space.dim
    n = nodes**space.dim
    sums = np.zeros(5)
    shift = None
    for start in range(0, n, 1_000_000):
        idx = np.unravel_index(np.arange(start, min(n, start + 1_000_000)), sizes)
        xi = np.stack([rules[j][0][idx[j]] for j in range(space.dim)], axis=1)
        w = np.prod([rules[j][1][idx[j]] for j in range(space.dim)], axis=0)
        y = model.evaluate(germ.to_physical(xi), space.names, [output]).scalars[output][:, 0]
        shift = w @ y / w.sum() if shift is None else shift
        z = y - shift
        sums += [w.sum(), w @ z, w @ z**2, w @ z**3, w @ z**4]
    s0, s1, s2, s3, s4 = sums
    m1, m2, m3, m4 = s1 / s0, s2 / s0, s3 / s0, s4 / s0
    mu2 = m2 - m1**2
    mu3 = m3 - 3 * m1 * m2 + 2 * m1**3
    mu4 = m4 - 4 * m1 * m3 + 6 * m1**2 * m2 - 3 * m1**4
    return {"mean": shift + m1, "std": math.sqrt(mu2), "skewness": mu3 / mu2**1.5,
            "kurtosis": mu4 / mu2**2}


def cases() -> list[dict[str, Any]]:
    """Model, input space, output, component and reference statistics of each benchmark."""
    lin = LinearGaussian()
    lin_space = _normals(3, mean=1.0, std=2.0)
    mu, cov = lin.exact_mean_cov(np.full(3, 1.0), 4.0 * np.eye(3))
    logn = Lognormal()
    ish = Ishigami()
    ish_space = InputSpace([Uniform(name=f"x{i + 1}", dist="uniform", low=-np.pi, high=np.pi)
                            for i in range(3)])
    ex = ish.exact()
    ish_kurt = _tensor_gauss_moments(ish, ish_space, "y", 60)["kurtosis"]
    bore, bore_space = Borehole(), _borehole_space()
    bore_ref = _tensor_gauss_moments(bore, bore_space, "flow", 8)
    bore_check = _tensor_gauss_moments(bore, bore_space, "flow", 7)
    return [
        {"name": "linear_gaussian", "model": lin, "space": lin_space, "output": "y",
         "ref": {"mean": mu[0], "std": math.sqrt(cov[0, 0]), "skewness": 0.0, "kurtosis": 3.0},
         "note": "y1 = x1 + 2 x2 - 0.5 x3, x ~ N(1, 2^2): closed form"},
        {"name": "lognormal", "model": logn, "space": _normals(3), "output": "y",
         "ref": logn.exact_moments(), "note": "exp(0.3 x1 + 0.2 x2 + 0.1 x3): closed form"},
        {"name": "ishigami", "model": ish, "space": ish_space, "output": "y",
         "ref": {"mean": ex["mean"], "std": math.sqrt(ex["variance"]), "skewness": 0.0,
                 "kurtosis": ish_kurt},
         "note": "a = 7, b = 0.1: mean, variance closed form; kurtosis by 60^3 Gauss-Legendre"},
        {"name": "borehole", "model": bore, "space": bore_space, "output": "flow",
         "ref": bore_ref,
         "note": "reference by 8^8 tensor Gauss; |8 - 7 nodes| relative: " + ", ".join(
             f"{k} {abs(bore_ref[k] - bore_check[k]) / abs(bore_ref[k]):.1e}"
             for k in STAT_NAMES)},
    ]


# ---------------------------------------------------------------------- methods
def run_method(method: Method, model: Model, space: InputSpace, output: str
               ) -> tuple[dict[str, float], int]:
    """Design -> evaluate -> refine -> estimate (the driver's loop); first component's stats."""
    design = method.design(space, SEED)
    out = model.evaluate(design.x, space.names, [output])
    while (bigger := method.refine(space, design, out)) is not None:
        more = model.evaluate(bigger.x[design.n_runs:], space.names, [output])
        design, out = bigger, ModelOutput.concatenate([out, more])
    s = method.estimate(space, design, out).stats[output]
    return {k: float(s.stat(k)[0]) for k in STAT_NAMES}, out.n


def _largest_level(space: InputSpace, nested: bool, budget: int) -> int | None:
    germ = Germ.of(space)
    best = None
    for level in range(2, 13):
        rules = [{"normal": "genz_keister", "uniform": "patterson"}.get(f, "gauss") if nested
                 else "gauss" for f in germ.families]
        try:
            n = smolyak_grid(germ, level - 1, rules).n_nodes
        except ValueError:  # chaospy's nested tables end
            break
        if n > budget:
            break
        best = level
    return best


def chaospy_point_collocation(model: Model, space: InputSpace, output: str, budget: int
                              ) -> tuple[dict[str, float], int]:
    dist = space.joint
    p = 1
    while math.comb(p + 1 + space.dim, space.dim) <= budget // 2:
        p += 1
    expansion = chaospy.generate_expansion(p, dist, normed=True)
    samples = dist.sample(budget, rule="sobol", seed=SEED)  # chaospy's (d, n)
    y = model.evaluate(samples.T, space.names, [output]).scalars[output][:, 0]
    poly = chaospy.fit_regression(expansion, samples, y)
    # Std, skewness and kurtosis from 2^17 Sobol' draws of the surrogate: chaospy.Std / Skew /
    # Kurt expand the polynomial's powers symbolically, which takes minutes for 8 inputs.
    draws = poly(*dist.sample(2**17, rule="sobol", seed=SEED))
    d = draws - draws.mean()
    mu2, mu3, mu4 = (np.mean(d**k) for k in (2, 3, 4))
    return {"mean": float(chaospy.E(poly, dist)), "std": float(math.sqrt(mu2)),
            "skewness": float(mu3 / mu2**1.5), "kurtosis": float(mu4 / mu2**2)}, budget


def methods_for(space: InputSpace, budget: int) -> list[tuple[str, Any]]:
    d = space.dim
    out: list[tuple[str, Any]] = []
    m = int(math.floor(budget ** (1.0 / d) + 1e-9))
    qmc = {"surrogate_sampling": "sobol"}
    out.append(("tensor", TensorPCE({"m": m, **qmc}) if m >= 2 else None))
    for nested in (False, True):
        level = _largest_level(space, nested, budget)
        out.append(("smolyak-nested" if nested else "smolyak",
                    SmolyakPCE({"level": level, "nested": nested, **qmc}) if level else None))
    out.append(("adaptive", AdaptivePCE({"n_samples": budget, **qmc})))
    out.append(("chaospy-pc", "chaospy"))
    return out


def _err(value: float, ref: float) -> str:
    if not np.isfinite(value):
        return f"{'nan':>9}"
    if ref == 0.0:
        return f"{abs(value):9.1e}"
    return f"{abs(value - ref) / abs(ref):9.1e}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--budgets", type=int, nargs="+", default=list(BUDGETS))
    ap.add_argument("--models", nargs="+", default=None)
    args = ap.parse_args()
    logging.basicConfig(level=logging.ERROR)
    warnings.simplefilter("ignore")  # chaospy's deprecation chatter; errors still raise
    t0 = time.perf_counter()
    for case in cases():
        if args.models and case["name"] not in args.models:
            continue
        ref = case["ref"]
        print(f"\n## {case['name']} ({case['note']})")
        print("reference: " + ", ".join(f"{k} {ref[k]:.6g}" for k in STAT_NAMES))
        head = "relative error" + (" (skewness: abs)" if ref["skewness"] == 0.0 else "")
        print(f"{'budget':>6}  {'method':<15}{'runs':>6}  {'mean':>9}{'std':>9}{'skewness':>9}"
              f"{'kurtosis':>9}  {'fit s':>6}   {head}")
        for budget in args.budgets:
            for label, method in methods_for(case["space"], budget):
                if method is None:
                    print(f"{budget:>6}  {label:<15}{'-':>6}  (no design within the budget)")
                    continue
                t = time.perf_counter()
                try:
                    if method == "chaospy":
                        stats, n = chaospy_point_collocation(case["model"], case["space"],
                                                             case["output"], budget)
                    else:
                        stats, n = run_method(method, case["model"], case["space"],
                                              case["output"])
                except Exception as exc:  # a baseline that breaks is reported, not fatal
                    print(f"{budget:>6}  {label:<15}{'-':>6}  failed: {type(exc).__name__}: "
                          f"{str(exc)[:60]}")
                    continue
                errs = "".join(_err(stats[k], ref[k]) for k in STAT_NAMES)
                print(f"{budget:>6}  {label:<15}{n:>6}  {errs}  {time.perf_counter() - t:6.1f}")
    print(f"\ntotal {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
