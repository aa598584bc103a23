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

__all__ = ["Figure", "colormap", "input_colour", "new_figure", "save", "FORMATS"]

#: The file formats :func:`save` writes (``uqguide plot --format``).
FORMATS = ("png", "svg", "pdf")
#: One colour per input, by its place in the config (tab10, then tab20's light shades).
_INPUT_COLOURS = ["#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
                  "#bcbd22", "#17becf", "#7f7f7f", "#aec7e8", "#ff9896", "#98df8a", "#ffbb78",
                  "#c5b0d5", "#c49c94", "#f7b6d2", "#dbdb8d", "#9edae5", "#c7c7c7"]


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
    """Write ``fig`` at ``path`` atomically, making its folder; return ``path``. The format is
    the file's suffix (one of :data:`FORMATS`, else PNG).

    ``kwargs`` go to :meth:`Figure.savefig` (e.g. ``bbox_inches="tight"``).
    """
    fmt = Path(path).suffix.lstrip(".").lower()
    fmt = fmt if fmt in FORMATS else "png"
    return atomic.write_with(path, lambda f: fig.savefig(f, dpi=dpi, format=fmt, **kwargs),
                             binary=True)


def input_colour(i: int) -> str:
    """The colour of input ``i`` (its place among the config's inputs) in every figure."""
    return _INPUT_COLOURS[i % len(_INPUT_COLOURS)]


def colormap(name: str) -> Colormap:
    """A registered colormap by name (``pyplot.get_cmap`` without pyplot)."""
    from matplotlib import colormaps

    return colormaps[name]
