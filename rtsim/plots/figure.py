"""The one place rtsim's plotting functions get a new figure from.

Outside IPython a figure is a plain :class:`matplotlib.figure.Figure`, made without pyplot
(nothing to close, nothing shown by surprise). In an IPython kernel whose matplotlib backend
is the inline one (Jupyter's default) it is a pyplot figure, so that it shows however the user
calls it, as any matplotlib figure does there: at the end of the cell, on ``plt.show()``, or
returned as the cell's value — once, because the PNG formatter :func:`show_once` closes a
pyplot figure it has shown (:func:`enable_figure_display` registers it; the inline backend
registers its own when it starts, so :func:`new_figure` registers it again after).
"""

from __future__ import annotations

import io
import sys
from typing import Any

from matplotlib.figure import Figure

__all__ = ["new_figure", "inline_kernel", "figure_png", "show_once", "enable_figure_display"]


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
    """A new figure (``kwargs`` as :class:`~matplotlib.figure.Figure`'s; module docstring)."""
    if inline_kernel():
        import matplotlib.pyplot as plt

        fig = plt.figure(**kwargs)
        enable_figure_display()  # after the backend, which registers its own on its start
        return fig
    return Figure(**kwargs)


def figure_png(fig: Any, dpi: int = 100) -> bytes:
    """A matplotlib Figure as PNG bytes (works for figures made with or without pyplot)."""
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi, bbox_inches="tight")
    return buf.getvalue()


def show_once(fig: Any) -> bytes:
    """The PNG of a figure IPython shows; a pyplot figure is then closed, so that the inline
    backend does not show it a second time at the end of the cell."""
    png = figure_png(fig)
    if getattr(fig.canvas, "manager", None) is not None and "matplotlib.pyplot" in sys.modules:
        import matplotlib.pyplot as plt

        plt.close(fig)
    return png


def enable_figure_display() -> bool:
    """Show a ``matplotlib.figure.Figure`` returned as a cell's value (or given to
    ``display``) as a PNG, once: registers :func:`show_once` as the running IPython shell's
    PNG formatter of ``Figure``. Returns whether an IPython shell was found (nothing is done
    outside IPython)."""
    if "IPython" not in sys.modules:
        return False
    try:
        from IPython import get_ipython
    except ImportError:  # pragma: no cover
        return False
    ip = get_ipython()
    if ip is None:
        return False
    ip.display_formatter.formatters["image/png"].for_type(Figure, show_once)
    return True
