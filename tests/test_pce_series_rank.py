"""A series' principal components: the joint least-angle path and the moments' rule.

Closed forms: the multiresponse path of one column is the single-column LARS path; exact
polynomial components are recovered to round-off by the joint fit as by the column-by-column
fit; a series whose skewness lives in a component of 4e-5 of the variance keeps it by default
(the 0.9999 variance rule drops it, and with it the whole skewness).
"""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

from uqguide.core.inputs import InputSpace
from uqguide.methods.pce_adaptive import AdaptivePCE
from uqguide.core.types import ModelOutput
from uqguide.pce.germ import Germ
from uqguide.pce.lars import LarsBasis, LarsPath
from uqguide.pce.sparse_regression import fit_columns

from .test_pce_helpers import normal_space

# Round-off of an exact least-squares fit on a few dozen runs (condition number of the
# degree-3 Hermite basis there below 1e3, times 1e-16, with margin).
EXACT = 1e-10


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_joint_path_of_one_column_is_the_lars_path(seed):
    rng = np.random.default_rng(seed)
    psi = rng.normal(size=(60, 45))
    psi[:, 0] = 1.0
    y = psi[:, 1:5] @ rng.normal(size=4) + 0.1 * rng.normal(size=60)
    lb = LarsBasis(psi)
    np.testing.assert_array_equal(LarsPath(lb, y[:, None]).order(58),
                                  LarsPath(lb, y).order(58))


def _hermite_design(n: int, seed: int) -> tuple[InputSpace, Germ, np.ndarray]:
    space = normal_space(2)
    germ = Germ.of(space)
    return space, germ, np.random.default_rng(seed).normal(size=(n, 2))


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_joint_fit_equals_per_column_fit_on_exact_polynomials(seed):
    """Three columns, each an exact polynomial of degree <= 3 in two normal inputs: both
    searches recover them to round-off, so they agree there."""
    _, germ, xi = _hermite_design(40, seed)
    x1, x2 = xi[:, 0], xi[:, 1]
    y = np.column_stack([2.0 * x1 + 0.5 * x2, 0.3 * (x1**2 - 1.0) + 0.1 * x1 * x2,
                         0.01 * (x2**3 - 3.0 * x2) + 0.02 * x1])
    joint = fit_columns(germ, xi, y, degree_max=3, q=1.0, joint=True)
    alone = fit_columns(germ, xi, y, degree_max=3, q=1.0)
    test = np.random.default_rng(100 + seed).normal(size=(200, 2))
    from uqguide.pce.expansion import Expansion

    a = Expansion(germ, joint.alpha, joint.core, (3,)).evaluate(test)
    b = Expansion(germ, alone.alpha, alone.core, (3,)).evaluate(test)
    scale = np.abs(y).max(axis=0)
    assert np.all(np.abs(a - b).max(axis=0) <= EXACT * scale)
    assert np.all(joint.loo <= EXACT)


_T = np.linspace(0.0, 1.0, 21)
_EPS = 0.009  # the skewed component's share of the variance: eps^2 mean(cos^2) = 4e-5


def _skew_in_small_component(x: np.ndarray) -> np.ndarray:
    """``y(t) = x1 + eps cos(pi t) He2(x2) / sqrt 2``: the symmetric ``x1`` holds all but 4e-5
    of the variance; every step's skewness comes from the small component."""
    h = (x[:, 1:2] ** 2 - 1.0) / np.sqrt(2.0)
    return x[:, :1] + _EPS * np.cos(np.pi * _T) * h


def _closed_form() -> tuple[np.ndarray, np.ndarray]:
    """Skewness and kurtosis per step: with ``e = eps cos(pi t)``, ``E h^3 = 2 sqrt 2``,
    ``E h^4 = 15``: skewness ``e^3 2 sqrt 2 / (1 + e^2)^1.5``, kurtosis
    ``(3 + 6 e^2 + 15 e^4) / (1 + e^2)^2``."""
    e = _EPS * np.cos(np.pi * _T)
    return (e**3 * 2.0 * np.sqrt(2.0) / (1.0 + e**2) ** 1.5,
            (3.0 + 6.0 * e**2 + 15.0 * e**4) / (1.0 + e**2) ** 2)


def _series_estimate(settings: dict):
    space = normal_space(2)
    method = AdaptivePCE({"n_samples": 30, "degree_max": 2, "q_norm": 1.0,
                          "surrogate_draws": 1000, **settings})
    design = method.design(space, 3)
    y = _skew_in_small_component(design.x)
    out = ModelOutput(time=_T, series={"y": y[:, :, None]}, failed=np.zeros(30, bool),
                      reasons=np.full(30, "", object))
    return method.estimate(space, design, out)


def test_components_grow_until_the_skewness_is_not_truncated():
    skew, kurt = _closed_form()
    est = _series_estimate({})
    s = est.stats["y"]
    assert est.diagnostics["n_components.y"] == 2
    np.testing.assert_allclose(s.skewness[:, 0], skew, rtol=0, atol=EXACT)
    np.testing.assert_allclose(s.kurtosis[:, 0], kurt, rtol=0, atol=EXACT)
    # The former default keeps one component: the skewness is then 0, off by the whole
    # closed form (2e-6 at the ends), four orders above the round-off the rule reaches.
    old = _series_estimate({"variance_fraction": 0.9999})
    assert old.diagnostics["n_components.y"] == 1
    assert np.abs(old.stats["y"].skewness[:, 0] - skew).max() > 1e4 * EXACT


def test_explicit_component_count_wins():
    est = _series_estimate({"n_components": 1})
    assert est.diagnostics["n_components.y"] == 1


def test_variance_fraction_and_n_components_exclude_each_other():
    with pytest.raises(ValidationError, match="'n_components' parameter of pce_adaptive must "
                                              "be unset when variance_fraction"):
        AdaptivePCE({"variance_fraction": 0.99, "n_components": 3})


@pytest.mark.parametrize("seed", [0, 1])
def test_hybrid_fits_the_leading_component_alone_and_the_rest_jointly(seed, monkeypatch):
    """Above :data:`series_fit.HYBRID_WORK` (forced to 0 here) the first component is the
    column-by-column fit of it alone, the others the joint fit of them alone, term for term,
    and each component's leave-one-out residuals are those of its own fit. On exact
    polynomial columns the merged expansion reproduces every column to round-off."""
    from uqguide.pce import series_fit
    from uqguide.pce.expansion import Expansion

    _, germ, xi = _hermite_design(40, seed)
    x1, x2 = xi[:, 0], xi[:, 1]
    y = np.column_stack([2.0 * x1 + 0.5 * x2, 0.3 * (x1**2 - 1.0) + 0.1 * x1 * x2,
                         0.01 * (x2**3 - 3.0 * x2) + 0.02 * x1])
    kw = dict(degree_min=1, degree_max=3, q=1.0)
    monkeypatch.setattr(series_fit, "HYBRID_WORK", 0.0)
    fit, resid = series_fit._fit_components(germ, xi, y, loo=True, **kw)
    lead = fit_columns(germ, xi, y[:, :1], **kw)
    rest = fit_columns(germ, xi, y[:, 1:], joint=True, **kw)

    def terms(f, c):
        return {tuple(a): v for a, v in zip(f.alpha.tolist(), f.core[:, c]) if v != 0.0}

    assert terms(fit, 0) == terms(lead, 0)
    assert [terms(fit, c) for c in (1, 2)] == [terms(rest, c) for c in (0, 1)]
    np.testing.assert_array_equal(fit.degree, np.concatenate([lead.degree, rest.degree]))
    np.testing.assert_array_equal(resid[:, 1:], rest.loo_resid)
    test = np.random.default_rng(100 + seed).normal(size=(200, 2))
    t1, t2 = test[:, 0], test[:, 1]
    truth = np.column_stack([2.0 * t1 + 0.5 * t2, 0.3 * (t1**2 - 1.0) + 0.1 * t1 * t2,
                             0.01 * (t2**3 - 3.0 * t2) + 0.02 * t1])
    both = Expansion(germ, fit.alpha, fit.core, (3,)).evaluate(test)
    assert np.all(np.abs(both - truth).max(axis=0) <= EXACT * np.abs(y).max(axis=0))
    assert np.all(np.abs(resid) <= EXACT * np.abs(y).max(axis=0))
