"""Sliding-mode laws: closed-loop identities (spec 12.3), stall and saturation."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.models.dynamics.tschauner_hempel import ChiefOrbit, LVLHPlant
from uqguide.models.gmm.controllers import NTSMC, TSMC, ReachingLaw, sig
from uqguide.models.gmm.gauss_sum import GaussSum
from uqguide.models.gmm.mixture import WANG2022_PUBLISHED
from uqguide.models.gmm.potential import AttractRepulsePotential
from tests.oracles.gmm import saturate

R_F = np.array([-5.0, -0.913043, -0.304348])
P_W, M_W = 1.2e-2 * np.eye(3), np.diag([0.8, 0.6, 0.4])
REACH = ReachingLaw([1.5e-2] * 3, [1e-2] * 3, 0.9999)
K_S = [10.0, 6.0, 8.0]
PLANT = LVLHPlant(ChiefOrbit(6778.1336e3, 0.01))


def _potentials() -> dict[str, AttractRepulsePotential]:
    return {
        # variance floor 0.09 m^2 (the F configurations): GMM terms act over metres
        "gmm": AttractRepulsePotential(
            P_W, M_W, WANG2022_PUBLISHED.with_variance_floor(0.09).to_gauss_sum()),
        "apf": AttractRepulsePotential(
            P_W, M_W, GaussSum.from_apf([0.1], [[0, 0, 0]], [5.5e-4 * np.eye(3)], [1.0])),
    }


def _controllers():
    pots = _potentials()
    return {
        "apf_tsmc": TSMC(pots["apf"], R_F, K_S, REACH),
        "gmm_tsmc": TSMC(pots["gmm"], R_F, K_S, REACH),
        "gmm_ntsmc": NTSMC(pots["gmm"], R_F, K_S, REACH, 0.01, [1e-2, 1e-3, 1e-3], [1, 0.8, 0.8],
                           1.5, 5, 7),
    }


def _rk4(r, v, A, B, u, h):
    def f(r, v):
        return v, r @ A.T + v @ B.T + u

    k1 = f(r, v)
    k2 = f(r + h / 2 * k1[0], v + h / 2 * k1[1])
    k3 = f(r + h / 2 * k2[0], v + h / 2 * k2[1])
    k4 = f(r + h * k3[0], v + h * k3[1])
    return (r + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0]),
            v + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1]))


@pytest.mark.parametrize("name", ["apf_tsmc", "gmm_tsmc", "gmm_ntsmc"])
def test_law_imposes_the_reaching_law_exactly(name):
    # Unsaturated, continuous application: dS/dt along the plant equals -l1 S - l2 sig^a(S).
    # Central difference over +-1e-6 s: truncation ~ h^2 S''' ~ 1e-12, rounding ~ 1e-16 / 1e-6
    # relative to S, far below the spec's 1e-5.
    ctl = _controllers()[name]
    rng = np.random.default_rng(2)
    r = rng.uniform(-8, 8, (40, 3))
    v = rng.uniform(0.02, 0.3, (40, 3)) * rng.choice([-1, 1], (40, 3))  # |e'_i| > 0 for NTSMC
    A, B = PLANT.matrices(0.0, 0.7)
    u = ctl.command(r, v, A, B)
    h = 1e-6
    rp, vp = _rk4(r, v, A, B, u, h)
    rm, vm = _rk4(r, v, A, B, u, -h)
    S_dot = (ctl.sliding(rp, vp) - ctl.sliding(rm, vm)) / (2 * h)
    expected = REACH.rate(ctl.sliding(r, v))
    err = np.linalg.norm(S_dot - expected, axis=1) / np.linalg.norm(expected, axis=1)
    assert err.max() < 1e-5


def test_ntsmc_stalls_on_a_zero_rate_axis_unless_floored():
    # spec A17: with e'_z = 0 the published law leaves z to the plant; eps > 0 moves it.
    pot = _potentials()["gmm"]
    kw = dict(xi0=0.01, xi1=[1e-2, 1e-3, 1e-3], xi2=[1, 0.8, 0.8], tau=1.5, p=5, q=7)
    r = np.array([[1.0, -16.0, 0.0]])
    v = np.zeros((1, 3))
    A, B = PLANT.matrices(0.0, 0.0)
    u0 = NTSMC(pot, R_F, K_S, REACH, eps=0.0, **kw).command(r, v, A, B)
    u1 = NTSMC(pot, R_F, K_S, REACH, eps=1e-6, **kw).command(r, v, A, B)
    np.testing.assert_allclose(u0, -(r @ A.T), atol=1e-18)  # only the plant is cancelled
    assert abs(u1[0, 2]) > 1e-7 and np.sign(u1[0, 2]) == np.sign(R_F[2])


def test_ntsmc_rejects_even_exponents():
    with pytest.raises(ValueError, match="odd"):
        NTSMC(_potentials()["gmm"], R_F, K_S, REACH, 0.01, [1, 1, 1], [1, 1, 1], 1.5, 4, 7)


def test_reaching_law_validates_alpha_and_sig_is_odd():
    with pytest.raises(ValueError, match="alpha"):
        ReachingLaw([1, 1, 1], [1, 1, 1], 1.0)
    x = np.array([-8.0, 0.0, 8.0])
    np.testing.assert_allclose(sig(x, 1 / 3), [-2.0, 0.0, 2.0])


def test_saturation_by_norm_keeps_direction_and_per_axis_clips():
    u = np.array([[0.3, 0.4, 0.0], [3.0, -4.0, 0.0]])
    s, lim = saturate(u, 0.6)
    np.testing.assert_allclose(s, [[0.3, 0.4, 0.0], [0.36, -0.48, 0.0]])
    np.testing.assert_array_equal(lim, [False, True])
    s, lim = saturate(u, 0.6, per_axis=True)
    np.testing.assert_allclose(s, [[0.3, 0.4, 0.0], [0.6, -0.6, 0.0]])
