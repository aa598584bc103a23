"""GMM-FTC proximity to a rotating, complex-shaped target (Chen et al. 2020; docs/papers.md).

``target`` holds the target's geometry, point cloud and GMMs (published Table 2, shipped fit),
``law`` the fixed-time controller (eqs 20-31, eq 36 bound), ``loop`` the sampled-data
simulation's settings, result and metrics, ``kernel_numba`` the loop compiled (its NumPy oracle
is ``tests/oracles/gmm_ftc.py``), ``noise`` the keyed thruster-error streams, ``params`` the
parameters, ``model`` the registered model. The nominal scenario beside the paper is
:mod:`uqguide.papers.gmm_ftc`.
"""

from .model import GMMFTC
from .params import GMMFTCParams

__all__ = ["GMMFTC", "GMMFTCParams"]
