"""GMM-FTC proximity to a rotating, complex-shaped target (Chen et al. 2020; docs/papers.md).

``target`` holds the target's geometry, point cloud and GMMs (published Table 2, shipped fit),
``law`` the fixed-time controller (eqs 20-31, eq 36 bound), ``kernel_numpy`` the sampled-data
simulation with its metrics (NumPy reference), ``kernel_numba`` the same loop compiled,
``noise`` the keyed thruster-error streams, ``params`` the parameters, ``model`` the
registered model. The nominal scenario beside the paper is :mod:`uqguide.papers.gmm_ftc`.
"""

from .model import GMMFTC
from .params import GMMFTCParams

__all__ = ["GMMFTC", "GMMFTCParams"]
