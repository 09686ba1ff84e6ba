"""Notebook display: short reprs and HTML reprs of results, figures shown as cell values.

- `ResultDisplay` (a mixin of [`ScenarioResult`][rtsim.coupling.ScenarioResult],
  [`SimResult`][rtsim.sim.SimResult], [`SweepOutcome`][rtsim.sweep.SweepOutcome] and
  `ValidationOutcome`): ``repr`` is one line of headline facts,
  ``_repr_html_`` those facts and the ``summary_frame()`` table, so a result returned as a
  cell's value shows its summary rather than thousands of characters of DataFrames.
- `enable_figure_display`: a matplotlib ``Figure`` returned as a cell's value is shown as
  a PNG in any IPython kernel, with or without ``%matplotlib inline``, once: with the inline
  backend rtsim's figures are pyplot figures (``rtsim.plots.figure``), shown at the end
  of the cell or on ``plt.show()`` too, and a figure shown as the cell's value is closed so
  that the backend does not show it again. Called when [`rtsim.plots`][rtsim.plots] is imported;
  does
  nothing outside IPython.
"""

from __future__ import annotations

import html
import io
import math
import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["ResultDisplay", "enable_figure_display", "flatten", "figure_png"]

#: Rows of a summary table shown in ``_repr_html_`` before it is cut.
HTML_MAX_ROWS = 40


def flatten(obj: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested mappings as one level with dotted keys (``violations.separation``)."""
    out: dict[str, Any] = {}
    for k, v in obj.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out.update(flatten(v, key + "."))
        else:
            out[key] = v
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, bool) or v is None:
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else f"{v:.4g}"
    return str(v)


class ResultDisplay:
    """Mixin: one-line ``repr`` from `headline`, HTML from it and `summary_frame`.

    A class using it is a ``@dataclass(repr=False)`` that defines ``headline()`` (an ordered
    dict of a few scalar facts) and ``summary_frame()`` (a DataFrame).
    """

    def headline(self) -> dict[str, Any]:  # pragma: no cover - every result overrides it
        raise NotImplementedError

    def summary_frame(self) -> pd.DataFrame:  # pragma: no cover - every result overrides it
        raise NotImplementedError

    def __repr__(self) -> str:
        facts = ", ".join(f"{k}={_fmt(v)}" for k, v in self.headline().items())
        return f"<{type(self).__name__} {facts}>"

    def _repr_html_(self) -> str:
        facts = " · ".join(
            f"<b>{html.escape(k)}</b> {html.escape(_fmt(v))}" for k, v in self.headline().items()
        )
        df = self.summary_frame()
        table = df.to_html(
            max_rows=HTML_MAX_ROWS,
            float_format=lambda x: f"{x:.6g}",
            border=0,
            classes="rtsim-summary",
        )
        return (
            f"<div class='rtsim-result'><p><code>{type(self).__name__}</code>: {facts}</p>"
            f"{table}</div>"
        )


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
    ``display``) as a PNG, once: registers `show_once` as the running IPython shell's
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
    from matplotlib.figure import Figure

    ip.display_formatter.formatters["image/png"].for_type(Figure, show_once)
    return True
