"""Every registered model and method against its contract (uqguide.testing), and proof that the
checks catch what they claim to: broken toys fail them with a message naming the rule."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import pytest
from pydantic import ConfigDict, Field

from uqguide.methods.base import Design, Method, StreamingMethod
from uqguide.methods.monte_carlo import MonteCarlo
from uqguide.models.base import InputInfo, Model, ModelParams, OutputInfo
from uqguide.core.types import ModelOutput
from uqguide.config.registry import METHODS, MODELS, method_class, model_class
from uqguide.testing import (ConformanceError, check_method, check_model, method_checks,
                             model_checks, parametrize_with_checks)


# One test case a rule and a class (uqguide.testing.parametrize_with_checks), so a broken rule
# fails on its own line. The FMU model needs the session's test FMU, so it is checked apart.
@parametrize_with_checks(models=[model_class(n) for n in sorted(MODELS) if n != "fmu"],
                         methods=[method_class(n) for n in sorted(METHODS)])
def test_every_registered_class_keeps_each_rule(check):
    check()


def test_the_fmu_model_keeps_the_contract(request):
    from tests.fmu_decay import example_params  # skips without FMPy

    check_model(model_class("fmu"), example_params(request.getfixturevalue("decay_fmu")))


# The 2-process pool check costs ~1-5 CPU-s a method (spawned workers, each importing uqguide
# and the benchmark model), so it runs with the slow tests for every method. The default suite
# keeps one cheap pooled run through the same executor path:
# tests/test_validation_design.py (a PCE's validation runs, serial and on 2 workers).
@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(METHODS))
def test_every_registered_method_keeps_the_contract_in_a_pool(name):
    checks = dict(method_checks(method_class(name)))
    checks["workers"]()


def test_the_named_checks_are_the_whole_contract():
    rules = [rule for rule, _ in model_checks(_Toy)]
    assert rules == ["metadata", "parameters", "shapes", "determinism", "batch-split invariance"]
    rules = [rule for rule, _ in method_checks(MonteCarlo)]
    assert rules == ["closed forms", "seeds", "batch size", "workers", "streaming", "resume",
                     "given rows"]


# ---------------------------------------------------------------------------- broken toys
class _ToyParams(ModelParams):
    gain: float = Field(default=2.0, allow_inf_nan=False)


class _Toy(Model):
    """``y = gain a + b``, correct; the subclasses below each break one rule."""

    name = "toy"
    summary = "toy"
    Params = _ToyParams

    def inputs(self):
        return (InputInfo("a", "1", "a", 1.0), InputInfo("b", "1", "b", 0.0))

    def outputs(self):
        return (OutputInfo("y", "scalar", "1", "y"),)

    def _y(self, values: Mapping[str, np.ndarray]) -> np.ndarray:
        return self.params.gain * values["a"] + values["b"]

    def _evaluate(self, values, n, outputs):
        return ModelOutput(time=np.zeros(0), scalars={"y": self._y(values)[:, None]},
                           failed=np.zeros(n, dtype=bool), reasons=np.full(n, "", dtype=object))


def test_a_correct_toy_passes():
    check_model(_Toy)


def test_a_model_returning_the_wrong_shape_fails_with_the_shape_named():
    class WrongShape(_Toy):
        def _evaluate(self, values, n, outputs):
            out = super()._evaluate(values, n, outputs)
            out.scalars["y"] = out.scalars["y"][:, 0]  # (n,) instead of (n, 1)
            return out

    with pytest.raises(ConformanceError, match=r"model 'toy': shapes: .*'y' has shape \(6,\), "
                                               r"expected \(6, 1\)"):
        check_model(WrongShape)


def test_a_model_drawing_from_the_global_random_state_fails_determinism():
    class Noisy(_Toy):
        def _y(self, values):
            return super()._y(values) + 1e-3 * np.random.standard_normal(values["a"].shape)

    with pytest.raises(ConformanceError, match="model 'toy': determinism"):
        check_model(Noisy)


def test_a_model_coupling_the_samples_of_a_batch_fails_the_batch_split():
    class Coupled(_Toy):
        def _y(self, values):
            y = super()._y(values)
            return y - y.mean()  # each sample depends on the others of its batch

    with pytest.raises(ConformanceError, match="model 'toy': batch-split invariance"):
        check_model(Coupled)


def test_each_named_check_fails_alone_for_the_rule_it_names():
    class Coupled(_Toy):
        def _y(self, values):
            y = super()._y(values)
            return y - y.mean()

    failed = []
    for rule, check in model_checks(Coupled):
        try:
            check()
        except ConformanceError as exc:
            assert f": {rule}: " in str(exc)
            failed.append(rule)
    assert failed == ["batch-split invariance"]


def test_a_model_whose_float_parameter_takes_nan_fails():
    class LaxParams(ModelParams):
        model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=True)
        gain: float = 2.0

    class Lax(_Toy):
        Params = LaxParams

    with pytest.raises(ConformanceError, match="model 'toy': parameters: 'gain' accepts nan"):
        check_model(Lax)


def test_a_failed_sample_without_a_reason_fails():
    class Silent(_Toy):
        def _evaluate(self, values, n, outputs):
            out = super()._evaluate(values, n, outputs)
            out.failed[0] = True  # no reason given
            return out

    with pytest.raises(ConformanceError, match="model 'toy': failure mask"):
        check_model(Silent)


def test_a_method_that_ignores_its_seed_fails():
    class SeedBlind(MonteCarlo):
        def design(self, space, seed):
            return super().design(space, 0)

    with pytest.raises(ConformanceError, match="method 'monte_carlo': seeds: seeds 5 and 6 give "
                                               "the same design"):
        check_method(SeedBlind, workers=False)


def test_a_method_with_a_biased_mean_fails_the_closed_form():
    class Biased(MonteCarlo):
        def estimate_reduced(self, space, design: Design, runs, acc):
            est = super().estimate_reduced(space, design, runs, acc)
            est.stats["y"].mean = est.stats["y"].mean + 0.5  # 0.5 is ~20 standard errors
            return est

    with pytest.raises(ConformanceError, match="method 'monte_carlo': closed forms: mean"):
        check_method(Biased, workers=False)


def test_a_streaming_method_whose_in_memory_estimate_differs_fails():
    class TwoWays(MonteCarlo):
        def estimate(self, space, design: Design, outputs):
            est = super().estimate(space, design, outputs)
            est.stats["y"].std = est.stats["y"].std * 1.001
            return est

    with pytest.raises(ConformanceError, match="method 'monte_carlo': streaming: the estimate "
                                               "of outputs in memory differs"):
        check_method(TwoWays, workers=False)


# ---------------------------------------------------------------------------- contract shapes
def test_the_driver_asks_the_class_not_flags():
    # Monte Carlo streams: its own chunk split, whatever the batch size, and it holds no
    # runs; the others are cut into batches and get every run.
    mc = MonteCarlo({"n_samples": 10, "chunk_size": 4})
    assert isinstance(mc, StreamingMethod) and not mc.holds_runs
    assert mc.chunks(10, 3) == [(0, 4), (4, 8), (8, 10)]
    pce = method_class("pce_tensor")({"m": 2})
    assert not isinstance(pce, StreamingMethod) and pce.holds_runs
    assert pce.chunks(10, 3) == [(0, 3), (3, 6), (6, 9), (9, 10)]
    assert pce.chunks(0, 3) == [(0, 0)]


def test_a_streaming_method_cannot_refine():
    with pytest.raises(TypeError, match="Refining: a streaming method cannot refine"):
        class Refining(MonteCarlo):
            def refine(self, space, design, outputs):
                return None


def test_the_retired_streaming_flag_is_refused_where_the_class_is_written():
    with pytest.raises(TypeError, match="Flagged: 'reduces_chunks' is retired; subclass "
                                        "uqguide.methods.base.StreamingMethod"):
        class Flagged(Method):
            reduces_chunks = True


def test_outputs_come_back_in_the_declared_order_whatever_the_model_filled():
    """A model looping over the set of wanted outputs fills its dicts in the order of string
    hashes, which PYTHONHASHSEED changes per process; bootstrap seeds handed out by position
    then moved ft_as_dispersion's Sobol' intervals between processes."""
    class Reversed(_Toy):
        def outputs(self):
            return (OutputInfo("y", "scalar", "1", "y"), OutputInfo("z", "scalar", "1", "z"))

        def _evaluate(self, values, n, outputs):
            y = self._y(values)[:, None]
            return ModelOutput(time=np.zeros(0), scalars={"z": -y, "y": y},
                               failed=np.zeros(n, dtype=bool),
                               reasons=np.full(n, "", dtype=object))

    out = Reversed().evaluate(np.ones((2, 2)), ["a", "b"], ["z", "y"])
    assert list(out.scalars) == ["y", "z"]
