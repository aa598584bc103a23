"""Delta-method (influence-function) intervals of Monte Carlo moments: the merge of the
higher central sums, coverage against the known answer and against the Poisson bootstrap, the
``intervals`` setting and the imports of a Monte-Carlo-only run."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from math import comb

import numpy as np
import pytest

from uqguide.config.run_config import validate_config
from uqguide.errors import ConfigError
from uqguide.methods.monte_carlo import MonteCarloReducer, split_summary
from uqguide.core.types import STAT_NAMES, ModelOutput
from uqguide.models.benchmarks import Lognormal
from uqguide.driver.propagate import run
from uqguide.stats.moments import (
    HIGH_ORDER, MomentSums, delta_standard_errors, statistics_from_sums,
)


def test_higher_central_sums_merge_as_one_pass():
    y = np.random.default_rng(3).lognormal(size=(1001, 2))
    merged = MomentSums.of(y[:17], high=True)
    for a, b in ((17, 400), (400, 401), (401, 1001)):
        merged = merged.merge(MomentSums.of(y[a:b], high=True))
    whole = MomentSums.of(y, high=True)
    np.testing.assert_allclose(merged.high, whole.high, rtol=1e-12)
    np.testing.assert_allclose(merged.m4, whole.m4, rtol=1e-12)


def test_delta_standard_errors_of_a_gaussian_are_the_textbook_ones():
    # Normal data: var(mean) = s^2/n, var(std) = s^2/(2n), var(skew) = 6/n, var(kurt) = 24/n
    s, n = 2.0, 1000.0
    mu = (s**2, 0.0, 3 * s**4, 0.0, 15 * s**6, 0.0, 105 * s**8)
    se = delta_standard_errors(tuple(np.array(m) for m in mu), n)
    np.testing.assert_allclose([se[k] for k in STAT_NAMES],
                               [s / np.sqrt(n), s / np.sqrt(2 * n), np.sqrt(6 / n),
                                np.sqrt(24 / n)], rtol=1e-12)


def _streamed(y: np.ndarray, intervals: str, replicate: int, chunk: int = 1000):
    """Statistics of scalar samples ``y (n, 1)`` through the Monte Carlo chunk reduction."""
    reduce = MonteCarloReducer(200, replicate, None, "report", intervals=intervals)
    acc: dict = {}
    for i, a in enumerate(range(0, y.shape[0], chunk)):
        part = y[a:a + chunk]
        out = ModelOutput(time=np.zeros(0), scalars={"y": part},
                          failed=np.zeros(part.shape[0], bool))
        for key, sums in split_summary(reduce(out, i)).items():
            acc[key] = acc[key].merge(sums) if key in acc else sums
    return statistics_from_sums(acc[("m", "y")], acc.get(("b", "y")), delta=acc.get(("h", "y")))


def _lognormal_central_moments(s2: float) -> tuple[np.ndarray, ...]:
    """Exact ``(mu_2, ..., mu_8)`` of ``exp(N(0, s2))``: raw moments ``exp(k^2 s2 / 2)``."""
    raw = [np.exp(k * k * s2 / 2) for k in range(9)]
    m = raw[1]
    return tuple(np.array(sum(comb(p, j) * raw[j] * (-m) ** (p - j) for j in range(p + 1)))
                 for p in range(2, 9))


@pytest.mark.slow
def test_delta_coverage_matches_the_known_answer_and_the_bootstrap():
    """R replicates of the lognormal benchmark (n = 4000 each, seeds 0..R-1).

    - Coverage: the fraction of 95% intervals that hold the exact moment. A coverage proportion
      over R independent replicates has standard error sqrt(0.95 0.05 / R) = 0.018; the
      tolerance is 4 of them against 0.95 (mean, std, skewness), and 4 of the paired
      difference's (at most sqrt(2) times that) against the bootstrap's on the same replicates
      (all four). The kurtosis intervals of both methods cover ~83 % here, not 95 %: both take
      its spread from the sample's own 8th moment, which a lognormal sample underestimates
      when it underestimates the kurtosis; so for the kurtosis the known answer is checked on
      the standard error itself (next point), not on the coverage.
    - Standard error: the delta-method SE evaluated at the exact moments against the spread of
      the R estimates; the sample std of R near-normal estimates has relative standard error
      ~1/sqrt(2R) = 5.8 %, the tolerance is 4 of them.
    """
    model = Lognormal()
    a = np.asarray(model.params.a)
    exact = model.exact_moments()
    R, n = 150, 4000
    hits = {kind: {k: 0 for k in STAT_NAMES} for kind in ("delta", "bootstrap")}
    estimates: dict[str, list[float]] = {k: [] for k in STAT_NAMES}
    for r in range(R):
        x = np.random.default_rng([2026, r]).standard_normal((n, a.size))
        y = np.exp(x @ a)[:, None]
        for kind in hits:
            st = _streamed(y, kind, r)
            for k in STAT_NAMES:
                lo, hi = st.ci[k][:, 0]
                hits[kind][k] += int(lo <= exact[k] <= hi)
                if kind == "delta":
                    estimates[k].append(float(st.stat(k)[0]))
    se = np.sqrt(0.95 * 0.05 / R)
    for k in STAT_NAMES:
        cov_d, cov_b = hits["delta"][k] / R, hits["bootstrap"][k] / R
        if k != "kurtosis":
            assert abs(cov_d - 0.95) <= 4 * se, (k, cov_d)
        assert abs(cov_d - cov_b) <= 4 * np.sqrt(2) * se, (k, cov_d, cov_b)
    exact_se = delta_standard_errors(_lognormal_central_moments(float(np.sum(a * a))), n)
    for k in STAT_NAMES:
        spread = float(np.std(estimates[k], ddof=1))
        assert abs(spread / float(exact_se[k]) - 1) <= 4 / np.sqrt(2 * R), (k, spread,
                                                                              exact_se[k])


def test_monte_carlo_defaults_to_tail_and_keeps_delta_and_bootstrap(lognormal_config):
    by = {}
    for kind in ("delta", "bootstrap", "tail"):
        cfg = dict(lognormal_config)
        cfg["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": 4000,
                           "intervals": kind}]
        by[kind] = run(validate_config(cfg)).run("mc").estimate
    default = run(validate_config(lognormal_config)).run("mc").estimate
    assert default.diagnostics["intervals"] == "tail"
    assert by["bootstrap"].diagnostics["intervals"] == "bootstrap"
    np.testing.assert_array_equal(default.stats["y"].ci["std"], by["tail"].stats["y"].ci["std"])
    # same moments whatever the interval method; the two intervals of the std agree in width
    # to the bootstrap's own Monte Carlo error (200 resamples: ~1/sqrt(2 * 200) = 5% relative,
    # 4 of those: 20%)
    d, b = by["delta"].stats["y"], by["bootstrap"].stats["y"]
    np.testing.assert_array_equal(d.std, b.std)
    wd, wb = np.diff(d.ci["std"], axis=0), np.diff(b.ci["std"], axis=0)
    assert np.all(np.abs(wd / wb - 1) < 0.2), (wd, wb)


def test_bad_interval_method_names_the_field_and_the_choices(lognormal_config):
    cfg = dict(lognormal_config)
    cfg["methods"] = [{"name": "monte_carlo", "label": "mc", "n_samples": 10,
                       "intervals": "jackknife"}]
    with pytest.raises(ConfigError) as e:
        validate_config(cfg)
    text = str(e.value)
    assert "intervals" in text and "jackknife" in text and "bootstrap" in text


@pytest.mark.slow
def test_a_monte_carlo_only_run_imports_no_chaospy(tmp_path):
    cfg = tmp_path / "mc.yaml"
    cfg.write_text(textwrap.dedent("""
        model: {name: lognormal}
        inputs:
          - {name: x1, dist: normal, mean: 0.0, std: 1.0}
          - {name: x2, dist: normal, mean: 0.0, std: 1.0}
          - {name: x3, dist: normal, mean: 0.0, std: 1.0}
        methods:
          - {name: monte_carlo, label: mc, n_samples: 100}
        seed: 1
    """))
    code = textwrap.dedent(f"""
        import sys
        from uqguide.cli import main
        try:
            main(["run", {str(cfg)!r}, "--out", {str(tmp_path / "out")!r}, "-q"],
                 standalone_mode=False)
        except SystemExit as e:
            assert not e.code, e.code
        print(sorted(m for m in sys.modules if m.split(".")[0] == "chaospy"))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "[]", done.stdout


def numpy_sums(y: np.ndarray) -> MomentSums:
    """The test oracle of the compiled :meth:`MomentSums.of` (comoments and high orders), in
    NumPy: two passes, ``d^4`` as ``d^2 d^2``, each power summed along the runs."""
    mean = y.mean(axis=0)
    d = y - mean
    cm = np.einsum("n...i,n...j->...ij", d, d)
    d2 = d * d
    pw = d2 * d
    sums = [d2.sum(axis=0), pw.sum(axis=0)]
    np.multiply(d2, d2, out=pw)
    sums.append(pw.sum(axis=0))
    for _ in range(HIGH_ORDER - 4):
        pw *= d
        sums.append(pw.sum(axis=0))
    return MomentSums(float(y.shape[0]), mean, sums[0], sums[1], sums[2], cm, np.stack(sums[3:]))


@pytest.mark.parametrize("shape", [(1000, 1), (1000, 3), (700, 20, 1), (700, 20, 3), (5, 0)])
def test_compiled_central_sums_equal_the_numpy_ones(shape):
    y = np.random.default_rng(11).lognormal(size=shape)
    a = MomentSums.of(y, high=True)
    b = numpy_sums(y)
    for f in ("mean", "m2", "m3", "m4", "cm", "high"):
        # same additions in the same order except NumPy's pairwise sum of a single column
        np.testing.assert_allclose(getattr(a, f), getattr(b, f), rtol=1e-13, atol=0, err_msg=f)
