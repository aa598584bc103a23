"""FTCAPN against closed forms: free drift, the stop crossing, Hill terms, the command law.

These run the compiled kernel; test_ftcapn_kernels.py checks that its NumPy oracle
(tests/oracles/ftcapn.py) gives the same numbers.
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from uqguide.models.dynamics.hill import cw_propagate
from uqguide.models.ftcapn import FTCAPN

ALL_SERIES = ("omega_s", "w", "R", "Rdot", "s", "a_c", "a_c_los", "dv", "r", "v", "speed")
POS_VEL = ["dx", "dy", "dz", "dvx", "dvy", "dvz"]


def model(**kw) -> FTCAPN:
    return FTCAPN(kw)


def all_outputs(m: FTCAPN) -> frozenset[str]:
    return frozenset(o.name for o in m.outputs())


def test_initial_state_is_table2_sign_flipped():
    r0, v0 = model().initial_state()
    assert np.allclose(r0, [-4386.28, -308.60, -3204.43])
    assert np.allclose(v0, [57.7, -2.1, 38.5])
    e_theta, e_r, e_w = model().initial_los_frame()
    assert np.allclose(np.cross(e_w, e_r), e_theta)
    # v0 = Rdot e_r + R omega e_theta (eq 1): the transverse velocity is along +e_theta
    assert v0 @ e_theta > 0 and abs(v0 @ e_w) < 1e-12


def test_free_drift_is_a_straight_line_with_exact_los_rate():
    m = model(control=False, t_final=60.0, t_max=60.0)
    rng = np.random.default_rng(1)
    x = rng.normal(size=(4, 6)) * [15, 15, 15, 3, 3, 3]
    out = m.evaluate(x, POS_VEL, ALL_SERIES)
    r0 = m.initial_state()[0] + x[:, :3]
    v0 = m.initial_state()[1] + x[:, 3:]
    t = out.time
    r = r0[:, None, :] + v0[:, None, :] * t[None, :, None]
    R = np.linalg.norm(r, axis=2)
    w = np.cross(r, np.broadcast_to(v0[:, None, :], r.shape)) / R[..., None] ** 2
    assert np.allclose(out.series["r"], r, rtol=1e-13, atol=1e-10)
    assert np.allclose(out.series["R"][..., 0], R, rtol=1e-13)
    assert np.allclose(out.series["w"], w, rtol=1e-10, atol=1e-16)
    assert np.allclose(out.series["omega_s"][..., 0], np.linalg.norm(w, axis=2), rtol=1e-10)
    assert np.allclose(out.series["Rdot"][..., 0], np.einsum("ntk,nk->nt", r, v0) / R, rtol=1e-12)
    assert np.all(out.series["a_c"] == 0) and np.all(out.series["dv"] == 0)
    # the default line misses the target by ~525 m: every run fails at t_max, with the reason
    assert out.failed.all()
    assert all("did not reach r_stop = 50 m within t_max = 60 s" in s for s in out.reasons)
    assert np.isnan(out.scalars["t_stop"]).all() if "t_stop" in out.scalars else True


def _pass_at(m: FTCAPN, miss: float, t_ca: float) -> np.ndarray:
    """Position error dx that makes the nominal straight line pass at ``miss`` from the target
    at ``t_ca``."""
    r0, v0 = m.initial_state()
    u = np.cross(v0, [0.0, 0.0, 1.0])
    u /= np.linalg.norm(u)
    return miss * u - v0 * t_ca - r0


@pytest.mark.parametrize("miss, t_ca", [(20.0, 40.1), (49.9, 40.25)])
def test_stop_crossing_is_exact_on_a_straight_pass(miss, t_ca):
    # (49.9 m, mid-step) dips below 50 m for ~0.09 s between grid points: the in-step range
    # minimum must be found, not only sign changes at the step ends.
    m = model(control=False, t_final=60.0, t_max=100.0)
    dx = _pass_at(m, miss, t_ca)
    out = m.evaluate(dx[None], ["dx", "dy", "dz"], ["t_stop", "r_at_stop", "R", "zem"])
    v0 = m.initial_state()[1]
    speed = np.linalg.norm(v0)
    t_exact = t_ca - np.sqrt(50.0**2 - miss**2) / speed  # |r| = 50 on the straight line
    assert not out.failed[0]
    assert out.scalars["t_stop"][0, 0] == pytest.approx(t_exact, abs=1e-9)
    assert np.linalg.norm(out.scalars["r_at_stop"][0]) == pytest.approx(50.0, abs=1e-6)
    assert out.scalars["zem"][0, 0] == pytest.approx(miss, abs=1e-9)
    R = out.series["R"][0, :, 0]
    after = out.time >= out.scalars["t_stop"][0, 0]
    assert np.all(R[after] == R[after][0]) and R[after][0] == pytest.approx(50.0, abs=1e-9)


def test_no_stop_when_the_pass_stays_outside():
    m = model(control=False, t_final=60.0, t_max=60.0)
    out = m.evaluate(_pass_at(m, 50.1, 40.25)[None], ["dx", "dy", "dz"], ["t_stop"])
    assert out.failed[0]


def test_target_maneuver_is_constant_along_initial_los_axes():
    m = model(control=False, t_final=30.0, t_max=30.0)
    a = np.array([[0.1, -0.05, 0.07]])
    out = m.evaluate(a, ["at_theta", "at_r", "at_w"], ["r"])
    accel = a[0] @ m.initial_los_frame()  # rows e_theta, e_r, e_w
    r0, v0 = m.initial_state()
    t = out.time[:, None]
    assert np.allclose(out.series["r"][0], r0 + v0 * t + 0.5 * accel * t * t, rtol=1e-13,
                       atol=1e-9)


def test_hill_free_drift_matches_closed_form_cw():
    m = model(control=False, gravity="hill", t_final=60.0, t_max=60.0)
    x = np.array([[10.0, -5.0, 3.0, 0.2, -0.1, 0.3, 0.05, 0.0, -0.02]])
    names = POS_VEL + ["at_theta", "at_r", "at_w"]
    out = m.evaluate(x, names, ["r", "v"])
    r0 = m.initial_state()[0] + x[0, :3]
    v0 = m.initial_state()[1] + x[0, 3:6]
    accel = x[0, 6:] @ m.initial_los_frame()
    t = out.time
    rc, vc = cw_propagate(np.repeat(r0[None], t.size, 0), np.repeat(v0[None], t.size, 0),
                          m.mean_motion, t, accel)
    # RK4 of a linear system with constant forcing is the degree-4 Taylor polynomial of the
    # flow: error (n dt)^5 / 120 ~ 4e-19 per step, so only round-off (~1e-12 of 5 km) remains.
    assert np.allclose(out.series["r"][0], rc, rtol=0, atol=1e-8)
    assert np.allclose(out.series["v"][0], vc, rtol=0, atol=1e-10)
    # the Hill terms are not negligible over 60 s: they bend the line by metres
    straight = r0 + v0 * t[:, None] + 0.5 * accel * t[:, None] ** 2
    assert np.abs(straight - rc).max() > 1.0


def test_command_follows_the_spec_law():
    """Recompute eqs (5), (6), (13), (14) and the PN term from the recorded series."""
    m = model()
    p = m.params
    x = np.array([[3.0, -2.0, 1.0, 0.3, -0.2, 0.1, 2e-5, 5.0]])
    out = m.evaluate(x, POS_VEL + ["b_w", "b_R"], ALL_SERIES + ("t_stop",))
    k = out.time < out.scalars["t_stop"][0, 0]  # steps before the stop (control active)
    R, Rdot, om, s = (out.series[n][0, k, 0] for n in ("R", "Rdot", "omega_s", "s"))
    Rm, omm = R + 5.0, om + 2e-5
    assert np.allclose(s, p.c * Rm + Rdot, rtol=1e-12, atol=1e-12)
    sg = np.where(np.abs(s) < p.delta, s / p.delta, np.sign(s))
    u = -p.c * Rdot - p.eps * sg - p.beta * np.abs(s) ** p.eta * sg - Rm * omm**2
    u = np.clip(u, -p.A_sat, p.A_sat)
    acl = out.series["a_c_los"][0, k]
    assert np.allclose(acl[:, 0], -u, rtol=1e-12, atol=1e-12)
    assert np.allclose(acl[:, 1], -p.N * Rdot * omm, rtol=1e-12, atol=1e-15)
    assert np.all(acl[:, 2] == 0)
    # the Cartesian command has the same magnitude and no component along e_w
    ac = out.series["a_c"][0, k]
    assert np.allclose(np.linalg.norm(ac, axis=1), np.linalg.norm(acl, axis=1), rtol=1e-12)
    assert np.allclose(np.einsum("ti,ti->t", ac, out.series["w"][0, k]), 0, atol=1e-15)
    # delta-v is the running integral of the held |a_c|
    dv = out.series["dv"][0, k, 0]
    assert np.allclose(np.diff(dv), p.dt * np.linalg.norm(acl[:-1], axis=1), rtol=1e-12)


def test_sliding_mode_reaching_law_and_surface():
    """Outside the boundary layer and unsaturated, s' = -eps - beta |s|^eta (eq 9's V' < 0);
    the layer is reached before the eq (12) bound and kept; then Rdot ~ -c R."""
    m = model()
    p = m.params
    out = m.nominal(frozenset(["s", "R", "Rdot", "a_c_los", "omega_s", "t_surface", "t_stop",
                               "Rdot_stop"]))
    s = out.series["s"][0, :, 0]
    t_surf = out.scalars["t_surface"][0, 0]
    t_stop = out.scalars["t_stop"][0, 0]
    bound = abs(s[0]) ** (1 - p.eta) / (p.beta * (1 - p.eta))
    assert 0 < t_surf < bound
    k = np.flatnonzero((out.time[1:] < t_surf) & (out.time[1:] < t_stop))
    unsat = np.abs(out.series["a_c_los"][0, k, 0]) < p.A_sat
    k = k[unsat]
    ds = (s[k + 1] - s[k]) / p.dt
    law = -p.eps - p.beta * np.abs(s[k]) ** p.eta
    # ZOH: the command is frozen over the step while c Rdot + R omega^2 drifts; that drift is
    # bounded by c (A_sat + max R omega^2) + max |Rdot| omega^2, so the step mean of s' is off
    # by at most dt/2 times it.
    R, Rdot, om = (out.series[n][0, :, 0] for n in ("R", "Rdot", "omega_s"))
    tol = p.dt / 2 * (p.c * (p.A_sat + np.max(R * om**2)) + np.max(np.abs(Rdot) * om**2))
    assert k.size > 40
    assert np.max(np.abs(ds - law)) < tol
    inside = (out.time >= t_surf) & (out.time <= t_stop)
    assert np.all(np.abs(s[inside]) <= p.delta)
    # on the surface Rdot = -c R: at the stop within the spec's 10 % (speed at stop)
    assert out.scalars["Rdot_stop"][0, 0] == pytest.approx(-p.c * p.r_stop, rel=0.10)


def test_samples_are_frozen_after_stop():
    m = model()
    rng = np.random.default_rng(5)
    x = rng.normal(size=(20, 6)) * [15, 15, 15, 3, 3, 3]
    out = m.evaluate(x, POS_VEL, ALL_SERIES + ("t_stop", "r_at_stop", "v_at_stop",
                                               "omega_s_stop", "dv_total"))
    assert not out.failed.any()
    for i in range(20):
        t_stop = out.scalars["t_stop"][i, 0]
        after = out.time > t_stop
        if not after.any():
            continue
        for name in ALL_SERIES:
            y = out.series[name][i, after]
            assert np.all(y == y[0]), name
        first = np.argmax(after)
        assert np.allclose(out.series["r"][i, first], out.scalars["r_at_stop"][i], rtol=0)
        assert np.allclose(out.series["v"][i, first], out.scalars["v_at_stop"][i], rtol=0)
        assert out.series["R"][i, first, 0] == pytest.approx(50.0, abs=1e-6)
        assert out.series["dv"][i, first, 0] == out.scalars["dv_total"][i, 0]
        assert out.series["omega_s"][i, first, 0] == pytest.approx(
            out.scalars["omega_s_stop"][i, 0], rel=1e-10)


def test_stop_is_on_the_50m_sphere_for_a_dispersed_batch():
    for gravity in ("none", "hill"):
        m = model(gravity=gravity)
        rng = np.random.default_rng(6)
        x = rng.normal(size=(50, 11)) * [15, 15, 15, 3, 3, 3, 1e-5, 5, 0.1, 0.1, 0.1]
        out = m.evaluate(x, [i.name for i in m.inputs()], ["r_at_stop", "t_stop"])
        ok = ~out.failed
        assert ok.sum() >= 45
        R = np.linalg.norm(out.scalars["r_at_stop"][ok], axis=1)
        assert np.abs(R - 50.0).max() < 1e-6


def test_non_finite_state_is_flagged_not_raised():
    m = model()
    x = np.array([[0.0], [np.nan], [0.0]])
    out = m.evaluate(x, ["b_w"], ["omega_s", "t_stop"])
    assert list(out.failed) == [False, True, False]
    assert "non-finite" in out.reasons[1]
    assert np.isnan(out.scalars["t_stop"][1, 0])
    assert np.isfinite(out.scalars["t_stop"][[0, 2], 0]).all()


def test_identical_samples_give_identical_outputs_and_nan_shape_statistics():
    from uqguide.stats.moments import sample_statistics

    m = model()
    out = m.evaluate(np.zeros((6, 1)), ["dx"], ["omega_s", "zem", "t_stop"])
    for y in list(out.series.values()) + list(out.scalars.values()):
        assert np.all(y == y[:1])
    with np.errstate(all="raise"):
        st = sample_statistics(out.series["omega_s"], bootstrap=0)
    # the mean of equal numbers is rounded, so the std is round-off (stats.py treats a std
    # below 1e-12 |mean| as zero), and skewness / kurtosis are NaN, without warnings
    assert np.all(st.std <= 1e-12 * np.abs(st.mean))
    assert np.isnan(st.skewness).all() and np.isnan(st.kurtosis).all()


def test_only_requested_outputs_are_returned_and_grid_defaults_to_nominal_stop():
    m = model()
    out = m.evaluate(np.zeros((2, 1)), ["dx"], ["R", "zem"])
    assert set(out.series) == {"R"} and set(out.scalars) == {"zem"}
    # nominal stop at 77.1 s, rounded up to the 0.5 s step
    assert out.time[-1] == 77.5 and out.time.shape == (156,)
    assert set(m.default_outputs()) >= {"omega_s", "R", "zem_eq15", "zem", "t_stop",
                                        "dv_total", "speed_stop"}


def test_parameters_are_validated():
    with pytest.raises(ValidationError, match="t_final must not exceed t_max"):
        FTCAPN({"t_final": 500.0})
    with pytest.raises(ValidationError):
        FTCAPN({"eta": 1.5})
    with pytest.raises(ValidationError):
        FTCAPN({"gain": 1.0})


def test_closed_loop_run_still_running_at_t_max_fails_with_reason():
    m = model(t_max=40.0, t_final=40.0)
    out = m.evaluate(np.zeros((3, 1)), ["dx"], ["R", "t_stop", "zem", "dv_total"])
    assert out.failed.all()
    assert set(out.reasons) == {"range did not reach r_stop = 50 m within t_max = 40 s"}
    for v in out.scalars.values():
        assert np.isnan(v).all()
    # the series up to t_max are a valid record of the run (still closing at 40 s)
    R = out.series["R"][0, :, 0]
    assert np.isfinite(R).all() and np.all(np.diff(R) < 0) and R[-1] > 50.0


@pytest.mark.parametrize("gravity", ["none", "hill"])
def test_stop_state_is_the_closed_form_motion_of_the_last_step(gravity):
    """From the last grid state before the stop, the held command (ZOH) and the target
    acceleration give the motion inside the step in closed form (a parabola, or forced CW):
    it must reach the recorded stop state at the recorded stop time."""
    m = model(gravity=gravity, t_final=100.0)  # the grid covers every stop of this batch
    rng = np.random.default_rng(8)
    x = rng.normal(size=(10, 11)) * [15, 15, 15, 3, 3, 3, 1e-5, 5, 0.1, 0.1, 0.1]
    out = m.evaluate(x, [i.name for i in m.inputs()],
                     ["r", "v", "a_c", "t_stop", "r_at_stop", "v_at_stop"])
    at = x[:, 8:11] @ m.initial_los_frame()
    assert not out.failed.any()
    t_stop = out.scalars["t_stop"][:, 0]
    k = np.floor(t_stop / m.params.dt).astype(int)  # last grid point before the stop
    rows = np.arange(10)
    r, v = out.series["r"][rows, k], out.series["v"][rows, k]
    f = at - out.series["a_c"][rows, k]
    tau = t_stop - out.time[k]
    assert np.all((tau > 0) & (tau <= m.params.dt))
    if gravity == "none":
        r_s, v_s = r + v * tau[:, None] + 0.5 * f * tau[:, None] ** 2, v + f * tau[:, None]
    else:
        r_s, v_s = cw_propagate(r, v, m.mean_motion, tau, f)
    assert np.allclose(out.scalars["r_at_stop"], r_s, rtol=0, atol=1e-9)
    assert np.allclose(out.scalars["v_at_stop"], v_s, rtol=0, atol=1e-11)
    assert np.allclose(np.linalg.norm(r_s, axis=1), 50.0, rtol=0, atol=1e-8)
