"""The windows table in long form: one row per window and follower (``followers.csv``).

``windows.csv`` is wide: every per-follower quantity is a column per follower (``f1_x`` …
``f4_viol_contact``, 169 columns at n = 4). `followers_frame` turns those into one
row per (window, follower), so a per-follower question is a ``groupby`` rather than a melt:

- ``window``, ``t`` (ms, the window's release), ``w`` (ms), ``follower`` (1..n);
- the truth: ``x``, ``y`` (cm, world frame), ``heading``, ``rho`` (cm), ``beta``,
  ``theta`` (rad), ``v`` (cm/s);
- the leader's estimate of the same, ``x_est`` … ``v_est``, and ``error`` (cm), the distance
  between the estimated and the true position (the fix error);
- per bound (localization, separation, path_diversion, bearing): ``msb_<bound>_pred`` (ms,
  what the decision predicted) and ``msb_<bound>_true`` (ms, what the world did),
  ``viol_<bound>`` (the violation ratio);
- ``contact_cm_pred``, ``contact_cm_true`` (cm), ``viol_contact``: the closest approach to
  any other robot, predicted and true, and whether it broke 2·r_F + clearance;
- ``lost``: whether the follower's track was lost in that window.

Column names are the wide table's with the ``f<k>_`` prefix removed (docs/outputs.md).
"""

from __future__ import annotations

import re
from collections.abc import Iterable
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["WINDOW_KEYS", "follower_count", "followers_frame"]

#: The window's columns repeated on every follower's row.
WINDOW_KEYS: tuple[str, ...] = ("window", "t", "w")
_FOLLOWER = re.compile(r"^f(\d+)_(.+)$")


def follower_count(columns: Iterable[object]) -> int:
    """How many followers a wide windows table's ``columns`` describe (the largest ``k`` of
    an ``f<k>_`` column; 0 without one)."""
    ks = [int(m.group(1)) for c in columns if (m := _FOLLOWER.match(str(c)))]
    return max(ks, default=0)


def followers_frame(windows: pd.DataFrame) -> pd.DataFrame:
    """``windows`` (the wide table of a run, or a chunk of it) in long form (module doc):
    rows ordered by window, then follower."""
    import numpy as np
    import pandas as pd

    per: dict[int, dict[str, str]] = {}
    for col in windows.columns:
        m = _FOLLOWER.match(str(col))
        if m:
            per.setdefault(int(m.group(1)), {})[col] = m.group(2)
    keys = [k for k in WINDOW_KEYS if k in windows.columns]
    parts = []
    for k in sorted(per):
        part = windows[keys + list(per[k])].rename(columns=per[k])
        part.insert(len(keys), "follower", np.full(len(part), k, dtype="int64"))
        parts.append(part)
    if not parts:
        return pd.DataFrame(columns=[*keys, "follower"])
    out = pd.concat(parts, ignore_index=False).sort_index(kind="stable")
    if {"x", "y", "x_est", "y_est"} <= set(out.columns):
        err = np.hypot(out["x_est"] - out["x"], out["y_est"] - out["y"])
        cols = list(out.columns)
        at = cols.index("v_est") + 1 if "v_est" in cols else len(cols)
        out.insert(at, "error", err)
    return out.reset_index(drop=True)
