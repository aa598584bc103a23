"""Fit the [W] chief's GMM from its surface point cloud and store it as package data.

    python scripts/fit_gmm_wang2022.py [--out uqguide/data/gmm_wang2022_fitted.npz]

Recipe (gmm-controllers.md 4.3, 5.3): the grid cloud of spec 4.3 (200 x 200 per body face,
283 x 141 per panel, 99,000 per antenna, duplicates on the cube edges removed: 515,414 points),
k-means from the [W 22] centres, then EM (scikit-learn, full covariances, reg_covar 1e-5,
tol 1e-8). Takes ~10-40 s. ``tests/test_gmm_fitting.py`` (slow) refits and compares with the
stored file; the default tests compare the stored file with the published App. A4 set.
"""

from __future__ import annotations

import argparse
import logging
import time
from pathlib import Path

from uqguide.models.gmm.geometry import wang2022_chief
from uqguide.models.gmm.mixture import WANG2022_MEANS0, fit_mixture
from uqguide.models.gmm.point_cloud import WANG2022_GRID_COUNTS, grid_cloud

DEFAULT_OUT = Path(__file__).resolve().parents[1] / "uqguide" / "data" / "gmm_wang2022_fitted.npz"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    t0 = time.perf_counter()
    points = grid_cloud(wang2022_chief(), WANG2022_GRID_COUNTS)
    mixture, info = fit_mixture(points, means0=WANG2022_MEANS0)
    mixture.save(
        args.out,
        n_points=info.n_points,
        n_iter=info.n_iter,
        converged=info.converged,
        lower_bound=info.lower_bound,
        recipe=("grid cloud of spec 4.3 (deduplicated), k-means from [W 22], "
                "EM reg_covar 1e-5 tol 1e-8"),
    )
    logging.info("wrote %s (%d points, %d EM iterations, %.1f s)", args.out, info.n_points,
                 info.n_iter, time.perf_counter() - t0)


if __name__ == "__main__":
    main()
