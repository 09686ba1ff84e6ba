"""Figures fit for a paper: column-width sizes, print resolution, small legends.

A two-column paper (IEEE, ACM) sets a figure one column wide (`COLUMN_IN`) or across
both (`PAGE_IN`); text in a figure reads best at the caption's size, 7–8 pt, and a
raster figure prints sharp at `DPI` (vector formats, ``--format pdf`` or ``svg``, need
none). A legend of more than `MAX_LEGEND` entries is cut to that many, its last entry
saying how many more the figure's CSV holds (`few`). `paper` draws a figure function's
text at these sizes.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any, ParamSpec, TypeVar

__all__ = ["COLUMN_IN", "PAGE_IN", "DPI", "MAX_LEGEND", "PAPER_RC", "size", "few", "paper"]

_P = ParamSpec("_P")
_F = TypeVar("_F")

#: One column of a two-column paper, inches (IEEE: 3.5 in).
COLUMN_IN = 3.5
#: Both columns, inches (IEEE: 7.16 in).
PAGE_IN = 7.16
#: Print resolution of raster figures (dots per inch).
DPI = 300
#: The most entries a legend shows.
MAX_LEGEND = 6
#: matplotlib settings for text at caption size.
PAPER_RC: dict[str, Any] = {
    "font.size": 8,
    "axes.titlesize": 8,
    "axes.labelsize": 8,
    "legend.fontsize": 7,
    "legend.title_fontsize": 7,
    "xtick.labelsize": 7,
    "ytick.labelsize": 7,
    "lines.linewidth": 1.0,
    "savefig.dpi": DPI,
}


def size(
    columns: int = 1, height_in: float | None = None, aspect: float = 0.62
) -> tuple[float, float]:
    """A figure's size in inches: ``columns`` (1 or 2) wide, ``height_in`` high (default
    ``aspect`` × the width)."""
    width = COLUMN_IN if columns == 1 else PAGE_IN
    return width, (aspect * width if height_in is None else height_in)


def few(
    handles: Sequence[Any], labels: Sequence[str], most: int = MAX_LEGEND
) -> tuple[list[Any], list[str]]:
    """At most ``most`` legend entries: the first ``most - 1`` and one saying how many more
    there are (an empty handle), when there are more than ``most``."""
    handles, labels = list(handles), list(labels)
    if len(handles) <= most:
        return handles, labels
    from matplotlib.lines import Line2D

    rest = len(handles) - (most - 1)
    more = Line2D([], [], linestyle="none")
    return [*handles[: most - 1], more], [*labels[: most - 1], f"+{rest} more (in the CSV)"]


def paper(draw: Callable[_P, _F]) -> Callable[_P, _F]:
    """Decorator: run a function that returns a figure under `PAPER_RC`. Tick labels are made
    when the figure is drawn, after the context: their size is set on each axes (only on a
    figure the function made itself, not when the caller passed ``ax``)."""

    @functools.wraps(draw)
    def wrapper(*args: _P.args, **kwargs: _P.kwargs) -> _F:
        import matplotlib as mpl

        with mpl.rc_context(PAPER_RC):  # type: ignore[arg-type]
            fig = draw(*args, **kwargs)
        if kwargs.get("ax") is None:
            for ax in getattr(fig, "axes", ()):
                ax.tick_params(axis="x", labelsize=PAPER_RC["xtick.labelsize"])
                ax.tick_params(axis="y", labelsize=PAPER_RC["ytick.labelsize"])
        return fig

    return wrapper
