"""FTCAPN rendezvous guidance simulator (Wang & Song 2019; docs/papers.md).

``params`` holds the parameters, ``model`` the model class, ``kernel_numba`` the compiled closed
loop (its NumPy oracle is ``tests/oracles/ftcapn.py``), ``drift`` the zero-effort-miss closed
forms, ``layout`` the kernel's output layout. The paper's nominal report and figures are in
:mod:`uqguide.papers.ftcapn`.
"""

from .model import FTCAPN
from .params import FTCAPNParams

__all__ = ["FTCAPN", "FTCAPNParams"]
