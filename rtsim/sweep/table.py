"""A sweep's results table from its point records: strict JSON records, one type per column.

Point files are strict JSON: a metric that is not finite (NaN, ±inf; ``w_sch`` of an
infeasible set is ``inf``) is written as ``null`` under ``metrics`` and its value, ``"nan"``,
``"inf"`` or ``"-inf"``, under ``nonfinite`` (`encode_metrics`, `decode_metrics`).

The table (`build_table`) is always writable to Parquet: a metric named like a grid
column becomes ``metric.<name>``; a point whose metric names still clash after that, or
whose metric has another type (``bool``, ``number``, ``text``) than the same metric at the
points before it in point order, is a ``failed`` row with that error (its metrics left
empty). NaN (no value) fits any column.

Seeds: ``seed`` is the seed the user asked for — the grid's ``seed`` value at a point that
has one, else the sweep's ``seed`` (default 0) — and ``point_seed`` the one the point ran
with (the grid's seed itself, else derived from the sweep's seed and the point's values,
[`rtsim.sweep.grid.point_seed`][rtsim.sweep.grid.point_seed]).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import TYPE_CHECKING, Any

from rtsim.sweep.point import RESERVED as _RESERVED  # the table's own columns, in order

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["encode_metrics", "decode_metrics", "value_type", "build_table"]

_NONFINITE = {"nan": math.nan, "inf": math.inf, "-inf": -math.inf}


def encode_metrics(metrics: Mapping[str, Any]) -> tuple[dict[str, Any], dict[str, str]]:
    """``(metrics with non-finite floats as None, {name: "nan" | "inf" | "-inf"})``."""
    out: dict[str, Any] = {}
    special: dict[str, str] = {}
    for k, v in metrics.items():
        if isinstance(v, float) and not math.isfinite(v):
            special[k] = "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
            out[k] = None
        else:
            out[k] = v
    return out, special


def decode_metrics(rec: Mapping[str, Any]) -> dict[str, Any]:
    """A record's metrics with the non-finite values restored (a bare ``null`` is NaN)."""
    special = rec.get("nonfinite") or {}
    out = {}
    for k, v in (rec.get("metrics") or {}).items():
        out[k] = _NONFINITE.get(special.get(k, "nan"), math.nan) if v is None else v
    return out


def value_type(v: Any) -> str | None:
    """``bool``, ``number`` or ``text``; None for NaN (no value, fits every column)."""
    if isinstance(v, bool):
        return "bool"
    if isinstance(v, int | float):
        return None if isinstance(v, float) and math.isnan(v) else "number"
    return "text"


def build_table(
    order: Sequence[Any],
    record: Callable[[Any], Mapping[str, Any]],
    param_cols: Sequence[str],
    sweep_seed: int = 0,
) -> pd.DataFrame:
    """The results table: one row per point of ``order`` (objects with ``params`` and
    ``seed``), ``record(point)`` its finished record; ``sweep_seed``: the sweep's seed, the
    ``seed`` column of points without a grid seed. See the module docstring."""
    import pandas as pd

    rows: list[dict[str, Any]] = []
    metric_cols: list[str] = []
    col_type: dict[str, tuple[str, int]] = {}  # column -> (type, index of the first point)
    params = set(param_cols)
    for p in order:
        rec = record(p)
        row: dict[str, Any] = {k: p.params[k] for k in param_cols}
        asked = p.params.get("seed", sweep_seed)
        row.update(seed=asked, point_seed=p.seed, status=rec["status"], error=rec["error"])
        metrics = decode_metrics(rec) if rec["status"] == "ok" else {}
        named: dict[str, Any] = {}
        error = ""
        for k, v in metrics.items():
            col = f"metric.{k}" if k in params else k
            if col in named or col in params or col in _RESERVED:
                error = (
                    f"ValueError: metric '{k}' clashes with another column "
                    f"'{col}' of the results table"
                )
                break
            named[col] = v
        if not error:
            for col, v in named.items():
                t = value_type(v)
                seen = col_type.get(col)
                if t is not None and seen is not None and seen[0] != t:
                    error = (
                        f"TypeError: metric '{col}' is {t} ({v!r}) but {seen[0]} at point "
                        f"{seen[1]} (one type per results column)"
                    )
                    break
        if error:
            row.update(status="failed", error=error)
            named = {}
        for col, v in named.items():
            t = value_type(v)
            if t is not None and col not in col_type:
                col_type[col] = (t, getattr(p, "index", 0))
            if col not in row:
                if col not in metric_cols:
                    metric_cols.append(col)
                row[col] = v
        rows.append(row)
    cols = list(param_cols) + list(_RESERVED) + metric_cols
    df = pd.DataFrame.from_records(rows, columns=cols)
    df["seed"] = df["seed"].astype("int64")
    df["point_seed"] = df["point_seed"].astype("int64")
    return df
