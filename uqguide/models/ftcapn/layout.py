"""Array layouts of the FTCAPN kernel (and of its NumPy test oracle).

Both kernels fill the same preallocated arrays, so they can be compared number for number:

- ``p`` (float64, ``N_PARAMS``): the guidance and simulation constants, indices ``P_*``;
- ``buf`` (float64, ``(C, n, T)``): the requested time series; ``col[S_*]`` is the first row
  of series ``S_*`` in ``buf`` (``-1``: not recorded), so each component is a contiguous
  ``(n, T)`` block;
- ``sc`` (float64, ``(n, N_KSCALARS)``): per-sample results at stop, indices ``K_*``;
- ``status`` (int8, ``(n,)``): ``ST_OK``, ``ST_TMAX`` or ``ST_NONFINITE``.
"""

from __future__ import annotations

import numpy as np

# ---- constants vector p
P_C, P_EPS, P_BETA, P_ETA, P_N, P_ASAT, P_DELTA, P_DT, P_RSTOP, P_NMEAN, P_SETTLE, P_CONTROL = (
    range(12)
)
#: 1: ``at`` holds the target maneuver's components along the current (rotating) LOS frame
#: ``e_theta, e_r, e_w``, applied per step (held over it); 0: ``at`` is a fixed vector.
P_ROTATING = 12
N_PARAMS = 13

# ---- time series: (name, number of components); the order fixes the S_* indices
SERIES_LAYOUT: tuple[tuple[str, int], ...] = (
    ("omega_s", 1),
    ("w", 3),
    ("R", 1),
    ("Rdot", 1),
    ("s", 1),
    ("a_c", 3),
    ("a_c_los", 3),
    ("dv", 1),
    ("r", 3),
    ("v", 3),
    ("speed", 1),
)
S_OMEGA, S_W, S_R, S_RDOT, S_S, S_AC, S_ACLOS, S_DV, S_POS, S_VEL, S_SPEED = range(11)
N_SERIES = len(SERIES_LAYOUT)

# ---- kernel scalars
K_TSTOP = 0  # stop time [s]
K_RS = 1  # 1..3: position at stop [m]
K_VS = 4  # 4..6: velocity at stop [m/s]
K_DV = 7  # accumulated delta-v [m/s]
K_TSURF = 8  # first time |s| <= delta [s]
K_TSETTLE = 9  # time after which omega_s stays <= settle fraction * omega_s(0) [s]
K_ACMAX = 10  # largest commanded acceleration magnitude [m/s^2]
K_TFAIL = 11  # time at which the sample failed [s]
N_KSCALARS = 12

ST_OK, ST_TMAX, ST_NONFINITE = 0, 1, 2


def series_columns(wanted: frozenset[str] | set[str]) -> tuple[np.ndarray, int]:
    """Row offsets ``col (N_SERIES,)`` in ``buf`` (``-1`` where not wanted) and its height ``C``."""
    col = np.full(N_SERIES, -1, dtype=np.int64)
    c = 0
    for i, (name, k) in enumerate(SERIES_LAYOUT):
        if name in wanted:
            col[i] = c
            c += k
    return col, c
