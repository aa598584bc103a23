"""Where a model's runs succeed, learnt from the runs: a PCE fitted where some runs failed takes
its statistics conditional on success from surrogate draws inside this region, checked on its
validation runs and with the region's own uncertainty in their intervals.

The classifier, its check and the bootstrap spread: docs/pce.md#runs-that-failed.
scikit-learn is imported only when some run failed.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..stats.moments import central_moments, shape_moments

#: Slack costs this many times the margin's norm: a near-hard margin wherever the runs separate.
MARGIN_C = 1e3
#: liblinear penalises the intercept as a feature of this constant value: its penalty is then
#: that of a slope 1/10 as large, negligible beside the slopes' for intercepts up to ~10 margins.
INTERCEPT_SCALE = 10.0
#: liblinear's coordinate-descent passes (its default 1000 stops early on hard margins).
MAX_ITER = 10_000
#: Rows of the minority class per feature a degree-2 boundary needs (the events-per-variable
#: rule of logistic regression, Peduzzi et al. 1996); with fewer the boundary is linear.
EVENTS_PER_FEATURE = 10
#: Folds of the check on the validation runs: leave-one-out up to this many runs, a bounded
#: cost beyond.
FOLDS = 20
#: The turns of the boundary's normal towards each feature (tan of the angle: 18 and 45
#: degrees either way) that :func:`turned_regions` tries.
TURNS = (-1.0, -1.0 / 3.0, 1.0 / 3.0, 1.0)
#: Refits of the classifier on resampled runs, and the surrogate draws each is scored on.
BOOTSTRAP, BOOTSTRAP_DRAWS = 200, 20_000


def features(xi: np.ndarray, degree: int) -> np.ndarray:
    """The germ's monomials of degree 1 to ``degree`` (1 or 2) at ``xi (n, d)``."""
    xi = np.asarray(xi, dtype=float)
    if degree == 1:
        return xi
    i, j = np.triu_indices(xi.shape[1])
    return np.hstack([xi, xi[:, i] * xi[:, j]])


@dataclass(frozen=True)
class SuccessRegion:
    """A max-margin boundary between the runs that succeeded and those that failed, on the
    germ's monomials up to ``degree``."""

    degree: int
    classifier: Any

    def side(self, xi: np.ndarray) -> np.ndarray:
        """The signed distance ``(n,)`` of germ points ``xi (n, d)`` from the boundary in
        margins: below 0 predicted to succeed, within (-1, 1) inside the margin (the gap
        between the runs that succeeded and those that failed, where none lies)."""
        # the linear kernel's decision function, without scikit-learn's per-call overhead
        clf = self.classifier
        return features(xi, self.degree) @ clf.coef_[0] + clf.intercept_[0]

    def succeeds(self, xi: np.ndarray) -> np.ndarray:
        """Whether a run at germ points ``xi (n, d)`` is predicted to succeed ``(n,)``."""
        return self.side(xi) < 0.0


def fit_region(xi: np.ndarray, failed: np.ndarray) -> SuccessRegion | None:
    """The region learnt from runs at germ points ``xi (n, d)`` and their failure mask; None
    where they all succeeded or all failed (nothing to learn)."""
    from sklearn.exceptions import ConvergenceWarning
    from sklearn.svm import LinearSVC

    failed = np.asarray(failed, dtype=bool)
    minority = int(min(failed.sum(), (~failed).sum()))
    if minority == 0:
        return None
    d = xi.shape[1]
    degree = 2 if minority >= EVENTS_PER_FEATURE * (d + d * (d + 1) // 2) else 1
    clf = LinearSVC(C=MARGIN_C, intercept_scaling=INTERCEPT_SCALE, max_iter=MAX_ITER)
    with warnings.catch_warnings():
        # a boundary not converged is still checked on the validation runs
        warnings.simplefilter("ignore", ConvergenceWarning)
        clf.fit(features(xi, degree), failed.astype(int))
    return SuccessRegion(degree, clf)


@dataclass(frozen=True)
class RegionCheck:
    """The region's check on the validation runs: each classified by the region fitted on
    every other run; ``passed`` where it misclassifies none, or fewer than the failed runs
    (predicting success everywhere misclassifies exactly those)."""

    misclassified: int
    failed: int
    n: int

    @property
    def passed(self) -> bool:
        return self.misclassified == 0 or self.misclassified < self.failed

    def line(self) -> str:
        return (f"{self.misclassified} of {self.n} validation runs misclassified "
                f"({self.failed} of them failed)")


def check_region(xi: np.ndarray, failed: np.ndarray, held: np.ndarray) -> RegionCheck:
    """Cross-validated check of the region on the rows ``held`` (the validation runs) of the
    runs ``xi, failed``: split into at most :data:`FOLDS` folds (one run each where they are
    fewer), each fold's runs classified by the region fitted on every other run."""
    failed = np.asarray(failed, dtype=bool)
    held = np.asarray(held, dtype=int)
    wrong = 0
    for fold in np.array_split(held, min(FOLDS, held.size)):
        keep = np.ones(failed.size, dtype=bool)
        keep[fold] = False
        region = fit_region(xi[keep], failed[keep])
        predicted = (np.zeros(fold.size, dtype=bool) if region is None
                     else ~region.succeeds(xi[fold]))
        wrong += int(np.sum(predicted != failed[fold]))
    return RegionCheck(wrong, int(failed[held].sum()), int(held.size))


def conditional_moments(values: np.ndarray, inside: np.ndarray) -> dict[str, np.ndarray]:
    """Mean, std, skewness and kurtosis of the draws ``values (m, ...)`` inside the region."""
    mean, mu2, mu3, mu4 = central_moments(values[inside])
    std, skew, kurt = shape_moments(mean, mu2, mu3, mu4)
    return {"mean": mean, "std": std, "skewness": skew, "kurtosis": kurt}


def turned_regions(region: SuccessRegion, xi: np.ndarray, failed: np.ndarray,
                   xi_draws: np.ndarray) -> list[np.ndarray]:
    """Draws ``xi_draws`` inside the other boundaries the runs allow: the normal turned
    towards or away from each feature by :data:`TURNS` (tan of the angle), kept where it still
    separates the runs, at either edge of the gap it leaves between them (masks of the
    draws). A boundary learnt from a handful of failed runs is poorly oriented: with three
    failures at large ``b`` it is ``b > 3.6`` where the truth is ``a + b > 2.9``."""
    w = np.asarray(region.classifier.coef_[0], dtype=float)
    w = w / np.linalg.norm(w)
    at_runs, at_draws = features(xi, region.degree), features(xi_draws, region.degree)
    out = []
    for j in range(w.size):
        for turn in TURNS:
            n = w.copy()
            n[j] += turn
            p = at_runs @ n
            inner, outer = float(np.max(p[~failed])), float(np.min(p[failed]))
            if inner >= outer:
                continue  # the runs refute this boundary
            q = at_draws @ n
            out += [q <= inner, q < outer]
    return [m for m in out if m.any()]


def failed_share(failed: np.ndarray, weight: np.ndarray) -> tuple[float, float, float]:
    """The chance that a run fails and its 95% interval, from runs ``failed`` weighted to the
    input distribution (``weight`` summing to 1): Clopper-Pearson at the weights' effective
    count (Kish's ``1 / sum w^2``)."""
    from ..core.events import clopper_pearson

    w = np.asarray(weight, dtype=float)
    n = 1.0 / float(np.sum(w**2))
    p = float(np.sum(w[np.asarray(failed, bool)]))
    return (p, *clopper_pearson(n * p, n))


def region_spread(xi: np.ndarray, failed: np.ndarray, xi_draws: np.ndarray,
                  values: np.ndarray, share: tuple[float, float], seed: int
                  ) -> dict[str, np.ndarray]:
    """How far the statistics of the surrogate draws ``values (m, ...)`` at ``xi_draws`` can
    move with the region: per statistic, the largest distance from the full fit's value to
    the values with the boundary moved (along its normal) until the draws outside it hold
    either end of ``share``, the failed share's interval (:func:`failed_share`: a boundary
    turned wrong by a handful of failed runs still leaves out about that much), and to the
    2.5% and 97.5% points of :data:`BOOTSTRAP` refits on resampled runs (a resample with one
    class only learns no boundary: all its draws count)."""
    rng = np.random.default_rng(np.random.SeedSequence([int(seed), 0x5ec]))
    full = fit_region(xi, failed)
    side = np.full(xi_draws.shape[0], -np.inf) if full is None else full.side(xi_draws)
    at = conditional_moments(values, side < 0.0)
    band = {k: np.zeros(np.shape(v)) for k, v in at.items()}
    for p in share:
        edge = np.quantile(side, 1.0 - p) if p > 0.0 else np.inf
        inside = side < edge if p < 1.0 else np.zeros(side.size, dtype=bool)
        if inside.any():
            for k, v in conditional_moments(values, inside).items():
                band[k] = np.fmax(band[k], np.abs(v - at[k]))
    if full is not None:
        for inside in turned_regions(full, xi, failed, xi_draws):
            for k, v in conditional_moments(values, inside).items():
                band[k] = np.fmax(band[k], np.abs(v - at[k]))
    reps: dict[str, list[np.ndarray]] = {k: [] for k in at}
    n = xi.shape[0]
    for _ in range(BOOTSTRAP):
        rows = rng.integers(0, n, n)
        region = fit_region(xi[rows], failed[rows])
        ins = np.ones(xi_draws.shape[0], bool) if region is None else region.succeeds(xi_draws)
        if not ins.any():
            continue
        for k, v in conditional_moments(values, ins).items():
            reps[k].append(v)
    out = {}
    for k, v in at.items():
        if not reps[k]:
            out[k] = np.full(np.shape(v), np.inf)
            continue
        lo, hi = np.nanpercentile(np.asarray(reps[k]), [2.5, 97.5], axis=0)
        out[k] = np.fmax(band[k], np.fmax(np.abs(hi - v), np.abs(v - lo)))
    return out
