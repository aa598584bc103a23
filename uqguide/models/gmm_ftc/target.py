"""The rotating target of [C]: geometry, surface point cloud and its 12-component GMM.

A 2 m cube with two 6 m x 2 m solar panels along body ``x`` and two 2 m antennas along ``y``
(:func:`target_geometry`). Its shape enters the controller as a GMM (:func:`target_mixture`):
:data:`TABLE2`, the published fit with its lost minus signs and exponent restored (A10), by
default; or the fit of a seeded 40,000-point surface cloud (:func:`surface_cloud`) by EM started
from :data:`TABLE1` (A29), made by ``scripts/fit_gmm_ftc.py`` and shipped as package data
(:func:`fitted_mixture`).

The geometry, the point counts and the restorations:
docs/papers.md#gmm-ftc-target-thruster-error-and-inputs.
"""

from __future__ import annotations

import numpy as np

from ..gmm.geometry import ChiefGeometry, Part
from ..gmm.mixture import FitInfo, Mixture, diagonals, fit_mixture
from ..gmm.point_cloud import random_cloud

CLOUD_COUNTS: dict[str, int] = {
    "body": 3320,  # per face (6 faces)
    "panel+x": 10023,
    "panel-x": 10023,
    "antenna+y": 17,
    "antenna-y": 17,
}
"""Random surface points per body face, per panel, per antenna (40,000 in all)."""

CLOUD_SEED = 20200829
"""Seed of the shipped fit's point cloud (the paper's publication date)."""

FITTED_DATA = "gmm_ftc_fitted.npz"
"""Package-data file (in ``uqguide/data``) holding the shipped fit."""

REG_COVAR = 1e-5
"""Covariance regularisation [m^2]: the published thickness of planar / linear parts."""


TABLE1 = Mixture(
    weights=np.array([8.302e-2] * 6 + [4.193e-4] * 2 + [1.256e-1, 1.252e-1, 1.252e-1, 1.252e-1]),
    means=np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
         [0, 2, 0], [0, -2, 0], [2.5, 0, 0], [-2.5, 0, 0], [5.5, 0, 0], [-5.5, 0, 0]],
        dtype=float,
    ),
    covariances=diagonals(
        [(0, .3301, .3301), (0, .3302, .3301), (.33, 0, .3302), (.3301, 0, .3299),
         (.3301, .33, 0), (.33, .33, 0), (0, .335, 0), (0, .335, 0),
         (.755, 0, .33), (.75, 0, .33), (.75, 0, .33), (.75, 0, .33)]
    ),
)
"""[C] Table 1 as printed (EM initial values, a partition of the cloud by part; minus signs
restored). Its zero variances must be regularised before use (the fit adds 1e-5 m^2); the
weights sum to 1.0008 and are normalised by the fit."""

TABLE2 = Mixture(
    weights=np.array(
        [8.295e-2, 8.295e-2, 8.302e-2, 8.302e-2, 8.300e-2, 8.302e-2,
         4.196e-4, 4.196e-4, 1.287e-1, 1.279e-1, 1.221e-1, 1.225e-1]
    ),
    means=np.array(
        [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1],
         [0, 2.0043, 0], [0, -2.0043, 0], [2.5886, 0, 0], [-2.5886, 0, 0],
         [5.4843, 0, 0], [-5.4811, 0, 0]],
        dtype=float,
    ),
    covariances=diagonals(
        [(1e-5, .3303, .3300), (1e-5, .3303, .3300), (.3300, 1e-5, .3300),
         (.3301, 1e-5, .3300), (.3299, .3301, 1e-5), (.3300, .3301, 1e-5),
         (1e-5, .3382, 1e-5), (1e-5, .3382, 1e-5), (.9601, 1e-5, .3301),
         (.9489, 1e-5, .3301), (.8751, 1e-5, .3300), (.8776, 1e-5, .3300)]
    ),
)
"""[C] Table 2, the published fit, restored (A10); components in the order faces +-x, +-y, +-z,
antennas +-y, inner panel halves +-x, outer panel halves +-x."""

PART_OF_COMPONENT: tuple[str, ...] = (
    "face+x", "face-x", "face+y", "face-y", "face+z", "face-z",
    "antenna+y", "antenna-y", "panel+x inner", "panel-x inner", "panel+x outer", "panel-x outer",
)
"""The part each component of :data:`TABLE1` / :data:`TABLE2` describes."""


def target_geometry(panel_half_thickness: float = 0.02, antenna_half_width: float = 0.05,
                    body_tolerance: float = 0.01) -> ChiefGeometry:
    """The [C] target's parts (section 4.1; placement from its Table 2 GMM, thicknesses [m]: A7).

    Cube of side 2 m (8 m^3); panels 6 m x 2 m in the plane ``y = 0``, ``x`` in +-[1, 7],
    ``z`` in [-1, 1]; antennas 2 m long on the ``y`` axis, ``y`` in +-[1, 3].
    """
    return ChiefGeometry(
        parts=(
            Part("body", "solid", (-1.0, -1.0, -1.0), (1.0, 1.0, 1.0)),
            Part("panel+x", "plate", (1.0, 0.0, -1.0), (7.0, 0.0, 1.0), panel_half_thickness),
            Part("panel-x", "plate", (-7.0, 0.0, -1.0), (-1.0, 0.0, 1.0), panel_half_thickness),
            Part("antenna+y", "segment", (0.0, 1.0, 0.0), (0.0, 3.0, 0.0), antenna_half_width),
            Part("antenna-y", "segment", (0.0, -3.0, 0.0), (0.0, -1.0, 0.0), antenna_half_width),
        ),
        body_tolerance=body_tolerance,
    )


def surface_cloud(seed: int = CLOUD_SEED) -> np.ndarray:
    """The 40,000-point uniform random surface cloud of the target, shape (40000, 3) [m]."""
    return random_cloud(target_geometry(), CLOUD_COUNTS, np.random.default_rng(seed))


EM_TOL = 1e-6
"""EM stopping threshold: gain of the mean log-likelihood per point between iterations.

Each panel is a uniform 6 m strip fitted by two Gaussians; the likelihood is nearly flat along
the split point, so EM creeps: from Table 1 the gain falls below 1e-6 after about 20
iterations, where the fit matches Table 2 (panel means 2.585 / 5.47 m vs 2.5886 / 5.4843 m),
and with a 1e-8 threshold EM runs past 1,000 iterations toward an asymmetric split (inner mean
3.07 m, weight 0.168). The paper does not give its threshold ([C 15]); 1e-6 reproduces its
table.
"""


def fit_target_mixture(points: np.ndarray, init: Mixture = TABLE1, max_iter: int = 1000,
                       tol: float = EM_TOL) -> tuple[Mixture, FitInfo]:
    """EM fit of the 12-component GMM to surface samples (N, 3) [m], started from ``init``
    (Table 1 by default, A29; ``REG_COVAR`` is added to its covariances and its weights are
    normalised)."""
    start = Mixture(init.weights / init.weights.sum(), init.means, init.covariances)
    return fit_mixture(points, init=start, reg_covar=REG_COVAR, tol=tol, max_iter=max_iter)


def fitted_mixture() -> Mixture:
    """The shipped EM fit (``uqguide/data/gmm_ftc_fitted.npz``)."""
    return Mixture.packaged(FITTED_DATA)


def target_mixture(source: str = "published") -> Mixture:
    """The target GMM: ``"published"`` ([C] Table 2) or ``"fitted"`` (the shipped EM fit)."""
    if source == "published":
        return TABLE2
    if source == "fitted":
        return fitted_mixture()
    raise ValueError(f"the GMM source must be 'published' or 'fitted', got {source!r}")
