"""FT-AS 6-DOF tracking control (Wei et al. 2024) and its two comparison controllers.

``params`` holds the parameters, ``model`` the model class, ``setup`` the plant, gains and
batch objects, ``scenario`` the reference orbit and disturbances, ``kernel_numba`` the compiled
closed loop (the equations in NumPy and the whole-run NumPy oracle are
``tests/oracles/ft_as_equations.py`` and ``tests/oracles/ft_as.py``), ``layout`` what it
records, ``runner`` the batch entry point.
"""

from .model import FTAS

__all__ = ["FTAS"]
