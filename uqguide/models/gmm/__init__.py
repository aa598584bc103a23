"""Potentials, geometry, point clouds and controllers for GMM-based proximity operations.

The [W] model ``gmm_proximity`` (:mod:`.model`, :mod:`.params`) and the building blocks it shares
with the [C] model (:mod:`uqguide.models.gmm_ftc`); docs/papers.md#gmm-potentials-and-controllers:

- :mod:`.gauss_sum`: ``V(r) = sum c_j exp(-1/2 d^T L d)`` with gradient, Hessian and third-
  derivative contraction (GMM kernels and classical APF obstacles);
- :mod:`.potential`: the attract/repulse potential and its derivatives ``g, H, H_f, Gamma``;
- :mod:`.geometry`: box-built chiefs, clearance, penetration, swept-segment collisions;
- :mod:`.point_cloud`, :mod:`.mixture`: surface samples, mixtures (published sets), k-means + EM;
- :mod:`.controllers`: reaching law, TSMC (APF/GMM) and NTSMC laws;
- :mod:`.loop`: the sampled-data closed loop's RK4 maps and result on a linear relative plant;
- :mod:`.kernel_numba`: the closed loop compiled (its NumPy oracle is ``tests/oracles/gmm.py``).
"""
