"""Potentials, geometry, point clouds and controllers for GMM-based proximity operations.

The [W] model ``gmm_proximity`` (:mod:`.model`, its parameters :mod:`.params`; Wang et al. 2022)
and the generic building blocks (gmm-controllers.md section 14) it shares with the [C] model
(:mod:`uqguide.models.gmm_ftc`):

- :mod:`.gauss_sum`: ``V(r) = sum c_j exp(-1/2 d^T L d)`` with gradient, Hessian and third-
  derivative contraction (GMM kernels and classical APF obstacles);
- :mod:`.potential`: the attract/repulse potential ``1/2 e^T P e + 1/2 (e^T M e) V`` and its
  derivatives ``g, H, H_f, Gamma``;
- :mod:`.geometry`: box-built chiefs, clearance, penetration, swept-segment collisions;
- :mod:`.point_cloud`, :mod:`.mixture`: surface samples, mixtures (published sets), k-means + EM;
- :mod:`.controllers`: reaching law, TSMC (APF/GMM) and NTSMC laws;
- :mod:`.loop`: the sampled-data closed loop's RK4 maps and result on a linear relative plant;
- :mod:`.kernel_numba`: the closed loop compiled for the whole run (its NumPy oracle is
  ``tests/oracles/gmm.py``).

The [W] paper's claims, report and figures are in :mod:`uqguide.papers.gmm_proximity`.
"""
