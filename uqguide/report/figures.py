"""The one way uqguide makes a figure: a bare :class:`~matplotlib.figure.Figure` on an Agg
canvas, written whole or not at all.

No ``pyplot``: its global figure registry leaks memory in long runs, is not thread-safe and
needs ``matplotlib.use`` before first import, which a library must not impose on its caller.
A figure from :func:`new_figure` is garbage-collected like any object, and :func:`save` writes
through :mod:`uqguide.core.atomic`, so a killed run never leaves a torn PNG under the final name.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import Colormap
from matplotlib.figure import Figure

from ..core import atomic

__all__ = ["Figure", "colormap", "new_figure", "save"]


def new_figure(figsize: tuple[float, float], *,
               layout: Literal["constrained", "compressed", "tight"] | None = None,
               **kwargs: Any) -> Figure:
    """A figure drawn by the Agg canvas, owned by the caller only; ``figsize`` in inches,
    ``kwargs`` to :class:`matplotlib.figure.Figure`. Add axes with ``fig.add_subplot`` or
    ``fig.subplots``."""
    fig = Figure(figsize=figsize, layout=layout, **kwargs)
    FigureCanvasAgg(fig)
    return fig


def save(fig: Figure, path: str | Path, dpi: float = 100, **kwargs: Any) -> Path:
    """Write ``fig`` as a PNG at ``path`` atomically, making its folder; return ``path``.

    ``kwargs`` go to :meth:`Figure.savefig` (e.g. ``bbox_inches="tight"``).
    """
    return atomic.write_with(path, lambda f: fig.savefig(f, dpi=dpi, format="png", **kwargs),
                             binary=True)


def colormap(name: str) -> Colormap:
    """A registered colormap by name (``pyplot.get_cmap`` without pyplot)."""
    from matplotlib import colormaps

    return colormaps[name]
