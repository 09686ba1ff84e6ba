"""summary.json from a run's window records (docs/outputs.md): the headline counts, the
critical share, the violations and the physical outcome, computed from the records' columns."""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from rtsim.analysis.kinematics import BOUND_KINDS
from rtsim.coupling.recorder import LOCALIZATION_COLUMNS, sensing_columns
from rtsim.world.config import WorldConfig
from rtsim.world.localization import LOST_CAUSES

__all__ = ["formation_model", "summarize", "summary_columns"]


def formation_model(cfg: WorldConfig) -> str:
    """The followers' control law of ``cfg`` (summary.json ``formation_model``):
    ``follow-the-leader`` or ``l-psi``."""
    return str(cfg.formation.model)


def _name(predictor: Any) -> str:
    return predictor if isinstance(predictor, str) else getattr(predictor, "__name__", "callable")


def summary_columns(n: int) -> list[str]:
    """The columns of windows.csv that [`summarize`][rtsim.coupling.summary.summarize] reads (``n``
    followers)."""
    return [
        "w",
        "w_sch",
        "msb_min",
        "binding",
        "critical",
        "missed",
        "tracks_lost",
        "assumption_broken",
        "method",
        "v_leader",
        "v_leader_desired",
        "feasible",
        "response",
        *(f"f{i}_viol_{k}" for i in range(1, n + 1) for k in BOUND_KINDS),
        *LOCALIZATION_COLUMNS,
        *sensing_columns(n),
    ]


def _p95_max(values: Any) -> dict[str, float] | None:
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]  # (inf: no fix)
    if not v.size:
        return None
    return {"p95": float(np.percentile(v, 95)), "max": float(v.max())}


def fix_errors(df: pd.DataFrame | Mapping[str, Any], n: int) -> dict[str, Any] | None:
    """summary.json ``localization_error_cm``: the accepted fixes' distance from the truth
    (cm; windows without a fix left out), p95 and max over every follower's fixes and
    ``per_follower`` (None: a table without the columns, or no fix)."""
    cols = [f"f{i}_fix_error_cm" for i in range(1, n + 1)]
    if any(c not in df for c in cols):
        return None
    per = [np.asarray(df[c], dtype=float) for c in cols]
    every = _p95_max(np.concatenate(per) if per else [])
    if every is None:
        return None
    return {**every, "per_follower": [_p95_max(v) for v in per]}


def _total(df: pd.DataFrame | Mapping[str, Any], col: str) -> int:
    """Sum of an integer column of windows.csv (0 when a table from before it lacks it)."""
    return int(np.asarray(df[col], dtype=np.int64).sum()) if col in df else 0


def summarize(
    df: pd.DataFrame | Mapping[str, Any],
    *,
    mode: str,
    w_sch: float,
    duration_s: float,
    seed: int,
    scenario: str,
    n: int,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """summary.json from windows.csv (docs/outputs.md) and run facts. ``df``: the table, or
    its columns (name -> array or list, as `records_columns`
    gives them): the summary is computed from arrays either way."""

    def col(name: str, dtype: Any = float) -> Any:
        return np.asarray(df[name], dtype=dtype)

    w = col("w")
    rows = len(w)
    crit = col("critical", bool)
    total_w = float(w.sum())
    violations = {
        k: int(sum(int(col(f"f{i}_viol_{k}", bool).sum()) for i in range(1, n + 1)))
        for k in BOUND_KINDS
    }
    binding_critical: dict[str, int] = {}
    for b in col("binding", object)[crit].tolist():
        kind = str(b).split(":")[0]
        binding_critical[kind] = binding_critical.get(kind, 0) + 1
    methods: dict[str, int] = {}
    for m in col("method", object).tolist():
        methods[str(m)] = methods.get(str(m), 0) + 1
    ratio = col("msb_min") / col("w_sch")
    speed = col("v_leader") / col("v_leader_desired")
    response = col("response")
    with np.errstate(invalid="ignore"):  # the table's max skips NaN (none in practice)
        kept = response[~np.isnan(response)]
    out: dict[str, Any] = {
        "scenario": scenario,
        "mode": mode,
        "seed": seed,
        "duration_s": duration_s,
        "w_sch": w_sch,
        "windows": int(rows),
        "missed": int(col("missed", bool).sum()),
        "tracks_lost": int(col("tracks_lost", np.int64).sum()),
        "assumption_broken": int(col("assumption_broken", bool).sum()),
        "violations": violations,
        "critical_share": float(w[crit].sum() / total_w) if total_w > 0 else 0.0,
        "critical_windows": int(crit.sum()),
        "methods": dict(sorted(methods.items())),
        "binding_critical": dict(sorted(binding_critical.items())),
        "min_msb_over_wsch": float(ratio.min()) if rows else math.nan,
        "min_speed_ratio": float(speed.min()) if rows else math.nan,
        "infeasible": int((~col("feasible", bool)).sum()),
        "max_response": float(kept.max()) if kept.size else math.nan,
        # lost tracks by cause (they sum to tracks_lost), searches charged, re-acquisitions
        "tracks_lost_by_cause": {c: _total(df, f"tracks_lost_{c}") for c in LOST_CAUSES},
        "searches": _total(df, "searches"),
        "reacquisitions": _total(df, "reacquisitions"),
        # the sensing: fixes made by a neighbour, the fixes' error from the truth, commands lost
        "confusions": _total(df, "confusions"),
        "radio_losses": _total(df, "radio_losses"),
        "localization_error_cm": fix_errors(df, n),
    }
    if extra:
        out.update(extra)
    return out
