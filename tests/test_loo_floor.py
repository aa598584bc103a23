"""The fit runs' leave-one-out values as a floor on the ``+cv`` intervals' variance: the
closed-form leave-one-out against refits without each run, the strata of any point against
the design's own runs, and the floor's variance against closed forms."""

from __future__ import annotations

import numpy as np
from scipy import stats
from scipy.special import beta as beta_fn

from uqguide.core.inputs import InputSpace, Uniform
from uqguide.pce import basis
from uqguide.pce.expansion import Expansion
from uqguide.pce.germ import Germ
from uqguide.pce.loo import FitFloor, FitRuns, loo_values
from uqguide.pce.validation import corrected_moments, stratified_se
from uqguide.pce.validation_design import stratified_validation
from uqguide.core.types import OutputStats


def _germ(d: int) -> Germ:
    return Germ.of(InputSpace([Uniform(name=f"x{i}", dist="uniform", low=-1.0, high=1.0)
                               for i in range(d)]))


def test_loo_values_are_the_refits_without_each_run():
    """``r / (1 - h)`` is exact for least squares on fixed terms: every run's value equals
    the prediction of the same terms refitted on the other runs, for a scalar with two
    columns on different terms and for a factored (principal-component) expansion."""
    rng = np.random.default_rng(3)
    germ = _germ(2)
    alpha = basis.graded(basis.hyperbolic_indices(2, 4, 1.0))
    xi = rng.uniform(-1, 1, (40, 2))
    psi = basis.evaluate(germ, alpha, xi)
    y = np.column_stack([np.exp(xi[:, 0]) * np.cos(2 * xi[:, 1]), np.abs(xi[:, 0] - 0.2)])
    terms = [np.arange(alpha.shape[0]), np.array([0, 1, 2, 4])]
    core = np.zeros((alpha.shape[0], 2))
    for j, t in enumerate(terms):
        core[t, j] = np.linalg.lstsq(psi[:, t], y[:, j], rcond=None)[0]
    exp = Expansion(germ, alpha, core, (2,))
    got = loo_values(exp, xi, y)
    want = np.empty_like(y)
    for i in range(xi.shape[0]):
        keep = np.arange(xi.shape[0]) != i
        for j, t in enumerate(terms):
            c = np.linalg.lstsq(psi[keep][:, t], y[keep, j], rcond=None)[0]
            want[i, j] = psi[i, t] @ c
    np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-12)
    # factored: the columns are scores mixed back to 3 output columns, with a mean row
    mix = np.array([[1.0, 0.5, -2.0], [0.0, 1.0, 3.0], [7.0, 7.0, 7.0]])
    fcore = np.column_stack([core, np.eye(alpha.shape[0])[:, 0]])
    fexp = Expansion(germ, alpha, fcore, (3,), mix=mix)
    np.testing.assert_allclose(loo_values(fexp, xi, y), want @ mix[:2] + mix[2],
                               rtol=1e-9, atol=1e-12)


def test_a_point_s_stratum_is_the_design_s_own_for_its_runs():
    """The sorter puts each validation run back in the stratum it was drawn from, and its
    ratio is the run's own (uniform pool: 1; arcsine pool: ``1 / q(u)``)."""
    def out(u):
        return {"y": stats.norm.ppf(u[:, :1]) + u[:, 1:2] ** 2}

    for d, seed in ((2, 1), (2, 5), (3, 2)):
        vd = stratified_validation(out, seed=seed, label="apce", n=60, d=d)
        assert vd.sorter is not None
        np.testing.assert_array_equal(vd.sorter.strata(out(vd.u)), vd.stratum)
        np.testing.assert_allclose(vd.sorter.ratios(vd.u), vd.ratios(), rtol=1e-12)
        assert abs(vd.sorter.input_share.sum() - 1.0) < 0.05  # E_q[r] over the pool
        assert vd.from_data(vd.to_data()).sorter is vd.sorter


def test_the_floor_s_variance_is_var_q_of_r_f_from_draws_of_p():
    """One stratum (the cube), the arcsine density, ``f = u``: ``Var_q(r f) = pi B(7/2, 3/2)
    - 1/4`` (``E_q[r^2 f^2] = E_p[r f^2]``), estimated from uniform draws within 4 standard
    errors, over three seeds; a uniform pool's floor is the plain sample variance."""
    want = np.pi * beta_fn(3.5, 1.5) - 0.25
    for seed in (1, 2, 3):
        u = np.random.default_rng(seed).random(200_000)
        r = np.pi * np.sqrt(u * (1 - u))  # 1 / q(u)
        floor = FitFloor(u[:, None], np.zeros(u.size, dtype=int), r, np.ones(1))
        got = float(floor.variance(0, 1.0)[0])
        terms = r * u * u - u * 2 * 0.5  # the estimator's linearisation about E_p f = 1/2
        assert abs(got - want) <= 4 * terms.std() / np.sqrt(u.size), seed
    f = np.random.default_rng(4).normal(size=(30, 2))
    plain = FitFloor(f, np.zeros(30, dtype=int), np.ones(30), np.ones(1))
    np.testing.assert_allclose(plain.variance(0, 1.0), f.var(axis=0, ddof=1), rtol=1e-12)


def test_the_floor_only_widens_and_never_moves_the_estimate():
    """Validation runs that missed a corner error (all differences tiny) get their interval
    from the fit runs that saw it; fit runs that saw less leave the interval alone; the
    value is the validation runs' in every case."""
    rng = np.random.default_rng(11)
    n, nf = 40, 120
    s = rng.normal(size=n)
    y = s + 1e-4 * rng.normal(size=n)
    sf = rng.normal(size=nf)
    pce = OutputStats(mean=np.array([0.0]), std=np.array([1.0]), skewness=np.array([0.0]),
                      kurtosis=np.array([3.0]), cov=np.zeros((1, 1)), n_used=nf)
    base = corrected_moments(pce, y[:, None], s[:, None])
    for scale, wider in ((0.05, True), (1e-6, False)):
        yf = sf + scale * rng.normal(size=nf) * (rng.random(nf) < 0.1)
        runs = FitRuns(y=yf[:, None], s_loo=sf[:, None], stratum=np.zeros(nf, dtype=int),
                       ratio=np.ones(nf), input_share=np.ones(1))
        cv = corrected_moments(pce, y[:, None], s[:, None], fit_runs=runs)
        for k in ("mean", "std"):
            assert cv.values[k] == base.values[k]
            if wider:
                assert cv.se[k][0] > 10 * base.se[k][0], k
            else:
                assert cv.se[k][0] == base.se[k][0], k
    # stratified_se: the floor takes over a stratum only where its variance is larger
    infl = np.array([[0.0], [1e-3], [0.0], [2e-3]])
    w, st, sh = np.full(4, 0.25), np.array([0, 0, 1, 1]), np.array([0.5, 0.5])
    big = FitFloor(np.array([[1.0], [-1.0], [0.0], [0.0]]), np.array([0, 0, 1, 1]),
                   np.ones(4), sh)
    se0 = stratified_se(infl, w, st, sh)[0]
    se1 = stratified_se(infl, w, st, sh, floor=big)[0]
    want = np.sqrt(0.25 * 2.0 / 2 + 0.25 * infl[2:].var(ddof=1) / 2)
    np.testing.assert_allclose(se1, want, rtol=1e-12)
    assert se1 > se0


def test_the_fits_are_least_squares_on_their_own_terms():
    """What :func:`loo_values` rests on: every column the adaptive PCE fits (a scalar, and
    each principal component of a series) is ordinary least squares on its retained terms,
    its residual orthogonal to them to round-off (1e-9 of its norm)."""
    from uqguide.core.inputs import Normal
    from uqguide.pce.series_fit import fit_series
    from uqguide.pce.sparse_regression import fit_columns

    germ = Germ.of(InputSpace([Normal(name="a", dist="normal", mean=0.0, std=1.0),
                               Uniform(name="b", dist="uniform", low=-1.0, high=1.0),
                               Uniform(name="c", dist="uniform", low=-1.0, high=1.0)]))
    rng = np.random.default_rng(1)
    xi = np.column_stack([rng.normal(size=120), rng.uniform(-1, 1, (120, 2))])
    y = (np.exp(0.3 * xi[:, 0]) * np.cos(xi[:, 1]) + np.abs(xi[:, 2]))[:, None]
    t = np.linspace(0.0, 5.0, 50)
    series = fit_series(germ, xi, np.exp(-0.2 * xi[:, :1] * t) * np.cos((1 + 0.1 * xi[:, 1:2]) * t))
    for fit, targets in ((fit_columns(germ, xi, y), y),
                         (series.fit, series.components.scores)):
        psi = basis.evaluate(germ, fit.alpha, xi)
        for j in range(targets.shape[1]):
            terms = np.union1d([0], np.flatnonzero(fit.core[:, j]))
            resid = targets[:, j] - psi @ fit.core[:, j]
            assert np.abs(psi[:, terms].T @ resid).max() <= 1e-9 * np.linalg.norm(resid), j


def test_a_derived_output_s_fit_runs_are_its_map_of_the_carriers_leave_one_out(monkeypatch):
    """A derived output (a distance through its miss vector, Table 5's ZEM in small) gets its
    fit runs too: each run's leave-one-out value is the output's map of its carriers'
    leave-one-out values, at the run's physical inputs. The miss vector here is linear, which
    the PCE fits exactly, so every value is the model's own to round-off (the inputs'
    std of 2 tells physical inputs from germ ones); and the runs are spread over the
    validation design's strata."""
    from uqguide.methods import pce_validated
    from uqguide.methods.base import RunContext
    from uqguide.methods.pce_adaptive import AdaptivePCE

    from .test_pce_derived import DIST, _Planar
    from .test_pce_helpers import normal_space, run_method

    seen: dict[str, FitRuns | None] = {}
    real = pce_validated.corrected_moments

    def spy(st, y, s, **kw):
        seen[str(len(seen))] = kw.get("fit_runs")
        return real(st, y, s, **kw)

    monkeypatch.setattr(pce_validated, "corrected_moments", spy)
    method = AdaptivePCE({"n_samples": 40, "degree_min": 1, "degree_max": 2,
                          "surrogate_draws": 20_000, "validation": {"n_samples": 40}})
    est, out = run_method(method.with_context(RunContext(derived={"dist": DIST})), _Planar(),
                          normal_space(3, std=2.0), outputs=("m", "dist"))
    runs = [fr for fr in seen.values() if fr is not None and fr.y.shape[1:] == (1,)]
    assert len(runs) == 1, "the distance's +cv interval gets the fit runs as a floor"
    fr = runs[0]
    assert fr.y.shape[0] == int((~out.failed).sum()) - est.diagnostics["n_validation"]
    np.testing.assert_allclose(fr.s_loo, fr.y, rtol=1e-9, atol=1e-9)
    assert fr.stratum.min() >= 0 and np.unique(fr.stratum).size >= 2
