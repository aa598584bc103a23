"""Which point value a validated PCE's ``+cv`` row prints: the PCE's own or the corrected one,
whichever has the smaller estimated mean squared error (:func:`better_points`).

Derivation and the measured effect on Table 5's ZEM:
docs/methods.md#validation-corrected-moments-no-usable-surrogate-the-kept-surrogate.
"""

from __future__ import annotations

import math

import numpy as np

#: The PCE's own value is printed where it lies within this many of the correction's standard
#: errors of the corrected value (its estimated squared bias below the correction's variance).
BIAS_FACTOR = math.sqrt(2.0)


def better_points(own: np.ndarray, corrected: np.ndarray, se: np.ndarray
                  ) -> tuple[np.ndarray, np.ndarray]:
    """The value of smaller estimated mean squared error at each point.

    ``own``: the PCE's statistic (NaN where withheld); ``corrected``: the control-variate value
    (NaN where not reported); ``se``: the correction's standard error. Returns the chosen values
    and where the PCE's value was taken.
    """
    own = np.asarray(own, dtype=float)
    corrected = np.asarray(corrected, dtype=float)
    se = np.broadcast_to(np.asarray(se, dtype=float), corrected.shape)
    with np.errstate(invalid="ignore"):
        chose = (np.isfinite(own) & np.isfinite(corrected) & np.isfinite(se)
                 & (np.abs(corrected - own) < BIAS_FACTOR * se))
    return np.where(chose, own, corrected), chose
