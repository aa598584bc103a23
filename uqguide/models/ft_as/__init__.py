"""FT-AS 6-DOF tracking control (Wei et al. 2024) and its two comparison controllers."""

from .model import FTAS

__all__ = ["FTAS"]
