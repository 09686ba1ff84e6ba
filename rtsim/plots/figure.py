"""The one place rtsim's plotting functions get a new figure from.

Outside IPython a figure is a plain `matplotlib.figure.Figure`, made without pyplot
(nothing to close, nothing shown by surprise). In an IPython kernel whose matplotlib backend
is the inline one (Jupyter's default) it is a pyplot figure, so that it shows however the user
calls it, as any matplotlib figure does there: at the end of the cell, on ``plt.show()``, or
returned as the cell's value — once, because the PNG formatter of
`rtsim.notebook.enable_figure_display` closes a pyplot figure it has shown (the inline
backend registers its own formatter when it starts, so `new_figure` registers rtsim's
again after).
"""

from __future__ import annotations

import sys
from typing import Any

from matplotlib.figure import Figure

from rtsim.notebook import enable_figure_display

__all__ = ["new_figure", "inline_kernel"]


def inline_kernel() -> bool:
    """Whether this is an IPython shell drawing with the inline backend."""
    if "IPython" not in sys.modules:
        return False
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover
        return False
    if get_ipython() is None:
        return False
    import matplotlib

    return "inline" in str(matplotlib.get_backend()).lower()


def new_figure(**kwargs: Any) -> Figure:
    """A new figure (``kwargs`` as `Figure`'s; module docstring)."""
    if inline_kernel():
        import matplotlib.pyplot as plt

        fig = plt.figure(**kwargs)
        enable_figure_display()  # after the backend, which registers its own on its start
        return fig
    return Figure(**kwargs)
