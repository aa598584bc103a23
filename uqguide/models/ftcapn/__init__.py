"""FTCAPN rendezvous guidance simulator (Wang & Song 2019; docs/papers.md).

``params`` holds the parameters, ``model`` the model class, ``kernel_numpy`` the reference
closed loop, ``kernel_numba`` the compiled one, ``drift`` the zero-effort-miss closed forms,
``layout`` the kernels' output layout. The paper's nominal report and figures are in
:mod:`uqguide.papers.ftcapn`.
"""

from .model import FTCAPN
from .params import FTCAPNParams

__all__ = ["FTCAPN", "FTCAPNParams"]
