"""``pce_adaptive`` at its defaults on a smooth model of 30, 40 and 60 inputs (issue 46: it used
to make its runs and then overflow in the exact moments): it finishes, and its statistics hold
the closed form.

Tolerances: the mean and std of the surrogate differ from the model's by at most the L2 norm
of the surrogate's error, ``sqrt(LOO) std`` with the corrected LOO error as its estimate (3x
for an estimate); every printed ``+cv`` value and the PCE's own value lie within 4 standard
errors of the ``+cv`` 95% interval (half-width / 1.96) of the truth.
"""

from __future__ import annotations

import numpy as np
import pytest

import uqguide
from uqguide.methods.pce_adaptive import AdaptivePCE

from .fixtures_models import EXP_RATE, sum_of_exponentials


def _exact(d: int) -> dict[str, float]:
    """Cumulants of independent terms add; ``E[exp(k s x)] = exp(k^2 s^2 / 2)``."""
    w = 1.0 / np.sqrt(np.arange(1, d + 1))
    m = [np.exp(k * k * EXP_RATE**2 / 2) for k in range(5)]  # raw moments of one term
    c2 = m[2] - m[1] ** 2
    c3 = m[3] - 3 * m[1] * m[2] + 2 * m[1] ** 3
    c4 = m[4] - 4 * m[1] * m[3] + 6 * m[1] ** 2 * m[2] - 3 * m[1] ** 4 - 3 * c2**2
    k2, k3, k4 = (w**2).sum() * c2, (w**3).sum() * c3, (w**4).sum() * c4
    return {"mean": m[1] * w.sum(), "std": np.sqrt(k2), "skewness": k3 / k2**1.5,
            "kurtosis": 3.0 + k4 / k2**2}


@pytest.mark.slow
@pytest.mark.parametrize("d", [30, 40, 60])
def test_many_inputs_at_the_defaults(d):
    names = [f"x{i + 1}" for i in range(d)]
    result = uqguide.run({
        "model": {"name": "callable", "function": sum_of_exponentials, "inputs": names,
                  "outputs": ["y"], "isolate": False},
        "inputs": [{"name": n, "dist": "normal", "mean": 0.0, "std": 1.0} for n in names],
        "methods": [{"name": "pce_adaptive", "label": "apce"}], "seed": 1})
    run = result.run("apce")
    assert run.success, run.message
    diag = run.estimate.diagnostics
    assert diag["moments_method"] == "exact"  # the linearisation, past 2^63 codes
    sizes = AdaptivePCE.default_sizes(d)
    assert run.n_runs <= sizes["most runs"]
    exact = _exact(d)
    s = run.estimate.stats["y"]
    bound = 3 * np.sqrt(diag["loo_error"]) * exact["std"]
    assert abs(s.mean[0] - exact["mean"]) <= bound
    assert abs(s.std[0] - exact["std"]) <= bound
    for k, truth in exact.items():
        lo, hi = s.corrected_ci[k][:, 0]
        se = (hi - lo) / 2 / 1.96
        assert abs(s.corrected[k][0] - truth) <= 4 * se, k
        assert abs(getattr(s, k)[0] - truth) <= 4 * se, k
