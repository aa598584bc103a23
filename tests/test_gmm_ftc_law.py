"""GMM-FTC law ([C] eqs 20-31) and the fixed-time bound ([C] eq 36); spec 7.4 and 12.3.

* Closed-loop identities: with the law's command held and the plant frozen at the sample time,
  the numerical derivatives of ``s1``, ``s2`` along the exact trajectory equal
  ``-alpha1 s1 - beta1 s1^3 + s2`` and the reaching law, at random states near the target,
  with ``k_s`` enlarged so that the GMM terms (``k_s H``, ``k_s Gamma``) carry weight.
* The eq (36) bound: the paper's formula gives 500 s for Table 3; the tight bound must still
  exceed the exact worst-case reaching time of the scalar reaching law, computed by quadrature.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import quad

from uqguide.models.dynamics.rotating_body_frame import LinearStage, RotatingBodyFrame
from uqguide.models.dynamics.tschauner_hempel import ChiefOrbit
from uqguide.models.gmm.controllers import sig
from uqguide.models.gmm.potential import AttractRepulsePotential
from uqguide.models.gmm_ftc.law import FTCGains, GMMFTCLaw, fixed_time_bound
from uqguide.models.gmm_ftc.target import TABLE2

TABLE3 = dict(alpha1=[0.3] * 3, beta1=[0.01] * 3, lambda1=[0.05] * 3, lambda2=[0.01] * 3,
              zeta1=0.6, zeta2=1.5)


def _law(k_s, floor: float) -> GMMFTCLaw:
    V = TABLE2.with_variance_floor(floor).to_gauss_sum("3d")
    pot = AttractRepulsePotential(np.diag([0.8, 0.8, 0.8]), np.diag([0.6, 0.6, 0.4]), V)
    return GMMFTCLaw(pot, np.array([2.0, 1.0, 0.0]), FTCGains(k_s=k_s, **TABLE3))


def _flow(x: np.ndarray, u: np.ndarray, A21: np.ndarray, A22: np.ndarray, t: float,
          steps: int = 20) -> np.ndarray:
    """RK4 of the frozen plant with u held, over t (may be negative)."""
    h = t / steps
    f = lambda s: np.hstack([s[:, 3:], s[:, :3] @ A21.T + s[:, 3:] @ A22.T + u])  # noqa: E731
    for _ in range(steps):
        k1 = f(x)
        k2 = f(x + 0.5 * h * k1)
        k3 = f(x + 0.5 * h * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


@pytest.mark.parametrize("floor", [0.05, 1e-3])
def test_closed_loop_identities(floor):
    """Spec 12.3: the numerical s1', s2' equal their designed dynamics to <= 1e-5 relative."""
    rng = np.random.default_rng(11)
    law = _law(k_s=[0.3, 0.2, 0.25], floor=floor)
    frame = RotatingBodyFrame(ChiefOrbit(6878.14e3, 0.01), np.array([[0.01, -0.02, 0.05]]))
    sched = frame.stage_schedule(40, 0.1)
    A21, A22 = (m[0] for m in frame.matrices_at(sched, 37))
    # points 0.02-0.3 m off the panels and faces, where the floored kernels bend phi strongly
    base = np.array([[3.0, 0.0, 0.2], [1.0, 0.4, -0.3], [5.5, 0.0, 0.8], [0.3, 2.0, 0.0]])
    r = base + rng.uniform(-0.3, 0.3, base.shape) * [0.5, 0.1, 0.5] + [0, 0.05, 0]
    v = rng.normal(0, 0.05, r.shape)
    cmd = law.command(r, v, LinearStage(A21, A22))
    assert not cmd.guarded.any()
    dt = 1e-4  # central difference: truncation dt^2 |s'''| / 6, rounding eps |s| / dt ~ 1e-11
    xp = _flow(np.hstack([r, v]), cmd.u, A21, A22, dt)
    xm = _flow(np.hstack([r, v]), cmd.u, A21, A22, -dt)
    s1p, s2p = law.surfaces(xp[:, :3], xp[:, 3:])
    s1m, s2m = law.surfaces(xm[:, :3], xm[:, 3:])
    g = law.gains
    s2_rate = -g.lambda1 * sig(cmd.s2, g.zeta1) - g.lambda2 * sig(cmd.s2, g.zeta2)
    s1_rate = -g.alpha1 * cmd.s1 - g.beta1 * cmd.s1**3 + cmd.s2
    num2 = (s2p - s2m) / (2 * dt)
    num1 = (s1p - s1m) / (2 * dt)
    # the GMM terms must matter, or the test would not check them
    plain = law.gains.k_s * law.potential.derivatives(r, law.r_f).g
    assert np.max(np.abs(plain)) > 0.05
    np.testing.assert_allclose(num2, s2_rate, rtol=1e-5, atol=1e-5 * np.abs(s2_rate).max())
    np.testing.assert_allclose(num1, s1_rate, rtol=1e-5, atol=1e-5 * np.abs(s1_rate).max())


def test_command_cancels_plant_at_the_goal():
    """At the goal, at rest, s1 = s2 = 0 and u = -A21 r_f (the printed "u = u_eq" lost its sign,
    spec A21)."""
    law = _law(k_s=[3e-4, 1e-4, 1e-4], floor=0.0)
    frame = RotatingBodyFrame(ChiefOrbit(6878.14e3, 0.01), np.array([[0.0, 0.0, 0.05]]))
    stage = frame.stage_at(frame.stage_schedule(5, 0.1), 3)
    A21, _ = stage.matrices()
    cmd = law.command(law.r_f[None, :], np.zeros((1, 3)), stage)
    np.testing.assert_allclose(cmd.s2, 0.0, atol=1e-15)
    np.testing.assert_allclose(cmd.u[0], -A21[0] @ law.r_f, rtol=1e-12)


def test_singular_guard_replaces_the_jacobian():
    law = _law(k_s=[1e3, 1e3, 1e3], floor=0.0)
    r = np.array([[2.5886, 0.0005, 0.1]])  # inside the +x inner panel sheet
    cmd = law.command(r, np.zeros((1, 3)), LinearStage(np.zeros((3, 3)), np.zeros((3, 3))))
    d = law.potential.derivatives(r, law.r_f)
    singular = abs(np.linalg.det(np.eye(3) + law.gains.k_s[:, None] * d.H[0])) < law.det_guard
    assert cmd.guarded[0] == singular
    assert np.all(np.isfinite(cmd.u))


def test_fixed_time_bound_table3():
    lam1, lam2 = np.full(3, 0.05), np.full(3, 0.01)
    # [C 36]: 2 / (0.05 * 0.4) + 2 / (0.01 * 0.5) = 100 + 400
    assert fixed_time_bound(lam1, lam2, 0.6, 1.5) == pytest.approx(500.0, rel=1e-12)
    tight = fixed_time_bound(lam1, lam2, 0.6, 1.5, tight=True)
    # supremum over initial conditions of the reaching time of one axis, s' = -l1 s^z1 - l2 s^z2
    worst, _ = quad(lambda s: 1.0 / (0.05 * s**0.6 + 0.01 * s**1.5), 0.0, np.inf, limit=200)
    assert worst < tight < 500.0
    assert tight == pytest.approx(278.8, abs=0.1)  # spec 7.4: "about 280 s"


def test_gains_are_validated():
    with pytest.raises(ValueError, match="zeta1 must be in"):
        FTCGains(**{**TABLE3, "zeta1": 1.2}, k_s=[1e-4] * 3)
    with pytest.raises(ValueError, match="lambda2 must be positive"):
        FTCGains(**{**TABLE3, "lambda2": [0.01, 0.0, 0.01]}, k_s=[1e-4] * 3)
