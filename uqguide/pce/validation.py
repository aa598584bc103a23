"""Validation of a PCE by independent model runs: its out-of-sample error, control-variate
corrections of its moments with their intervals, and where it is not usable.

Per output column: :func:`relative_error`; :func:`corrected_moments` (with
:func:`stratified_se`); the PCE's own values the runs refute (:func:`disagreeing`); where the
surrogate is usable (:func:`usable_mask`, :func:`withhold_all`).

Formulas, rules and measured coverage: docs/pce.md#validation and
docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from ..core.types import OutputStats
from ..stats.tail_intervals import hall_interval
from .loo import FitFloor, FitRuns
from .moments import central_from_raw
from .validation_design import random_validation

#: Default usability threshold on the relative (LOO or validation) error.
USABLE_ERROR = 0.1
LEVEL = 0.95


def validation_unit_rows(seed: int, label: str, n: int, d: int) -> np.ndarray:
    """Random validation inputs ``u (n, d)`` on the unit cube: independent uniform draws from
    the method's own validation stream (keyed by its label), away from the cube's faces."""
    return random_validation(seed, label, n, d).u


def relative_error(y: np.ndarray, s: np.ndarray, weight: np.ndarray | None = None
                   ) -> np.ndarray:
    """Out-of-sample relative error ``mean((y - s)^2) / var(y)`` per column of ``y, s (n, ...)``.

    ``weight (n,)``: stratified weights summing to 1 (default ``1 / n``): means over the input
    distribution, not the runs. 0 where the model does not vary and the surrogate agrees to
    round-off; ``inf`` where the model does not vary and the surrogate does.
    """
    if weight is None:
        weight = np.full(y.shape[0], 1.0 / max(y.shape[0], 1))
    w = weight.reshape((-1,) + (1,) * (y.ndim - 1))
    mse = np.sum(w * (y - s) ** 2, axis=0)
    mean = np.sum(w * y, axis=0)
    var = np.sum(w * (y - mean) ** 2, axis=0)
    floor = 1e-24 * mean**2 + 1e-300
    with np.errstate(divide="ignore", invalid="ignore"):
        e = np.where(var > floor, mse / np.where(var > floor, var, 1.0),
                     np.where(mse <= floor, 0.0, np.inf))
    return np.asarray(e, dtype=float)


def _moments_from_raw(c: np.ndarray, m1: np.ndarray, m2: np.ndarray, m3: np.ndarray,
                      m4: np.ndarray) -> dict[str, np.ndarray]:
    """mean, std, skewness and kurtosis from raw moments ``m_p`` about ``c``."""
    var, mu3, mu4 = central_from_raw(m1, m2, m3, m4)
    std = np.sqrt(np.maximum(var, 0.0))
    ok = std > 1e-12 * (np.abs(c + m1) + 1e-300)
    with np.errstate(divide="ignore", invalid="ignore"):
        skew = np.where(ok, mu3 / np.where(ok, std, 1.0) ** 3, np.nan)
        kurt = np.where(ok, mu4 / np.where(ok, std, 1.0) ** 4, np.nan)
    return {"mean": c + m1, "std": std, "skewness": skew, "kurtosis": kurt}


@dataclass
class Corrected:
    """Control-variate estimates of one output.

    ``values``: mean, std, skewness, kurtosis, ``(...)``; ``ci``: their 95% intervals
    ``(2, ...)`` (delta-method se, Welch's t quantile); ``error``: out-of-sample relative error;
    ``n``: successful validation runs; ``correction_half``: the correction's own 95% half-width;
    ``shown_ci``: the interval printed when it differs from ``ci``; ``se``: the correction's
    delta-method standard error.
    """

    values: dict[str, np.ndarray]
    ci: dict[str, np.ndarray]
    error: np.ndarray
    n: int
    correction_half: dict[str, np.ndarray]
    shown_ci: dict[str, np.ndarray] | None = None
    se: dict[str, np.ndarray] | None = None


def sampling_se(draws: np.ndarray, n_draws: int, *, n_boot: int = 200,
                seed: int = 0) -> dict[str, np.ndarray]:
    """Standard errors of the four moments of ``n_draws`` surrogate draws, from ``m``
    draws ``(m, ...)`` in hand: the bootstrap standard error scaled by ``sqrt(m / n_draws)``."""
    m = draws.shape[0]
    shape = draws.shape[1:]
    w = draws.reshape(m, -1)
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5e]))
    counts = rng.multinomial(m, np.full(m, 1.0 / m), size=n_boot).astype(float) / m
    c = w.mean(axis=0)
    bv = _moments_from_raw(c, *[counts @ (w - c) ** p for p in range(1, 5)])
    scale = np.sqrt(m / max(n_draws, 1))
    return {k: (np.sqrt(np.nanvar(v, axis=0)) * scale).reshape(shape) for k, v in bv.items()}


def _gradients(m1: np.ndarray, m2: np.ndarray, m3: np.ndarray, m4: np.ndarray
               ) -> dict[str, list[np.ndarray]]:
    """Derivatives of mean, std, skewness and kurtosis with respect to the raw moments
    ``M_1..M_4`` about a fixed centre (the delta method's linearisation)."""
    var, mu3, mu4 = central_from_raw(m1, m2, m3, m4)
    zero, one = np.zeros_like(m1), np.ones_like(m1)
    dvar = [-2 * m1, one, zero, zero]
    dmu3 = [-3 * m2 + 6 * m1**2, -3 * m1, one, zero]
    dmu4 = [-4 * m3 + 12 * m1 * m2 - 12 * m1**3, 6 * m1**2, -4 * m1, one]
    with np.errstate(divide="ignore", invalid="ignore"):
        sd = np.sqrt(np.maximum(var, 0.0))
        return {"mean": [one, zero, zero, zero],
                "std": [dv / (2 * sd) for dv in dvar],
                "skewness": [d3 / var**1.5 - 1.5 * mu3 / var**2.5 * dv
                             for d3, dv in zip(dmu3, dvar)],
                "kurtosis": [d4 / var**2 - 2 * mu4 / var**3 * dv
                             for d4, dv in zip(dmu4, dvar)]}


def stratified_se(influence: np.ndarray, weight: np.ndarray, stratum: np.ndarray,
                  share: np.ndarray, pool: int = 0, kurtosis_adjusted: bool = True,
                  floor: FitFloor | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Standard error ``(m,)`` of a stratified weighted mean and its Welch-Satterthwaite degrees
    of freedom.

    ``influence (n, m)``: the values averaged; ``weight (n,)``: ``r W_k / n_k``, ``r`` the
    importance ratio; ``share (K,)``: ``W_k``; ``pool``: size of the pool the strata were cut
    from (0: none); ``kurtosis_adjusted`` False: Welch's degrees of freedom; ``floor``: the fit
    runs' values, whose variance a stratum's may not fall below. Formulas and why:
    docs/pce.md#the-standard-error-of-a-stratified-mean.
    """
    m = influence.shape[1]
    ratio = importance_ratios(weight, stratum, share)
    plain = influence
    influence = influence * ratio[:, None]
    parts, dfs = [], []
    variances, kurtoses = {}, {}
    for k in range(share.size):
        rows = stratum == k
        nk = int(rows.sum())
        if nk >= 2:
            variances[k] = (influence[rows].var(axis=0, ddof=1), nk)
        if nk >= 4:
            d = influence[rows] - influence[rows].mean(axis=0)
            m2 = np.mean(d * d, axis=0)
            with np.errstate(invalid="ignore", divide="ignore"):
                kurtoses[k] = np.where(m2 > 0, np.mean(d**4, axis=0)
                                       / np.where(m2 > 0, m2, 1.0) ** 2, 3.0)
    largest = (np.max([v for v, _ in variances.values()], axis=0) if variances
               else np.full(m, np.nan))
    heaviest = (np.max(list(kurtoses.values()), axis=0) if kurtoses else np.full(m, 3.0))
    for k in range(share.size):
        nk = int((stratum == k).sum())
        if nk == 0 or share[k] == 0:
            continue
        v, _ = variances.get(k, (largest, nk))
        if floor is not None:
            v = np.maximum(v, floor.variance(k, share[k]))
        a = share[k] ** 2 * v / nk
        parts.append(a)
        kappa = kurtoses.get(k, heaviest) if kurtosis_adjusted else 3.0
        rel = (kappa - 3.0) / nk + 2.0 / max(nk - 1, 1)
        dfs.append(a**2 * np.maximum(rel, 1e-12) / 2.0)
    total = np.sum(parts, axis=0) if parts else np.full(m, np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        df = np.where(total > 0, total**2 / np.sum(dfs, axis=0), np.inf) if parts \
            else np.full(m, np.nan)
    if pool:
        mean = weight @ plain
        total = total + ((weight / ratio) @ (influence - mean) ** 2) / pool
    return np.sqrt(total), df


def importance_ratios(weight: np.ndarray, stratum: np.ndarray, share: np.ndarray
                      ) -> np.ndarray:
    """Each run's importance ratio ``r = weight n_k / W_k``; exactly 1 in a stratum whose ratios
    are all 1 to round-off, so a uniform pool gives plain stratified sampling bit for bit."""
    counts = np.bincount(stratum, minlength=share.size)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = np.where(share[stratum] > 0, weight * counts[stratum] / share[stratum], 1.0)
    for k in range(share.size):
        rows = stratum == k
        if rows.any() and np.allclose(r[rows], 1.0, rtol=0.0, atol=1e-9):
            r[rows] = 1.0
    return r


def stratified_skewness(influence: np.ndarray, stratum: np.ndarray, share: np.ndarray,
                        se: np.ndarray, weight: np.ndarray | None = None) -> np.ndarray:
    """Skewness of a stratified weighted mean's own distribution, ``sum_k W_k^3 mu3_k / n_k^2``
    over ``se`` cubed (``mu3_k`` of the ratio-weighted ``influence (n, m)``); 0 where undefined."""
    if weight is not None:
        influence = influence * importance_ratios(weight, stratum, share)[:, None]
    third = np.zeros(influence.shape[1])
    for k in range(share.size):
        rows = stratum == k
        nk = int(rows.sum())
        if nk < 3 or share[k] == 0:
            continue
        d = influence[rows] - influence[rows].mean(axis=0)
        third = third + share[k] ** 3 * np.mean(d**3, axis=0) / nk**2
    with np.errstate(invalid="ignore", divide="ignore"):
        g = third / se**3
    return np.where(np.isfinite(g), g, 0.0)


def corrected_moments(pce: OutputStats, y: np.ndarray, s: np.ndarray, *,
                      weight: np.ndarray | None = None, stratum: np.ndarray | None = None,
                      share: np.ndarray | None = None, pool: int = 0,
                      pce_se: dict[str, np.ndarray] | None = None,
                      fit_runs: FitRuns | None = None) -> Corrected:
    """Control-variate mean, std, skewness and kurtosis with 95% intervals.

    ``pce``: the PCE's own statistics; ``y, s (n, ...)``: model and surrogate at the successful
    validation runs; ``weight``, ``stratum``, ``share``, ``pool``: the validation design
    restricted to them (default random: weights ``1 / n``, one stratum, no pool); ``pce_se``:
    standard errors of sampled PCE moments (:func:`sampling_se`), added in quadrature;
    ``fit_runs``: floor each stratum's variance (:func:`stratified_se`). The delta method and
    the interval: docs/pce.md#the-corrected-moments.
    """
    n = y.shape[0]
    shape = y.shape[1:]
    if weight is None or stratum is None or share is None:
        weight, stratum, share = np.full(n, 1.0 / n), np.zeros(n, dtype=int), np.ones(1)
    c = np.asarray(pce.mean, dtype=float).reshape(-1)
    sd = np.nan_to_num(np.asarray(pce.std, dtype=float).reshape(-1))
    # A constant (or zero-variance) PCE has no skewness or kurtosis: its central moments are 0.
    sk = np.where(sd > 0, np.nan_to_num(np.asarray(pce.skewness, float).reshape(-1)), 0.0)
    ku = np.where(sd > 0, np.nan_to_num(np.asarray(pce.kurtosis, float).reshape(-1)), 0.0)
    base = [np.zeros_like(c), sd**2, sk * sd**3, ku * sd**4]
    yc = y.reshape(n, -1) - c
    sc = s.reshape(n, -1) - c
    diffs = [yc**p - sc**p for p in range(1, 5)]
    raw = [b + weight @ d for b, d in zip(base, diffs)]
    values = _moments_from_raw(c, *raw)
    grads = _gradients(*raw)
    from scipy.stats import t as student

    fit_diffs = None
    if fit_runs is not None:
        nf = fit_runs.y.shape[0]
        yf, sf = fit_runs.y.reshape(nf, -1) - c, fit_runs.s_loo.reshape(nf, -1) - c
        fit_diffs = [yf**p - sf**p for p in range(1, 5)]

    ci, own, shown, ses = {}, {}, {}, {}
    for k, g in grads.items():
        with np.errstate(invalid="ignore"):
            influence = sum(gp * d for gp, d in zip(g, diffs))
        floor = None
        if fit_runs is not None and fit_diffs is not None:
            with np.errstate(invalid="ignore"):
                at_fit = np.asarray(sum(gp * d for gp, d in zip(g, fit_diffs)))
            floor = FitFloor(np.nan_to_num(at_fit), fit_runs.stratum, fit_runs.ratio,
                             fit_runs.input_share)
        se, df = stratified_se(np.asarray(influence), weight, stratum, share, pool,
                               floor=floor)
        skew = stratified_skewness(np.asarray(influence), stratum, share, se, weight)
        welch = stratified_se(np.asarray(influence), weight, stratum, share, pool,
                              kurtosis_adjusted=False, floor=floor)[1]
        with np.errstate(invalid="ignore"):
            q = student.ppf((1 + LEVEL) / 2, np.maximum(df, 1.0))
            # the support checks are calibrated on Welch's t, symmetric
            half = student.ppf((1 + LEVEL) / 2, np.maximum(welch, 1.0)) * se
        own[k] = half.reshape(shape)
        ses[k] = np.asarray(se).reshape(shape)
        wide = q * se
        if pce_se is not None and k in pce_se:
            extra = 1.96 * np.asarray(pce_se[k]).reshape(-1)
            half = np.hypot(half, extra)
            # the PCE's own sampling error widens the interval's quantile in proportion
            with np.errstate(invalid="ignore", divide="ignore"):
                q = np.where(se > 0, np.hypot(wide, extra) / np.where(se > 0, se, 1.0), q)
        ci[k] = np.stack([values[k] - half, values[k] + half])
        lo, hi = hall_interval(values[k], se, q, skew)
        # Hall's correction lengthens a side, never shortens one below the symmetric t interval
        # (docs/pce.md#the-corrected-moments).
        with np.errstate(invalid="ignore"):
            lo, hi = np.minimum(lo, values[k] - q * se), np.maximum(hi, values[k] + q * se)
        shown[k] = np.stack([lo, hi])
    return Corrected(values={k: v.reshape(shape) for k, v in values.items()},
                     ci={k: v.reshape((2,) + shape) for k, v in ci.items()},
                     error=relative_error(y.reshape(n, -1), s.reshape(n, -1),
                                          weight).reshape(shape),
                     n=n, correction_half=own,
                     shown_ci={k: v.reshape((2,) + shape) for k, v in shown.items()},
                     se=ses)


#: Statistics whose PCE value is checked against its validation runs: scalars all four, series
#: mean and std (their steps are many, so the check must not fire on chance alone).
SCALAR_CHECKED = ("mean", "std", "skewness", "kurtosis")
SERIES_CHECKED = ("mean", "std")
#: A scalar's PCE value disagrees when it lies this many correction half-widths from the
#: corrected value (2: about 4 standard errors, a chance of 1e-4 per statistic).
SCALAR_FACTOR = 2.0
#: A series disagrees from the first of this many consecutive steps whose PCE value lies
#: outside the correction's 95% half-width (adjacent steps are strongly correlated, so this
#: is a guard against single-step chance, not a test at a computed level).
SERIES_RUN = 3
#: Differences below this share of the PCE's std (mean and std) or this absolute amount
#: (skewness and kurtosis) are immaterial to a dispersion analysis (docs/pce.md#immaterial).
MATERIAL = 0.01


def disagreeing(own: dict[str, np.ndarray], cv: Corrected, series: bool
                ) -> dict[str, np.ndarray]:
    """Per checked statistic, where the PCE's own value disagrees with its validation runs."""
    checked = SERIES_CHECKED if series else SCALAR_CHECKED
    factor = 1.0 if series else SCALAR_FACTOR
    scale = np.nan_to_num(np.abs(own["std"]))
    out = {}
    for k in checked:
        floor = MATERIAL * (scale if k in ("mean", "std") else 1.0)
        with np.errstate(invalid="ignore"):
            bad = np.abs(cv.values[k] - own[k]) > np.maximum(
                factor * cv.correction_half[k], floor)
        out[k] = bad & np.isfinite(own[k])
    return out


def sustained(mask: np.ndarray, run: int = SERIES_RUN) -> np.ndarray:
    """The entries of ``mask (T, ...)`` (steps first) that lie in a run of at least ``run``
    consecutive steps where some column of ``mask`` is True."""
    step = np.asarray(mask.reshape(mask.shape[0], -1).any(axis=1), dtype=bool)
    keep = np.zeros(step.shape, dtype=bool)
    for i in range(max(0, step.size - run + 1)):
        if step[i:i + run].all():
            keep[i:i + run] = True
    return mask & keep.reshape((-1,) + (1,) * (mask.ndim - 1))


def usable_mask(error: np.ndarray | None, loo: float | None, threshold: float,
                shape: tuple[int, ...]) -> np.ndarray:
    """Where the surrogate is usable: the validation error (per column, when known) and the
    fit's LOO error (one figure per output, when known) both at most ``threshold``; a series
    with a validation set is judged by it alone (its LOO error is dominated by the worst step).
    """
    ok = np.ones(shape, dtype=bool)
    if error is not None:
        ok &= np.asarray(error) <= threshold
    if loo is not None and (error is None or len(shape) < 2):
        ok &= bool(loo <= threshold)
    return ok


def nan_at(values: np.ndarray, where: np.ndarray, lead: int = 0) -> np.ndarray:
    """A float copy of ``values`` with NaN where ``where`` is True, ``where`` indexing the axes
    after the first ``lead`` ones."""
    out = np.array(values, dtype=float)
    out[(slice(None),) * lead + (where,)] = np.nan
    return out


def withhold_all(stats: OutputStats, usable: np.ndarray) -> None:
    """NaN the PCE's own moments (and covariance rows, Sobol' indices of inputs and groups,
    quantiles) where it is not usable."""
    bad = ~usable
    if not bad.any():
        return
    for name in ("mean", "std", "skewness", "kurtosis", "cov", "sobol_first", "sobol_total",
                 "sobol_group_first", "sobol_group_total"):
        v = getattr(stats, name)
        if v is not None:
            setattr(stats, name, nan_at(v, bad))
    if stats.quantiles is not None:
        stats.quantiles = nan_at(stats.quantiles, bad, lead=1)
    stats.ci = {k: nan_at(v, bad, lead=1) for k, v in stats.ci.items()}


def withdraw(stats: OutputStats, usable: np.ndarray) -> None:
    """Deprecated name of :func:`withhold_all`."""
    warnings.warn("uqguide.pce.validation.withdraw is deprecated: use withhold_all",
                  DeprecationWarning, stacklevel=2)
    withhold_all(stats, usable)
