"""FT-AS 6-DOF tracking control (Wei et al. 2024) and its two comparison controllers.

``params`` holds the parameters, ``model`` the model class, ``setup`` the plant, gains and
batch objects, ``scenario`` the reference orbit and disturbances, ``equations`` the spec's
equations in NumPy (one function per equation), ``kernel_numpy`` the whole-run NumPy reference
loop, ``kernel_numba`` the compiled one, ``layout`` what both record, ``runner`` the batch
entry point that chooses between them (:func:`uqguide.models.kernels.select`).
"""

from .model import FTAS

__all__ = ["FTAS"]
