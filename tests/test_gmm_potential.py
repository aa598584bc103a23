"""Gaussian sums and the attract/repulse potential against finite differences (spec 6, 12.1)."""

from __future__ import annotations

import numpy as np
import pytest

from uqguide.models.gmm.gauss_sum import GaussSum
from uqguide.models.gmm.mixture import WANG2022_PUBLISHED, Mixture
from uqguide.models.gmm.potential import AttractRepulsePotential

R_F = np.array([-5.0, -0.913043, -0.304348])
P_W = 1.2e-2 * np.eye(3)
M_W = np.diag([0.8, 0.6, 0.4])


def _random_spd(rng: np.random.Generator, scale: float) -> np.ndarray:
    Q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return Q @ np.diag(scale * rng.uniform(0.3, 1.5, 3)) @ Q.T


def _random_mixture(rng: np.random.Generator, K: int = 4) -> Mixture:
    w = rng.uniform(0.5, 1.5, K)
    covs = np.array([_random_spd(rng, 2.0) for _ in range(K)])
    return Mixture(w / w.sum(), rng.uniform(-3, 3, (K, 3)), covs)


def _sets(rng: np.random.Generator) -> dict[str, tuple[AttractRepulsePotential, np.ndarray, float]]:
    """Potential, evaluation points (n, 3), finite-difference step [m]."""
    wang = AttractRepulsePotential(P_W, M_W, WANG2022_PUBLISHED.to_gauss_sum("2pi"))
    # away from the published 3 mm sheets the GMM underflows to 0; the variance floor of the
    # F configurations (sigma >= 0.3 m) gives thick kernels of the same layout
    floored = AttractRepulsePotential(
        P_W, M_W, WANG2022_PUBLISHED.with_variance_floor(0.09).to_gauss_sum())
    apf_kernel = GaussSum.from_apf([0.1], [[0, 0, 0]], [5.5e-4 * np.eye(3)], [1.0])
    apf = AttractRepulsePotential(P_W, M_W, apf_kernel)
    full = AttractRepulsePotential(_random_spd(rng, 0.05), _random_spd(rng, 0.7),
                                   _random_mixture(rng).to_gauss_sum("3d"))
    thick = rng.uniform(-12, 12, (20, 3))
    thick[:10] = rng.uniform(-6, 6, (10, 3))  # near the body, where the floored kernels act
    # points within 4 mm of the published thin sheets: the +x face, the -y panel, an antenna
    thin = np.array([
        [5.0 + 0.003, 1.0, -2.0], [5.0 - 0.002, -3.0, 0.5], [0.001, -9.0, 1.0],
        [-0.0025, -12.0, -1.5], [-7.0, 0.002, -0.001], [8.0, -0.001, 0.0015],
    ])
    thin = thin + rng.uniform(-5e-4, 5e-4, thin.shape) * np.array([0, 1, 1])
    return {
        "wang-floored": (floored, thick, 1e-5),
        "wang-thin": (wang, thin, 1e-7),
        "apf": (apf, thick, 1e-5),
        "full-covariance": (full, rng.uniform(-4, 4, (20, 3)), 1e-5),
    }


def _rel(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Norm-wise relative error per point (the last axes are the vector/matrix)."""
    ax = tuple(range(1, a.ndim))
    return np.linalg.norm((a - b).reshape(a.shape[0], -1), axis=1) / np.maximum(
        np.linalg.norm(b.reshape(b.shape[0], -1), axis=1), 1e-300
    ) if ax else np.abs(a - b) / np.abs(b)


# Central differences have truncation error ~ h^2 |f'''| / 6 and rounding ~ eps |f| / h. With
# h = 1e-5 m on kernels of width >= 0.3 m both are < 1e-8 relative; inside the 3 mm sheets,
# h = 1e-7 m gives (h / sigma)^2 ~ 1e-9 and a rounding error ~ 1e-9. The 1e-6 is met
# everywhere (spec 12.1 asks only 1e-4 in the sheets); measured: <= 6e-9.
TOL = {"wang-floored": 1e-6, "wang-thin": 1e-6, "apf": 1e-6, "full-covariance": 1e-6}


@pytest.mark.parametrize("case", list(TOL))
def test_gradient_hessian_and_goal_derivative_match_finite_differences(case):
    pot, pts, h = _sets(np.random.default_rng(7))[case]
    d = pot.derivatives(pts, R_F)
    I = np.eye(3)
    g_fd = np.stack([(pot.phi(pts + h * I[a], R_F) - pot.phi(pts - h * I[a], R_F)) / (2 * h)
                     for a in range(3)], axis=1)
    H_fd = np.stack([(pot.derivatives(pts + h * I[a], R_F).g
                      - pot.derivatives(pts - h * I[a], R_F).g) / (2 * h)
                     for a in range(3)], axis=2)
    Hf_fd = np.stack([(pot.derivatives(pts, R_F + h * I[a]).g
                       - pot.derivatives(pts, R_F - h * I[a]).g) / (2 * h)
                      for a in range(3)], axis=2)
    assert _rel(d.g, g_fd).max() < TOL[case]
    assert _rel(d.H, H_fd).max() < TOL[case]
    assert _rel(d.H_f, Hf_fd).max() < TOL[case]
    np.testing.assert_allclose(d.H, np.swapaxes(d.H, 1, 2), rtol=0, atol=1e-12 * np.abs(d.H).max())


@pytest.mark.parametrize("case", list(TOL))
def test_third_derivative_contraction_is_the_rate_of_the_hessian(case):
    # Gamma(y) = D3 phi[y, y] = d/ds (H(r + s y) y) at s = 0.
    rng = np.random.default_rng(11)
    pot, pts, h = _sets(rng)[case]
    y = rng.normal(size=pts.shape)
    gamma = pot.derivatives(pts, R_F, y).gamma
    Hp = pot.derivatives(pts + h * y, R_F).H
    Hm = pot.derivatives(pts - h * y, R_F).H
    fd = np.einsum("nij,nj->ni", (Hp - Hm) / (2 * h), y)
    # Gamma has no contribution from the quadratic attraction, so it can be far smaller than
    # H; the difference quotient of H then carries a rounding floor ~ eps |H| |y|^2 / h.
    floor = 1e-15 * np.abs(Hp).max() * np.sum(y * y, axis=1) / h
    err = np.linalg.norm(gamma - fd, axis=1)
    # 10x: one more derivative
    assert np.all(err <= 10 * TOL[case] * np.linalg.norm(fd, axis=1) + floor)
    assert np.linalg.norm(fd, axis=1).max() > 1e3 * floor.max()  # the check is not vacuous


def test_gauss_sum_derivatives_match_finite_differences_of_the_value():
    rng = np.random.default_rng(3)
    gs = _random_mixture(rng).to_gauss_sum("2pi")
    pts = rng.uniform(-3, 3, (15, 3))
    h = 1e-5
    d = gs.derivatives(pts)
    I = np.eye(3)
    g_fd = np.stack([(gs.value(pts + h * I[a]) - gs.value(pts - h * I[a])) / (2 * h)
                     for a in range(3)], 1)
    H_fd = np.stack([(gs.derivatives(pts + h * I[a]).grad
                      - gs.derivatives(pts - h * I[a]).grad) / (2 * h)
                     for a in range(3)], 2)
    assert _rel(d.grad, g_fd).max() < 1e-6
    assert _rel(d.hess, H_fd).max() < 1e-6


def test_potential_vanishes_at_the_goal_and_is_attractive_far_away():
    pot = AttractRepulsePotential(P_W, M_W, WANG2022_PUBLISHED.to_gauss_sum())
    d = pot.derivatives(R_F[None], R_F)
    np.testing.assert_array_equal(pot.phi(R_F[None], R_F), [0.0])
    np.testing.assert_array_equal(d.g, np.zeros((1, 3)))
    far = np.array([[200.0, -300.0, 100.0]])  # every kernel underflows to exactly 0
    np.testing.assert_allclose(pot.derivatives(far, R_F).g, (far - R_F) @ P_W.T, rtol=1e-15)


def test_published_kernel_heights_match_spec():
    # spec 6.3: a [W] face kernel peaks at V ~ 0.46, the antenna kernel at ~2,100 (2pi norm);
    # the 3d normaliser is smaller by sqrt(2 pi) (spec 5.1, A9).
    gs = WANG2022_PUBLISHED.to_gauss_sum("2pi")
    assert gs.c[0] == pytest.approx(7.7216e-2 / (2 * np.pi * np.sqrt(1e-5 * 8.4169**2)), rel=1e-12)
    assert gs.c[0] == pytest.approx(0.46, abs=0.005)
    assert gs.c[7] == pytest.approx(2100, rel=0.01)
    np.testing.assert_allclose(gs.c / WANG2022_PUBLISHED.to_gauss_sum("3d").c, np.sqrt(2 * np.pi))
    with pytest.raises(ValueError, match="norm"):
        WANG2022_PUBLISHED.to_gauss_sum("4d")


def test_apf_kernel_is_the_published_obstacle_term():
    gs = GaussSum.from_apf([0.1], [[1.0, 2.0, 0.0]], [5.5e-4 * np.eye(3)], [1.0])
    r = np.array([[4.0, -3.0, 2.0]])
    d2 = np.sum((r - [1.0, 2.0, 0.0]) ** 2)
    assert gs.value(r)[0] == pytest.approx(0.1 * np.exp(-5.5e-4 * d2), rel=1e-14)


def test_per_sample_kernels_equal_separate_evaluations():
    rng = np.random.default_rng(5)
    mixes = [_random_mixture(rng) for _ in range(4)]
    sums = [m.to_gauss_sum() for m in mixes]
    batched = GaussSum(np.stack([s.c for s in sums]), np.stack([s.mu for s in sums]),
                       np.stack([s.L for s in sums]))
    pts = rng.uniform(-2, 2, (4, 3))
    y = rng.normal(size=(4, 3))
    db = batched.derivatives(pts, y)
    for i, s in enumerate(sums):
        di = s.derivatives(pts[i:i + 1], y[i:i + 1])
        for name in ("value", "grad", "hess", "third"):
            np.testing.assert_allclose(getattr(db, name)[i], getattr(di, name)[0],
                                       rtol=1e-14, atol=0)


def test_variance_floor_raises_small_eigenvalues_only():
    floored = WANG2022_PUBLISHED.with_variance_floor(0.09)
    diag = np.diagonal(floored.covariances, axis1=1, axis2=2)
    orig = np.diagonal(WANG2022_PUBLISHED.covariances, axis1=1, axis2=2)
    np.testing.assert_allclose(diag, np.maximum(orig, 0.09), rtol=1e-12)
    assert WANG2022_PUBLISHED.with_variance_floor(0.0) is WANG2022_PUBLISHED
