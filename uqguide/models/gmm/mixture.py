"""Gaussian mixtures of a chief's surface: parameters, the published sets, fitting by k-means + EM.

A :class:`Mixture` holds ``(pi_j, mu_j, Sigma_j)``; it turns into the repulsive kernels of the
potential with :meth:`Mixture.to_gauss_sum` (docs/papers.md#gmm-potentials-and-controllers).
The fitting recipe: docs/simulators.md#gmm-a-mixture-fitted-to-a-surface.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import numpy as np

from .gauss_sum import GaussSum, float_fields

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Mixture:
    """A 3-D Gaussian mixture: ``weights`` ``pi_j`` (K,) summing to 1, ``means`` ``mu_j`` (K, 3)
    [m], symmetric positive definite ``covariances`` ``Sigma_j`` (K, 3, 3) [m^2]."""

    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray

    def __post_init__(self) -> None:
        w, m, S = float_fields(self, "weights", "means", "covariances")
        K = w.shape[0]
        if w.shape != (K,) or m.shape != (K, 3) or S.shape != (K, 3, 3):
            raise ValueError(
                f"a mixture needs weights (K,), means (K, 3), covariances (K, 3, 3); "
                f"got {w.shape}, {m.shape}, {S.shape}"
            )

    @property
    def n_components(self) -> int:
        return int(self.weights.shape[0])

    def with_variance_floor(self, floor: float) -> Mixture:
        """Covariances with eigenvalues raised to at least ``floor`` [m^2] (A31, an optional
        deviation from the papers: docs/simulators.md#gmm-a-mixture-fitted-to-a-surface)."""
        if floor <= 0:
            return self
        vals, vecs = np.linalg.eigh(self.covariances)
        vals = np.maximum(vals, floor)
        S = np.einsum("kij,kj,klj->kil", vecs, vals, vecs)
        return Mixture(self.weights, self.means, S)

    def to_gauss_sum(self, norm: str = "2pi") -> GaussSum:
        """The kernels of the GMM potential ([W 8] with ``"2pi"``, [C 10] with ``"3d"``)."""
        return GaussSum.from_mixture(self.weights, self.means, self.covariances, norm)

    def save(self, path: str | Path, **metadata: object) -> None:
        """Write to a ``.npz`` file, with scalar/str metadata (provenance of a fit)."""
        reserved = {"weights", "means", "covariances", "allow_pickle"} & metadata.keys()
        if reserved:
            raise ValueError(f"metadata names {sorted(reserved)} are reserved by the .npz layout")
        arrays = {k: np.asarray(v) for k, v in metadata.items()}
        # allow_pickle is np.savez's default, spelled out so that no metadata key can take its place
        np.savez(
            path,
            allow_pickle=True,
            weights=self.weights,
            means=self.means,
            covariances=self.covariances,
            **arrays,
        )

    @classmethod
    def load(cls, path: str | Path) -> Mixture:
        with np.load(path) as data:
            return cls(data["weights"], data["means"], data["covariances"])

    @classmethod
    def packaged(cls, filename: str) -> Mixture:
        """A mixture shipped as package data in ``uqguide/data``."""
        with resources.as_file(resources.files("uqguide") / "data" / filename) as path:
            return cls.load(path)


def diagonals(rows: list[tuple[float, float, float]]) -> np.ndarray:
    """Diagonal matrices (K, 3, 3) from their diagonals (K rows of 3)."""
    return np.array([np.diag(r) for r in rows], dtype=float)


WANG2022_MEANS0 = np.array(
    [
        [5, 0, 0], [-5, 0, 0], [0, 5, 0], [0, -5, 0], [0, 0, 5],
        [0, 0, -5], [-7.5, 0, 0], [7.5, 0, 0], [0, 10, 0], [0, -10, 0],
    ],
    dtype=float,
)
"""k-means initial centres of [W 22] [m]."""

WANG2022_PUBLISHED = Mixture(
    weights=np.array(
        [7.7216e-2, 7.7216e-2, 7.7456e-2, 7.7456e-2, 7.7217e-2,
         7.7217e-2, 1.9113e-1, 1.9113e-1, 7.6980e-2, 7.6980e-2]
    ),
    means=np.array(
        [
            [5, 0, 0], [-5, 0, 0], [0, 5, 0], [0, -5, 0], [0, 0, 5],
            [0, 0, -5], [-7.5, 0, 0], [7.5, 0, 0], [0, 10.02, 0], [0, -10.02, 0],
        ],
        dtype=float,
    ),
    covariances=diagonals(
        [
            (1e-5, 8.4169, 8.4169), (1e-5, 8.4169, 8.4169),
            (8.3907, 1e-5, 8.3971), (8.3907, 1e-5, 8.3971),
            (8.4167, 8.4166, 1e-5), (8.4167, 8.4166, 1e-5),
            (2.0834, 1e-5, 1e-5), (2.0834, 1e-5, 1e-5),
            (1e-5, 8.3653, 2.1044), (1e-5, 8.3653, 2.1044),
        ]
    ),
)
"""The GMM of [W] App. A4 (eqs 36-42; the weights' exponent is 1e-2 as in extraction 000)."""


@dataclass(frozen=True)
class FitInfo:
    """Diagnostics of an EM fit: convergence, EM iterations, the final mean log-likelihood per
    point (``lower_bound``) and the number of points."""

    converged: bool
    n_iter: int
    lower_bound: float
    n_points: int


def kmeans_partition(points: np.ndarray, means0: np.ndarray) -> Mixture:
    """k-means of ``points`` (N, 3) from the initial centres ``means0`` (K, 3) [m], summarised
    as a mixture: cluster fractions, centroids and biased (1/N_j) covariances."""
    from sklearn.cluster import KMeans

    means0 = np.asarray(means0, dtype=float)
    # tol=0: iterate until the labels stop changing, so that the partition is the nearest-centre
    # partition of its own centroids (scikit-learn's default tolerance can stop one step early)
    km = KMeans(
        n_clusters=means0.shape[0], init=means0, n_init=1, tol=0.0, max_iter=1000
    ).fit(points)
    labels = km.labels_
    K = means0.shape[0]
    weights = np.bincount(labels, minlength=K) / points.shape[0]
    means = np.empty((K, 3))
    covs = np.empty((K, 3, 3))
    for j in range(K):
        pj = points[labels == j]
        means[j] = pj.mean(axis=0)
        d = pj - means[j]
        covs[j] = d.T @ d / pj.shape[0]
    return Mixture(weights, means, covs)


def fit_mixture(
    points: np.ndarray,
    means0: np.ndarray | None = None,
    init: Mixture | None = None,
    reg_covar: float = 1e-5,
    tol: float = 1e-8,
    max_iter: int = 1000,
) -> tuple[Mixture, FitInfo]:
    """Fit a Gaussian mixture to a surface point cloud (N, 3) [m] by EM.

    Start from the k-means partition of the initial centres ``means0`` (K, 3) ([W 22]), or
    directly from the parameters ``init`` (the [C] recipe, A29; ``reg_covar`` is added to their
    covariances). ``reg_covar`` [m^2] is added to every covariance diagonal (1e-5: the published
    thin variances); ``tol``, ``max_iter``: scikit-learn's stopping rule on the change of the mean
    log-likelihood.
    """
    from sklearn.mixture import GaussianMixture

    points = np.asarray(points, dtype=float)
    if means0 is not None and init is None:
        start = kmeans_partition(points, means0)
    elif means0 is None and init is not None:
        start = init
    else:
        raise ValueError("give exactly one of means0 (k-means start) or init (EM start)")
    covs0 = start.covariances + reg_covar * np.eye(3)
    gm = GaussianMixture(
        n_components=start.n_components,
        covariance_type="full",
        reg_covar=reg_covar,
        weights_init=start.weights / start.weights.sum(),
        means_init=start.means,
        precisions_init=np.linalg.inv(covs0),
        tol=tol,
        max_iter=max_iter,
    ).fit(points)
    info = FitInfo(bool(gm.converged_), int(gm.n_iter_), float(gm.lower_bound_), points.shape[0])
    log.info("GMM fit: %d points, %d EM iterations, converged=%s", info.n_points, info.n_iter,
             info.converged)
    return Mixture(gm.weights_, gm.means_, gm.covariances_), info
