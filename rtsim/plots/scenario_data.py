"""What a scenario figure shows, selected from a run's ``windows.csv`` table (docs/outputs.md):
the followers present, the critical spans, the violation ratios, the columns each figure
plots ([`figure_data`][rtsim.plots.scenario_data.figure_data]) and the rows a long run is drawn from
(`thin_rows`). No
drawing here: `rtsim.plots.scenario` draws what these return.
"""

from __future__ import annotations

import re

import numpy as np
import pandas as pd

from rtsim.coupling.recorder import window_columns
from rtsim.errors import InputError

__all__ = [
    "BOUND_KINDS",
    "FIGURE_BUCKETS",
    "FIGURE_MAX_ROWS",
    "binding_xy",
    "critical_spans",
    "figure_columns",
    "figure_data",
    "followers",
    "thin_rows",
    "violation_ratios",
]

BOUND_KINDS: tuple[str, ...] = ("localization", "separation", "path_diversion", "bearing")

# Okabe-Ito colour-blind-safe palette; one colour per quantity, the same in every figure.
VIOLATION_TOLERANCE = 0.05  # a broken bound counts beyond this relative overshoot

_FOLLOWER_RE = re.compile(r"^f(\d+)_x$")


# --- the table ---------------------------------------------------------------------------


def followers(df: pd.DataFrame) -> list[int]:
    """Follower numbers (1-based) found in the columns ``f{i}_x``, in numeric order."""
    found = (_FOLLOWER_RE.match(str(c)) for c in df.columns)
    return sorted(int(m.group(1)) for m in found if m)


def need_columns(df: pd.DataFrame, cols: list[str], what: str) -> None:
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise InputError(f"windows table: missing column {missing[0]!r} (needed for {what})")


def as_bool(s: pd.Series) -> np.ndarray:
    """A boolean column as read from CSV (bool dtype, or 'True'/'False' text)."""
    if s.dtype == bool:
        return s.to_numpy()
    text = s.astype(str).str.strip().str.lower()
    return text.isin(("true", "1", "1.0")).to_numpy()


def as_floats(s: pd.Series) -> np.ndarray:
    return pd.to_numeric(s, errors="coerce").to_numpy(dtype=float)


def times_s(df: pd.DataFrame) -> np.ndarray:
    return as_floats(df["t"]) / 1000.0


def ends_s(df: pd.DataFrame) -> np.ndarray:
    """End of each window in s: the next window's start; the last one ends at t + w."""
    t = times_s(df)
    if len(t) == 0:
        return t
    last_w = as_floats(df["w"])[-1] / 1000.0 if "w" in df.columns else 0.0
    last = t[-1] + (last_w if np.isfinite(last_w) else 0.0)
    return np.append(t[1:], last)


def spans_of(df: pd.DataFrame, mask: np.ndarray) -> list[tuple[float, float]]:
    """Maximal runs of consecutive windows where ``mask`` holds, as (start, end) in s."""
    t, ends = times_s(df), ends_s(df)
    spans: list[tuple[float, float]] = []
    start = None
    for i, on in enumerate(mask):
        if on and start is None:
            start = i
        if start is not None and (not on or i == len(mask) - 1):
            stop = i if on else i - 1
            spans.append((float(t[start]), float(ends[stop])))
            start = None
    return spans


def critical_spans(df: pd.DataFrame) -> list[tuple[float, float]]:
    """Time spans (s) of the critical region, min MSB < w_sch (runs of ``critical`` windows)."""
    need_columns(df, ["t", "critical"], "the critical region")
    return spans_of(df, as_bool(df["critical"]))


def kind_min(df: pd.DataFrame, kind: str, which: str) -> np.ndarray:
    """Per window, the minimum over followers of one bound kind's ``which`` (``pred`` or
    ``true``) column (inf when none is finite)."""
    cols = [f"f{i}_msb_{kind}_{which}" for i in followers(df)]
    need_columns(df, cols, f"the {kind} bound")
    if not cols:
        return np.full(len(df), np.inf)
    return np.min(np.column_stack([as_floats(df[c]) for c in cols]), axis=1)


def violation_ratios(df: pd.DataFrame) -> np.ndarray:
    """Per (window, follower, bound) the observed change over its threshold, w / ``_true``
    (> 1: the window broke the bound), as an (m, n·4) array (empty without ``_true``)."""
    cols = [f"f{i}_msb_{k}_true" for i in followers(df) for k in BOUND_KINDS]
    cols = [c for c in cols if c in df.columns]
    if not cols or "w" not in df.columns:
        return np.zeros((len(df), 0))
    true = np.column_stack([as_floats(df[c]) for c in cols])
    return as_floats(df["w"])[:, None] / true


def headline_counts(df: pd.DataFrame) -> str:
    """Panel headline: violations beyond 5 % and the largest violation ratio first, then
    misses and lost tracks."""
    missed = int(as_bool(df["missed"]).sum()) if "missed" in df.columns else 0
    lost = int(as_floats(df["tracks_lost"]).sum()) if "tracks_lost" in df.columns else 0
    r = violation_ratios(df)
    beyond = int((r > 1.0 + VIOLATION_TOLERANCE).sum())
    worst = float(r.max()) if r.size else 0.0
    return (
        f"violations > 5 % {beyond} · max ratio {worst:.2f} · misses {missed}\nlost tracks {lost}"
    )


def figure_columns(n: int) -> list[str]:
    """The columns of windows.csv that
    [`write_scenario_figures`][rtsim.plots.write_scenario_figures] draws (``n`` followers),
    in table order — what a long run reads back instead of the whole table."""
    need = {
        "window",
        "t",
        "w",
        "slack",
        "w_sch",
        "missed",
        "critical",
        "msb_min",
        "binding",
        "v_leader_desired",
        "v_leader",
        "v_leader_target",
        "segment",
        "leader_x",
        "leader_y",
    }
    for i in range(1, n + 1):
        need |= {f"f{i}_x", f"f{i}_y", f"f{i}_x_est", f"f{i}_y_est"}
        need |= {f"f{i}_msb_{k}_{which}" for k in BOUND_KINDS for which in ("pred", "true")}
    return [c for c in window_columns(n) if c in need]


#: The scenario figures in the order they are written (``SCENARIO_FIGURES``).
FIGURE_NAMES: tuple[str, ...] = (
    "paths",
    "window_slack",
    "bounds",
    "msb",
    "speed",
    "operating_space",
)

#: A run with more windows than this is drawn from a selection of rows (`thin_rows`).
FIGURE_MAX_ROWS = 20_000
#: Buckets of consecutive windows `thin_rows` keeps extremes of.
FIGURE_BUCKETS = 1_000


def thin_rows(df: pd.DataFrame, bucket: int) -> np.ndarray:
    """Which rows to draw of a long windows table (a boolean mask): per ``bucket``
    consecutive windows the first and last and, for every plotted value (w, slack, w_sch,
    min MSB, leader speed and target, each follower's predicted and true bounds), the rows of
    its smallest and largest value; both rows of every change of ``critical`` (so the shaded
    regions are exact) and every missed window (each is marked and counted). A figure of
    ~1000 pixels cannot show more; its lines and extremes are those of the whole table."""
    m = len(df)
    keep = np.zeros(m, dtype=bool)
    if m == 0:
        return keep
    bucket = max(1, int(bucket))
    nb = -(-m // bucket)
    starts = np.arange(nb) * bucket
    keep[starts] = True
    keep[np.minimum(starts + bucket, m) - 1] = True
    if "critical" in df.columns:
        f = as_bool(df["critical"])
        ch = np.flatnonzero(f[1:] != f[:-1])
        keep[ch] = True
        keep[ch + 1] = True
    if "missed" in df.columns:
        keep |= as_bool(df["missed"])
    guarded = [
        c
        for c in df.columns
        if c in ("w", "slack", "w_sch", "msb_min", "v_leader", "v_leader_target")
        or (str(c).startswith("f") and "_msb_" in str(c) and str(c).endswith(("_pred", "_true")))
    ]
    pad = nb * bucket - m
    for c in guarded:
        v = as_floats(df[c])
        nan = np.isnan(v)
        lo = np.pad(np.where(nan, np.inf, v), (0, pad), constant_values=np.inf)
        hi = np.pad(np.where(nan, -np.inf, v), (0, pad), constant_values=-np.inf)
        for pos in (lo.reshape(nb, bucket).argmin(axis=1), hi.reshape(nb, bucket).argmax(axis=1)):
            idx = starts + pos
            keep[idx[idx < m]] = True
    return keep


def figure_data(df: pd.DataFrame, name: str) -> pd.DataFrame:
    """The exact columns figure ``name`` plots, taken or derived from the windows table.

    Columns named as in ``windows.csv`` carry its values unchanged (times stay in ms; the
    figures divide by 1000). ``bound_<kind>_pred`` / ``bound_<kind>_true`` are the minimum
    over followers of ``f{i}_msb_<kind>_pred`` (the decision's prediction at the highest
    speed the leader had in the window) and ``f{i}_msb_<kind>_true`` (what the world showed);
    ``msb_min_pred`` / ``msb_min_true`` the minimum of those over the bound kinds (operating
    space). Infinite values stay ``inf``.
    """
    keys = ["window", "t"]
    if name == "paths":
        cols = keys + ["leader_x", "leader_y"]
        for i in followers(df):
            cols += [f"f{i}_x", f"f{i}_y", f"f{i}_x_est", f"f{i}_y_est"]
        cols.append("critical")
        if "binding" in df.columns:
            cols.append("binding")
    elif name == "window_slack":
        cols = keys + ["w", "slack", "w_sch", "missed", "critical"]
    elif name == "bounds":
        cols = keys + ["w", "w_sch", "critical"]
    elif name == "msb":
        cols = keys + ["w", "w_sch", "msb_min", "binding", "critical"]
    elif name == "speed":
        cols = keys + ["v_leader_desired", "v_leader", "v_leader_target", "segment"]
    elif name == "operating_space":
        cols = keys + ["w", "w_sch", "msb_min", "critical"]
    else:
        raise InputError(f"figure_data: unknown figure {name!r} (known: {', '.join(FIGURE_NAMES)})")
    need_columns(df, cols, f"the {name} figure")
    out = df.loc[:, cols].reset_index(drop=True)
    if name == "msb":
        out["msb_min_true"] = np.min(
            np.column_stack([kind_min(df, kind, "true") for kind in BOUND_KINDS]), axis=1
        )
    if name in ("bounds", "operating_space"):
        for which in ("pred", "true"):
            mins = {kind: kind_min(df, kind, which) for kind in BOUND_KINDS}
            if name == "bounds":
                for kind in BOUND_KINDS:
                    out[f"bound_{kind}_{which}"] = mins[kind]
            else:
                out[f"msb_min_{which}"] = np.min(np.column_stack(list(mins.values())), axis=1)
    return out


# --- drawing helpers ---------------------------------------------------------------------


def binding_xy(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Per window, the true position of the follower whose bound binds (``binding`` =
    ``kind:i``); the leader's where no follower binds or the table has no ``binding``."""
    x, y = as_floats(df["leader_x"]).copy(), as_floats(df["leader_y"]).copy()
    if "binding" not in df.columns:
        return x, y
    who = df["binding"].astype(str).str.rsplit(":", n=1).str[-1]
    num = pd.to_numeric(who, errors="coerce").to_numpy()
    for i in followers(df):
        sel = num == i
        if sel.any():
            x[sel] = as_floats(df[f"f{i}_x"])[sel]
            y[sel] = as_floats(df[f"f{i}_y"])[sel]
    return x, y
