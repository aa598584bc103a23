"""FTCAPN rendezvous guidance simulator (Wang & Song 2019; spec ftcapn.md).

``model`` holds the model class and its parameters, ``kernel_numpy`` the reference closed loop,
``kernel_numba`` the compiled one, ``drift`` the zero-effort-miss closed forms, ``layout`` the
kernels' output layout. The paper's nominal report and figures are in :mod:`uqguide.papers.ftcapn`.
"""

from .model import FTCAPN, FTCAPNParams

__all__ = ["FTCAPN", "FTCAPNParams"]
