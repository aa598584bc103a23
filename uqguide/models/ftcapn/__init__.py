"""FTCAPN rendezvous guidance simulator (Wang & Song 2019; spec ftcapn.md).

``model`` holds the model class and its parameters, ``kernel_numpy`` the reference closed loop,
``kernel_numba`` the compiled one, ``drift`` the zero-effort-miss closed forms, ``report`` the
nominal scenario's figures beside the paper's.
"""

from .model import FTCAPN, FTCAPNParams

__all__ = ["FTCAPN", "FTCAPNParams"]
