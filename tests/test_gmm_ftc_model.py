"""The gmm_ftc model: the paper's nominal scenario (acceptance), the model contract and the
closed-loop behaviour under dispersions.

Reference values: [C] section 4.2 claims (bounds) and the regression values of spec section 11
(times to 0.1 s, errors to one significant digit, noise ranges for other noise draws).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq

from uqguide.models.gmm_ftc import GMMFTC
from uqguide.papers import nominal_figures, nominal_report
from uqguide.papers.gmm_ftc.report import nominal_runs
from uqguide.config.registry import model_class


@pytest.fixture(scope="module")
def nominal() -> GMMFTC:
    model = GMMFTC()  # the paper's scenario: Table 2 GMM, Table 3 gains, +-5 % noise, 300 s
    nominal_runs(model)  # cached: the report and figures below reuse the runs
    return model


def _scalars(run):
    return {k: np.asarray(v) for k, v in run.scalars.items()}


def test_registered():
    assert model_class("gmm_ftc") is GMMFTC


def test_nominal_noise_free_acceptance(nominal):
    """C1, C2, C5-C7 hold; C3/C4 hold after the initial transient (spec 11)."""
    clean, _ = nominal_runs(nominal)
    s = {k: v[0] for k, v in _scalars(clean).items()}
    # C5: no collision; the closest approach is the goal itself (spec 11)
    assert s["collided"] == 0 and s["penetration"] == 0
    np.testing.assert_allclose(s["clearance_parts"][[0, 1, 3]], [1.0, 1.0, 2.0], atol=0.01)
    # C1: converged to 1e-4 m within 150 s (spec 11: 113.3 s, 4.6e-9 m after 150 s)
    assert s["t_converge"] <= 150.0 and s["t_converge"] == pytest.approx(113.3, abs=0.1)
    assert s["pos_error_final"] < 1e-4 and 4e-9 < s["pos_error_final"] < 6e-9
    # C2: velocity precision 1e-4 m/s (spec 11: 5.6e-7 m/s)
    assert s["speed_final"] < 1e-4 and 5e-7 < s["speed_final"] < 7e-7
    # C3: 0.15 m/s is exceeded only in the transient (spec 11: 0.2143 m/s, below after 22.1 s)
    assert s["speed_max"] == pytest.approx(0.2143, abs=5e-4)
    assert s["t_speed_below"] == pytest.approx(22.1, abs=0.1)
    # C4: 0.06 m/s^2 exceeded only at the first samples (spec 11: 0.736 m/s^2, below at 1.4 s)
    assert s["u_max"] == pytest.approx(0.736, abs=1e-3)
    assert s["t_u_below"] == pytest.approx(1.4, abs=0.1)
    assert s["u_max_converged"] < 0.06
    # C6: u settles to -u_eq, |w|^2 |r_f, perp| = 0.0025 * sqrt(5) within 10 %
    u_eq = 0.05**2 * np.sqrt(5.0)
    assert abs(s["u_final"] - u_eq) < 0.1 * u_eq
    assert s["u_spread_final"] < 0.1 * s["u_final"]
    # C7: s2 reaches 1e-6 m/s before the eq (36) bound (spec 11: 98.3 s; bound 500 s)
    assert s["t_reach_s2"] == pytest.approx(98.3, abs=0.1)
    assert s["t_reach_s2"] <= 500.0
    # spec 11 control at t_f: 5.84e-3 m/s^2 (one significant digit)
    assert s["u_final"] == pytest.approx(5.8e-3, abs=1e-4)


def test_nominal_with_thruster_noise_every_seed(nominal):
    """C1 and C5 for 16 noise streams (spec 11: t_conv 112.3-114.4 s, errors 4.6e-5-8.5e-5 m
    for its draws; our draws differ, so only the claim bounds are asserted)."""
    _, noisy = nominal_runs(nominal)
    s = _scalars(noisy)
    assert noisy.failed.sum() == 0
    assert np.all(s["collided"] == 0)
    assert np.all(s["t_converge"] <= 150.0) and np.all(s["converged"] == 1)
    assert np.all(s["pos_error_final"] < 1e-4)
    assert np.all(s["speed_final"] < 1e-4)
    # the noise does change the run (the streams are used): spread of 1-3 s in t_converge
    assert np.ptp(s["t_converge"]) > 0.2
    assert 0.70 < s["u_max"].min() and s["u_max"].max() < 0.78  # spec 11: 0.709-0.768


def test_nominal_report_flags(nominal):
    rows = nominal_report(nominal)
    misses = [r.quantity for r in rows if r.ok is False]
    # exactly the full-run amplitude claims C3/C4 fail (spec 11); all checked others hold
    assert sorted(misses) == sorted(["max |v| during the approach (C3)", "max |u| (C4)",
                                     "+-5 % noise, 16 seeds: max |u| (C4)"])
    bound = next(r for r in rows if r.quantity.startswith("fixed-time bound"))
    assert bound.value == pytest.approx(500.0)


@pytest.mark.slow
def test_nominal_figures(nominal, tmp_path):
    paths = nominal_figures(nominal, tmp_path)
    assert [p.name for p in paths] == [
        "gmm_ftc_body_trajectory.png", "gmm_ftc_lvlh_trajectory.png",
        "gmm_ftc_time_histories.png"]
    for p in paths:
        with open(p, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"


SHORT = {"t_final": 20.0, "record_dt": 1.0}


def test_contract_shapes_and_batch_independence():
    """Outputs have the contract's shapes; a sample's outputs (thruster noise included) do not
    depend on the batch it is evaluated in (spec 12.8)."""
    model = GMMFTC(SHORT)
    names = ["dx0", "dw_z", "thrust_scale_y"]
    x = np.array([[0.3, 0.002, 0.97], [-0.5, -0.001, 1.02], [0.0, 0.0, 1.0]])
    outs = [o.name for o in model.outputs()]
    full = model.evaluate(x, names, outs)
    assert full.time.shape == (21,)
    for o in model.outputs():
        arr = full.series[o.name] if o.kind == "series" else full.scalars[o.name]
        assert arr.shape == ((3, 21, o.k) if o.kind == "series" else (3, o.k))
        assert np.all(np.isfinite(arr)) or o.name == "u_max_converged"
    alone = model.evaluate(x[1:2], names, outs)
    for k in alone.series:
        np.testing.assert_array_equal(alone.series[k][0], full.series[k][1])
    for k in alone.scalars:
        np.testing.assert_array_equal(alone.scalars[k][0], full.scalars[k][1])
    # nominal sample equals the nominal run (noise keys are those of the nominal inputs)
    nom = model.evaluate(np.zeros((1, 0)), [], ["pos_error_norm"])
    np.testing.assert_array_equal(nom.series["pos_error_norm"][0], full.series[
        "pos_error_norm"][2])


def test_lvlh_outputs_are_the_rotated_body_outputs():
    model = GMMFTC({**SHORT, "thrust_noise": 0.0})
    out = model.evaluate(np.zeros((1, 0)), [], ["r_lvlh", "pos_error", "range", "u_lvlh",
                                                 "u_body", "los_rate", "v_lvlh"])
    t = out.time
    ang = 0.05 * t  # spin about z from C0 = I
    r_b = out.series["pos_error"][0] + [2.0, 1.0, 0.0]
    r_l = np.stack([np.cos(ang) * r_b[:, 0] - np.sin(ang) * r_b[:, 1],
                    np.sin(ang) * r_b[:, 0] + np.cos(ang) * r_b[:, 1], r_b[:, 2]], axis=1)
    np.testing.assert_allclose(out.series["r_lvlh"][0], r_l, atol=1e-12)
    np.testing.assert_allclose(out.series["range"][0, :, 0], np.linalg.norm(r_l, axis=1))
    np.testing.assert_allclose(np.linalg.norm(out.series["u_lvlh"][0], axis=1),
                               np.linalg.norm(out.series["u_body"][0], axis=1), rtol=1e-12)
    # start: body velocity 0, LVLH velocity w x r = (-0.15, 0.6, 0): LOS rate |r x v| / r^2
    v0 = np.cross([0, 0, 0.05], [12.0, 3.0, 1.0])
    np.testing.assert_allclose(out.series["v_lvlh"][0, 0], v0, atol=1e-15)
    expected = np.linalg.norm(np.cross([12.0, 3.0, 1.0], v0)) / 154.0
    assert out.series["los_rate"][0, 0, 0] == pytest.approx(expected, rel=1e-12)


def test_thrust_scale_offset_matches_steady_state_closed_form():
    """A constant thrust factor (1 + eps_i) per axis leaves the converged servicer where the law's
    reaching term absorbs the excess: applied (1 + eps) u = -A21 r at rest, so per axis
    -lambda1 sig^z1(s2) - lambda2 sig^z2(s2) = (A21 r)_i eps_i / (1 + eps_i) with v = 0,
    s2 = alpha1 s1 + beta1 s1^3 and s1 = (1 + k_s P) y1 (the GMM kernels vanish at the goal)."""
    eps = np.array([0.05, -0.04, 0.03])
    model = GMMFTC({"thrust_noise": 0.0, "t_final": 250.0})
    names = ["thrust_scale_x", "thrust_scale_y", "thrust_scale_z"]
    out = model.evaluate((1 + eps)[None, :], names, ["pos_error", "pos_error_final"])
    y1_sim = out.series["pos_error"][0, -1]
    p = model.params
    A21 = _a21_at(model, 250.0)
    d = (A21 @ np.asarray(p.r_f)) * eps / (1 + eps)
    y1 = []
    for i in range(3):
        # brentq calls excess within this iteration; i is bound anyway so that it cannot drift
        def excess(y, i=i):
            s1 = (1 + p.k_s[i] * p.P[i]) * y
            s2 = p.alpha1[i] * s1 + p.beta1[i] * s1**3
            return (p.lambda1[i] * np.sign(s2) * abs(s2) ** p.zeta1
                    + p.lambda2[i] * np.sign(s2) * abs(s2) ** p.zeta2 + d[i])
        y1.append(brentq(excess, -0.1, 0.1, xtol=1e-14) if d[i] != 0 else 0.0)
    # A21 r_f varies by ~1e-3 relative over a spin period (the C^T A C term) and the offset
    # scales as d^(1/zeta1): 1.7e-3; the r - r_f in A21 r is 1e-4 of r_f
    np.testing.assert_allclose(y1_sim, y1, rtol=5e-3, atol=1e-9)
    assert out.scalars["pos_error_final"][0, 0] > 1e-4  # the paper's 1e-4 m is lost


def _a21_at(model: GMMFTC, t: float) -> np.ndarray:
    from uqguide.models.dynamics.rotating_body_frame import RotatingBodyFrame

    frame = RotatingBodyFrame(model.orbit(), np.array([model.params.spin_rate]))
    k = int(round(t / model.params.dt))
    return frame.matrices_at(frame.stage_schedule(k, model.params.dt), 2 * k)[0][0]


def test_start_across_the_panel_collides():
    """Spec 11: a start on the other side of the panel plane (12, -3, 1) crosses the +x panel
    (the 3 mm GMM sheets are invisible to the 0.1 s sampled controller)."""
    model = GMMFTC({"thrust_noise": 0.0, "t_final": 120.0})
    out = model.evaluate(np.array([[-6.0], [0.0]]), ["dy0"],
                         ["collided", "min_clearance", "clearance_parts"])
    assert out.scalars["collided"][:, 0].tolist() == [1.0, 0.0]
    assert out.scalars["clearance_parts"][0, 1] < 0.02  # the +x panel's skeleton


def test_spin_rate_knowledge_error_leaves_an_offset():
    """With controller_spin: nominal the law cancels the wrong u_eq (no integral action)."""
    known = GMMFTC({"thrust_noise": 0.0, "t_final": 200.0})
    unknown = GMMFTC({"thrust_noise": 0.0, "t_final": 200.0, "controller_spin": "nominal"})
    x = np.array([[0.005]])
    e_known = known.evaluate(x, ["dw_z"], ["pos_error_final"]).scalars["pos_error_final"]
    e_unknown = unknown.evaluate(x, ["dw_z"], ["pos_error_final"]).scalars["pos_error_final"]
    assert e_known[0, 0] < 1e-4 < e_unknown[0, 0]


def test_model_variants_change_the_path_as_the_spec_reports():
    """Spec 11: the controller using the printed [C 7] moves the path by 1.2e-3 m, the 2pi
    normaliser by 1.2e-7 m, dropping the GMM (k_s -> 0) by 6.6e-4 m (one significant digit);
    the fitted GMM by < 1e-7 m (spec: 2.8e-9 m for its own fit; ours is another cloud)."""
    base = {"thrust_noise": 0.0, "t_final": 150.0, "record_dt": 0.1}

    def path(**kw):
        out = GMMFTC({**base, **kw}).evaluate(np.zeros((1, 0)), [], ["pos_error"])
        return out.series["pos_error"][0]

    p0 = path()
    dev = {name: np.abs(path(**kw) - p0).max() for name, kw in [
        ("printed", {"controller_model": "printed"}), ("2pi", {"norm": "2pi"}),
        ("no_gmm", {"k_s": (1e-12, 1e-12, 1e-12)}), ("fitted", {"gmm": "fitted"})]}
    assert dev["printed"] == pytest.approx(1.2e-3, abs=0.05e-3)
    assert dev["2pi"] == pytest.approx(1.2e-7, abs=0.05e-7)
    assert dev["no_gmm"] == pytest.approx(6.6e-4, abs=0.05e-4)
    assert 0 < dev["fitted"] < 1e-7


# the NumPy oracle's 30 steps cost 2 CPU-s of set-up: a slow test (the default suite's budget)
@pytest.mark.parametrize("kernel", [pytest.param("numpy", marks=pytest.mark.slow), "numba"])
def test_a_loop_that_diverges_at_a_coarse_step_is_a_failed_run_not_a_nan(kernel, request):
    """At dt = 1 s the finite-time law overshoots on some dispersed starts: the state grows
    until the speed or delta-v overflows. Those runs are failed and say why; the others keep
    finite outputs (issue: NaN delta-v reported as a success)."""
    from pathlib import Path

    import yaml

    from uqguide import load_config

    raw = yaml.safe_load((Path(__file__).parents[1] / "configs" /
                          "gmm_ftc_dispersion.yaml").read_text())
    raw.pop("reference")
    raw.pop("events")
    raw.pop("report_times", None)  # (they reach 50 s; this horizon is 30 s)
    raw["model"]["t_final"] = 30.0   # the diverging runs overflow by t = 12 s
    rc = load_config(dict(raw, methods=[{"name": "monte_carlo", "n_samples": 10}]))
    space = rc.space
    u = np.random.default_rng(1).random((6, space.dim))
    if kernel == "numpy":
        request.getfixturevalue("oracle_kernels")
    out = rc.model.at_fidelity({"dt": 1.0}).evaluate(space.from_unit(u), space.names,
                                                     ["delta_v", "min_clearance"])
    dv = out.scalars["delta_v"][:, 0]
    assert out.failed.sum() >= 3   # rows 1, 2, 4 and 5 of this stream diverge
    assert np.isfinite(dv[~out.failed]).all() and np.isnan(dv[out.failed]).all()
    assert set(out.reasons[out.failed]) <= {
        "non-finite state: the closed loop diverged",
        "the closed loop diverged (speed or delta-v overflowed; dt too coarse?)"}
