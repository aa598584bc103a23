"""The adaptive PCE's plan when the config gives no run counts (issue 27, "defaults sized to
the problem"): how far the design may grow, how many validation runs check it, and when the
fit's own evidence says to stop.

A config that gives ``n_samples`` or ``max_runs`` keeps its own plan; these rules apply only
when the method sizes the design itself.

**Budget** (:func:`default_budget`): ``min(max(10 n0, 100), 1000)`` fit runs, ``n0 = max(10 d,
2 P_min)`` the initial design (ten runs per input, twice the smallest candidate basis), never
below ``n0``.

- ``10 n0``: the enrichment loop grows the design by half each step, so ten times the initial
  design allows six refits (``n0 -> 1.5 n0 -> ... -> 10 n0``), enough for the degree to rise
  from the 2-3 a first fit of ``10 d`` runs supports to the 15-30 a smooth but oscillating
  output of a few inputs needs (the zoo's 2-input, 401-step oscillator,
  ``benchmarks/defaults_zoo.py``: LOO 2.9e-5 at degree 30 with 200 runs, kurtosis within 1.1%
  at t = 1, 5, 10 s; issue 27's, with a normal frequency, got kurtosis 1.3e6 against 3.06
  from 20 runs, the old default). Being a multiple of
  ``n0`` it is a multiple of ``d`` and of the basis size at once.
- 1000 at most: a 1000-run Monte Carlo gives every moment with an honest interval; a PCE
  still short of its target after as many runs is no cheaper than that, and a user who wants
  more says so with ``max_runs``. 100 at least, so a one-input model can still reach a high
  degree.

**Stopping** (:func:`settled`): the design stops growing when the worst output's corrected LOO
error is at most ``target_loo`` **and** every output's mean and standard deviation moved by at
most ``2 sqrt(loo) std`` since the previous fit. The bound is what a fit of relative L2 error
``loo`` allows: ``|E[S] - E[Y]| <= ||S - Y||_2 = sqrt(loo) std`` (Cauchy-Schwarz) and ``|std_S -
std_Y| <= ||S - Y||_2`` (the triangle inequality of the L2 norm of the centred outputs), so two
fits that both have that error differ by at most twice it. Moments that move more say the LOO
error is luck of the design (a feature the runs have not yet seen), and the design grows. A
first fit already below the target has no previous fit to compare with; its out-of-sample check
is the validation set. Skewness and kurtosis are not compared: their exact computation costs a
Gauss rule per refit, and the validation set judges them after the fit
(:mod:`uqguide.pce.support`).

**Validation** (:func:`default_validation`): ``max(20, ceil(n_fit / 4))`` runs after the final
fit, i.e. the common 80 / 20 split of the runs made, and at least 20 so every stratum of the
stratified design (:mod:`uqguide.pce.validation_design`, six strata of at least two runs) has
runs and the control-variate intervals have a few degrees of freedom each. At most 250 (a
quarter of the 1000-run budget).
"""

from __future__ import annotations

import math

import numpy as np

#: Default fit budget: this many times the initial design ...
BUDGET_FACTOR = 10
#: ... at least this many runs ...
BUDGET_MIN = 100
#: ... and at most this many (unless the initial design itself is larger).
BUDGET_MAX = 1000
#: Default validation runs: this share of the fit's runs ...
VALIDATION_SHARE = 0.25
#: ... and at least this many.
VALIDATION_MIN = 20
#: Two fits of LOO error ``e`` may differ in mean and std by ``MOMENT_FACTOR sqrt(e) std``.
MOMENT_FACTOR = 2.0


def default_budget(n0: int) -> int:
    """Fit runs the adaptive PCE may make at its defaults, for an initial design of ``n0``
    runs (module docstring)."""
    return max(n0, min(max(BUDGET_FACTOR * n0, BUDGET_MIN), BUDGET_MAX))


def default_validation(n_fit: int) -> int:
    """Validation runs after a default fit of ``n_fit`` runs (module docstring)."""
    return max(VALIDATION_MIN, math.ceil(VALIDATION_SHARE * n_fit))


def mean_and_std(coef: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and standard deviation of every column of an orthonormal expansion.

    Parameters
    ----------
    coef : ndarray, shape (P, m)
        Coefficients, row 0 the constant term.

    Returns
    -------
    mean, std : ndarray, shape (m,)
    """
    return coef[0], np.sqrt(np.sum(coef[1:] ** 2, axis=0))


def settled(previous: dict[str, tuple[np.ndarray, np.ndarray]],
            now: dict[str, tuple[np.ndarray, np.ndarray]], loo: dict[str, float],
            target: float) -> bool:
    """Whether the design may stop growing (module docstring).

    Parameters
    ----------
    previous, now : dict of str to (mean, std)
        Per output, the previous and the current fit's mean and std, arrays of shape (m,).
        ``previous`` empty: the first fit (no comparison).
    loo : dict of str to float
        The current fit's corrected LOO error per output (relative to the variance).
    target : float
        ``target_loo``.
    """
    if max(loo.values(), default=0.0) > target:
        return False
    for name, (mean, std) in now.items():
        if name not in previous:
            continue
        mean0, std0 = previous[name]
        tol = MOMENT_FACTOR * math.sqrt(max(loo.get(name, target), 0.0)) * np.maximum(std, std0)
        # round-off of a column that does not vary (a series' initial state) is no movement
        tol = np.maximum(tol, 1e-9 * (np.max(np.abs(mean), initial=0.0)
                                      + np.max(std, initial=0.0)))
        if np.any(np.abs(mean - mean0) > tol) or np.any(np.abs(std - std0) > tol):
            return False
    return True
