"""Which point value a validated PCE's ``+cv`` row prints: the PCE's own or the corrected one,
whichever has the smaller estimated mean squared error (issue 27, item 5).

The corrected value ``cv = pce + d`` adds the validation runs' correction ``d``, an unbiased
estimate of the PCE's bias ``b`` with standard error ``se``. Its error is all variance:
``MSE(cv) = se^2``. The PCE's own value has no variance given its fit (the validation runs are
independent of it) and all bias: ``MSE(pce) = b^2``, estimated without bias by ``d^2 - se^2``
(as ``E d^2 = b^2 + se^2``). The PCE's value is the better one where ``d^2 - se^2 < se^2``,
i.e. ``|cv - pce| < sqrt(2) se``; a sampled PCE moment's own sampling error is in both values
and drops out of the comparison.

Why: where the surrogate is good, its moments are exact for the surrogate and far closer to the
model's than 100 validation runs can tell, and the correction adds only their noise. On Table
5's ZEM over 20 fresh seeds (1001-1020) the PCE's own mean is 0.00075 m from the reference on
average, the corrected one 0.0019 m (``benchmarks/pce_coverage.py --first-seed 1001``). Where
the surrogate is biased the correction is larger than its noise and the corrected value wins.

The interval stays the correction's: it is what the validation runs know, and it holds the
chosen value (``sqrt(2) se`` is inside the ``t_{0.975} se`` half-width). Where the PCE's value
is withheld or has no usable surrogate, the corrected value is printed as before.
"""

from __future__ import annotations

import math

import numpy as np

#: The PCE's own value is printed where it lies within this many of the correction's standard
#: errors of the corrected value (its estimated squared bias below the correction's variance).
BIAS_FACTOR = math.sqrt(2.0)


def better_points(own: np.ndarray, corrected: np.ndarray, se: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The value of smaller estimated mean squared error at each point (module docstring).

    Parameters
    ----------
    own : ndarray, shape (...)
        The PCE's own statistic (NaN where withheld or unusable).
    corrected : ndarray, shape (...)
        The control-variate value (NaN where it is not reported).
    se : ndarray, shape (...)
        The correction's standard error.

    Returns
    -------
    value : ndarray, shape (...)
        The PCE's value where it is the better one, else the corrected value.
    chose_own : ndarray of bool, shape (...)
        Where the PCE's value was taken.
    """
    own = np.asarray(own, dtype=float)
    corrected = np.asarray(corrected, dtype=float)
    se = np.broadcast_to(np.asarray(se, dtype=float), corrected.shape)
    with np.errstate(invalid="ignore"):
        chose = (np.isfinite(own) & np.isfinite(corrected) & np.isfinite(se)
                 & (np.abs(corrected - own) < BIAS_FACTOR * se))
    return np.where(chose, own, corrected), chose
