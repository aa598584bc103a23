"""Derived outputs: a miss distance through the surrogate of its (smooth) miss vector."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest
from scipy import stats as sps

from uqguide.methods.base import RunContext
from uqguide.errors import MethodError
from uqguide.methods.pce_adaptive import AdaptivePCE
from uqguide.methods.pce_smolyak import SmolyakPCE
from uqguide.methods.pce_tensor import TensorPCE
from uqguide.models.base import InputInfo, Model, OutputInfo
from uqguide.core.types import DerivedOutput, ModelOutput

from .test_pce_helpers import normal_space, run_method


class _Planar(Model):
    """Miss vector ``m = (x1, 0.5 x1 + x2)`` and the distance ``hypot(x1, x3)``."""

    name = "planar"
    summary = "a miss vector and a distance"

    def inputs(self):
        return tuple(InputInfo(f"x{i}", "m", "") for i in (1, 2, 3))

    def outputs(self):
        return (OutputInfo("m", "scalar", "m", "miss vector", ("a", "b")),
                OutputInfo("dist", "scalar", "m", "hypot(x1, x3)"))

    def _evaluate(self, values: Mapping[str, np.ndarray], n: int, outputs: frozenset[str]):
        x1, x2, x3 = values["x1"], values["x2"], values["x3"]
        scalars = {"m": np.c_[x1, 0.5 * x1 + x2], "dist": np.hypot(x1, x3)[:, None]}
        return ModelOutput(time=np.zeros(0), scalars=scalars, failed=np.zeros(n, bool),
                           reasons=np.full(n, "", object))


DIST = DerivedOutput(("m",), lambda c, x: np.hypot(c["m"][:, 0], x["x3"])[:, None])
N_DRAWS = 200_000


def _rayleigh_reference():
    """Rayleigh(1) moments and the standard errors of their estimators from N_DRAWS random
    draws (skewness / kurtosis: sqrt(Var(Z^3) / n), sqrt(Var(Z^4) / n) of the standardised Z,
    which ignores the estimated normalisation and so overstates the error a little). The
    methods draw scrambled Sobol' points, whose errors are smaller still: a bound."""
    r = sps.rayleigh()
    m, s = r.mean(), r.std()
    z = [r.expect(lambda v, k=k: ((v - m) / s) ** k) for k in range(9)]
    se = {"mean": s / np.sqrt(N_DRAWS), "std": s * np.sqrt((z[4] - 1) / 4 / N_DRAWS),
          "skewness": np.sqrt((z[6] - z[3] ** 2) / N_DRAWS),
          "kurtosis": np.sqrt((z[8] - z[4] ** 2) / N_DRAWS)}
    return {"mean": m, "std": s, "skewness": z[3], "kurtosis": z[4]}, se


@pytest.mark.parametrize("method", [
    TensorPCE({"m": 2, "surrogate_draws": N_DRAWS}),
    SmolyakPCE({"level": 2, "surrogate_draws": N_DRAWS}),
    AdaptivePCE({"n_samples": 20, "degree_min": 1, "degree_max": 2,
                 "surrogate_draws": N_DRAWS})], ids=lambda m: m.name)
def test_distance_from_its_miss_vector(method):
    method = method.with_context(RunContext(derived={"dist": DIST}))
    est, _ = run_method(method, _Planar(), normal_space(3))
    s = est.stats["dist"]
    assert s.moments_method == "surrogate-sampling" and s.sobol_first is None
    ref, se = _rayleigh_reference()
    for name, value in ref.items():
        assert abs(s.stat(name)[0] - value) <= 5 * se[name], (name, s.stat(name)[0], value)
    # The stacked scalars: m (exact, linear) and dist, jointly sampled.
    assert est.scalar_names == ["m[0]", "m[1]", "dist"]
    assert est.diagnostics["scalar_moments"] == "surrogate-sampling"
    np.testing.assert_allclose(est.scalar_cov[:2, :2], [[1.0, 0.5], [0.5, 1.25]], rtol=0.02)
    assert abs(est.scalar_cov[0, 2]) < 5 * np.sqrt(1.0 * ref["std"] ** 2 / N_DRAWS)
    assert "dist from m" in est.diagnostics["derived"]


def test_missing_carrier_is_an_error():
    method = TensorPCE({"m": 2}, RunContext(derived={"dist": DerivedOutput(("r",),
                                                                           DIST.function)}))
    with pytest.raises(MethodError, match="derived from r, but the runs have no r"):
        run_method(method, _Planar(), normal_space(3))
