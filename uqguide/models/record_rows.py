"""Record writers the compiled kernels share: copy a run's recorded quantities into the outputs.

Plain copies, no arithmetic: they cannot change a number. The work and output shapes they
serve: docs/simulators.md#the-compiled-kernels-records. Imported by the ``kernel_numba``
modules only (it compiles on import).
"""

from __future__ import annotations

from .kernels import njit


@njit(cache=True, inline="always")
def put_lane(out, i, j, o, src, q0, width, l):  # pragma: no cover - compiled
    """``out[i, j, o + q] = src[q0 + q, l]`` for ``q < width`` (lane ``l`` of a block's work
    into sample ``i``'s grid row ``j``); nothing when ``o < 0``."""
    if o >= 0:
        for q in range(width):
            out[i, j, o + q] = src[q0 + q, l]


@njit(cache=True, inline="always")
def put_vector(out, i, j, o, src, q0, width):  # pragma: no cover - compiled
    """``out[i, j, o + q] = src[q0 + q]`` for ``q < width`` (one sample's work vector into its
    grid row ``j``); nothing when ``o < 0``."""
    if o >= 0:
        for q in range(width):
            out[i, j, o + q] = src[q0 + q]


@njit(cache=True, inline="always")
def put_lanes(buf, c, i0, j, src, q0, width, m, running):  # pragma: no cover - compiled
    """``buf[c + q, i0 + l, j] = src[q0 + q, l]`` for ``q < width`` and every running lane
    ``l < m`` (a block's work into grid row ``j`` of the series columns from ``c``); nothing
    when ``c < 0``."""
    if c >= 0:
        for q in range(width):
            for l in range(m):
                if running[l]:
                    buf[c + q, i0 + l, j] = src[q0 + q, l]
