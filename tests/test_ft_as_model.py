"""The compiled FT-AS kernel against its NumPy oracle (tests/oracles/ft_as*.py), and the model
contract."""

from __future__ import annotations

import numpy as np
import pytest

from tests.oracles import ft_as_equations as cl
from tests.oracles import substituted
from uqguide.models.ft_as import FTAS
from uqguide.models.ft_as.model import Variant
from uqguide.models.ft_as.params import FTASParams
from uqguide.models.ft_as.runner import Timing, run_batch
from uqguide.models.ft_as.setup import CHI1, OMEGA, PSI1, PSI2, R_E, SIGMA_E, V_E
from uqguide.config.registry import model_class

VARIANTS = [
    Variant("FT-AS", "ft_as", True),
    Variant("literal", "ft_as", False),
    Variant("FT-AS-P", "ft_as", False, 0.01),
    Variant("Case 1", "case1"),
    Variant("Case 2", "case2"),
]


@pytest.mark.parametrize(
    "params",
    [
        {},
        {"switch_units": "accel", "observer_norm": "per_channel"},
        {"switch_boundary": 0.05, "omega_chi": 0.01},
    ],
)
def test_kernel_matches_numpy_reference(params):
    # 40 steps of 0.1 s through the saturated start of every controller; both paths evaluate
    # the same formulas in a different order, so they agree to rounding.
    model = FTAS({"step": 0.1, **params})
    rng = np.random.default_rng(1)
    n = len(VARIANTS)
    values = model.nominal_values(n)
    values["mass_offset"] = rng.uniform(-5, 5, n)
    values["inertia_scale_error"] = rng.uniform(-0.05, 0.05, n)
    values["dr0_x"] = rng.uniform(-50, 50, n)
    batch = model.make_batch(values, VARIANTS)
    p = model.params
    groups = ("r_e", "v_e", "sigma_e", "omega_e", "eps1", "d_hat", "chi1")
    res = run_batch(batch, p.plant(), p.gains(), Timing(0.1, 4.0, 4.0), groups)
    X = batch.x0.copy()
    for k in range(40):
        X, _ = cl.rk4_step(k * 0.1, X, 0.1, batch, p.gains(), p.plant())
    tr = cl.tracking(4.0, X, p.plant())
    end = {g: res.records[g][:, -1] for g in groups}
    expected = {
        "r_e": X[:, R_E], "v_e": X[:, V_E], "sigma_e": X[:, SIGMA_E], "omega_e": tr.omega_e,
        "eps1": X[:, PSI1] - tr.e2, "d_hat": X[:, PSI2], "chi1": X[:, CHI1],
    }  # fmt: skip
    for g, want in expected.items():
        # sign(s) and the observer's unit vector amplify rounding differences a little
        # (seen: 1e-8 relative on d_hat with the accel-unit chatter); a wrong formula gives O(1)
        np.testing.assert_allclose(end[g], want, rtol=1e-7, atol=1e-9 * np.abs(want).max(),
                                   err_msg=g)  # fmt: skip
    assert np.all(X[:, OMEGA] != 0)


def test_observed_disturbance_matches_numpy():
    # eps2 = psi2 - d_obs recorded by the kernel at t = 0 against the closed form
    model = FTAS({"step": 0.1})
    batch = model.make_batch(model.nominal_values(len(VARIANTS)), VARIANTS)
    p = model.params
    res = run_batch(batch, p.plant(), p.gains(), Timing(0.1, 0.1, 0.1), ("eps2", "d_obs"))
    held = cl.controller(0.0, batch.x0, batch, p.gains(), p.plant())
    d = cl.true_disturbance(0.0, batch.x0, held.applied, batch, p.plant())
    tr = cl.tracking(0.0, batch.x0, p.plant())
    d_obs = d + cl.apply_M(held.applied - held.observed, tr.G, p.plant())
    np.testing.assert_allclose(res.records["d_obs"][:, 0], d_obs, rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(res.records["eps2"][:, 0], batch.x0[:, PSI2] - d_obs, rtol=1e-9,
                               atol=1e-15)  # fmt: skip


def test_registered_and_contract_shapes():
    assert model_class("ft_as") is FTAS
    model = FTAS({"step": 0.1, "duration": 60.0, "output_interval": 5.0, "final_window": 10.0})
    names = [o.name for o in model.outputs()]
    x = np.array([[1.0, 0.0], [0.5, 10.0], [1.5, -10.0]])
    out = model.evaluate(x, ["initial_error_scale", "dr0_z"], names)
    assert out.time.shape == (13,) and out.time[-1] == pytest.approx(60.0)
    for o in model.outputs():
        store = out.series if o.kind == "series" else out.scalars
        assert store[o.name].shape[0] == 3 and store[o.name].shape[-1] == o.k
        assert np.all(np.isfinite(store[o.name]))
    assert not out.failed.any()
    # the series at t = 0 are the scaled and offset Table 1 errors
    r0 = out.series["r_e"][:, 0]
    np.testing.assert_allclose(r0[1, :2], 0.5 * r0[0, :2], rtol=1e-12)
    assert r0[1, 2] == pytest.approx(0.5 * r0[0, 2] + 10.0, rel=1e-12)
    assert out.series["r_e_norm"][0, 0, 0] == pytest.approx(500.0, rel=1e-9)
    # applied-force envelope never above the 2 N limit for the saturated FT-AS
    assert out.series["force_peak"].max() <= 2.0
    assert out.scalars["peak_force"].max() == pytest.approx(2.0, rel=1e-6)


def test_samples_are_independent_of_the_batch():
    model = FTAS({"step": 0.1, "duration": 100.0, "output_interval": 10.0, "final_window": 20.0})
    x = np.array([[0.8, 1e-3], [1.2, 5e-3]])
    both = model.evaluate(x, ["initial_error_scale", "force_disturbance_amplitude"])
    one = model.evaluate(x[1:], ["initial_error_scale", "force_disturbance_amplitude"])
    for k in one.scalars:
        np.testing.assert_array_equal(both.scalars[k][1:], one.scalars[k])


@pytest.mark.parametrize("threads,block", [(1, 1), (2, 2), (2, 5)])
def test_samples_do_not_depend_on_the_thread_count_or_the_block(monkeypatch, threads, block):
    # a block of samples shares the clock (time-only terms) and runs on one thread: a sample's
    # numbers must be the same bits whichever block and thread it lands in
    from uqguide.models.ft_as import kernel_numba as kernel

    kw = {"step": 0.1, "duration": 60.0, "output_interval": 10.0, "final_window": 20.0}
    x = np.array([[0.8, 1e-3], [1.2, 5e-3], [1.0, 0.0], [0.9, 2e-3], [1.1, 8e-3]])
    names = ["initial_error_scale", "force_disturbance_amplitude"]
    ref = FTAS({**kw, "threads": 1}).evaluate(x, names)
    monkeypatch.setattr(kernel, "block_size", lambda n, t: block)
    out = FTAS({**kw, "threads": threads}).evaluate(x, names)
    for k in ref.scalars:
        np.testing.assert_array_equal(out.scalars[k], ref.scalars[k], err_msg=k)
    for k in ref.series:
        np.testing.assert_array_equal(out.series[k], ref.series[k], err_msg=k)


def test_nonfinite_sample_is_flagged_not_raised():
    model = FTAS({"step": 0.1, "duration": 20.0, "output_interval": 10.0, "final_window": 5.0})
    x = np.array([[1e-3], [np.inf], [1e-3]])
    out = model.evaluate(x, ["force_disturbance_amplitude"])
    assert out.failed.tolist() == [False, True, False]
    assert "non-finite" in out.reasons[1] and out.reasons[0] == ""
    np.testing.assert_array_equal(out.scalars["delta_v"][0], out.scalars["delta_v"][2])


def test_params_are_validated():
    with pytest.raises(ValueError, match="whole number of steps"):
        FTASParams(step=0.03, duration=100.0)
    with pytest.raises(ValueError, match="symmetric"):
        FTASParams(inertia=[[1, 2, 0], [0, 1, 0], [0, 0, 1]])
    with pytest.raises(ValueError):
        FTASParams(controller="case3")


def test_gains_follow_params():
    g = FTASParams(observer_norm="per_channel", switch_boundary=0.1).gains()
    assert g.obs_per_channel and g.boundary == 0.1
    assert g.a == pytest.approx(1 / 0.9) and g.b == pytest.approx(1.1)
    assert FTASParams().gains().c == 0.9


@pytest.mark.slow
def test_numpy_whole_run_reference_matches_kernel_metrics():
    # every metric and recorded group of the compiled kernel against the independently written
    # numpy loop (tests/oracles/ft_as.py), 60 s at h = 0.1 s through the saturated start, all
    # controllers
    kw = {"step": 0.1, "duration": 60.0, "output_interval": 5.0, "final_window": 20.0,
          "late_time": 30.0}  # fmt: skip
    groups = ("r_e", "v_e", "sigma_e", "omega_e", "s", "u_command", "u_applied_min",
              "u_applied_max", "eps1", "eps2", "d_hat", "d_obs", "chi1")  # fmt: skip
    model = FTAS(kw)
    a = model.run(model.nominal_values(len(VARIANTS)), VARIANTS, groups)
    with substituted():
        b = model.run(model.nominal_values(len(VARIANTS)), VARIANTS, groups)
    np.testing.assert_array_equal(a.time, b.time)
    for g in groups:
        scale = np.abs(b.records[g]).max()
        np.testing.assert_allclose(a.records[g], b.records[g], rtol=1e-7, atol=1e-9 * scale,
                                   err_msg=g)  # fmt: skip
    for q in a.settle:
        np.testing.assert_allclose(a.settle[q], b.settle[q], atol=1e-9, err_msg=q)
    for q in a.final_max:
        np.testing.assert_allclose(a.final_max[q], b.final_max[q], rtol=1e-6, err_msg=q)
    for name in ("peak_applied", "peak_command", "peak_late", "impulse"):
        np.testing.assert_allclose(getattr(a, name), getattr(b, name), rtol=1e-7, err_msg=name)
    # the settling bookkeeping saw real crossings (not all zeros or all at the horizon)
    assert 0.0 < a.settle["eps1"][0, 1] < 60.0


def test_numpy_reference_flags_failures_like_the_kernel():
    kw = {"step": 0.1, "duration": 5.0, "output_interval": 1.0, "final_window": 1.0}
    x, names = np.array([[1e-3], [np.inf]]), ["force_disturbance_amplitude"]
    outs = [FTAS(kw).evaluate(x, names, ["r_e", "delta_v"])]
    with substituted():
        outs.append(FTAS(kw).evaluate(x, names, ["r_e", "delta_v"]))
    for out in outs:
        assert out.failed.tolist() == [False, True]
    np.testing.assert_allclose(outs[0].series["r_e"][0], outs[1].series["r_e"][0], rtol=1e-9)
