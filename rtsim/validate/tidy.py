"""The validation table: the sweeps' per-point rows turned into one row per
(configuration, mode, task).

Columns (ms unless noted; NaN where not applicable):

- ``source`` (``paper`` | ``random``), ``config`` (``n=2,r_H=30`` | ``random-7``), ``n``,
  ``r_H`` (cm), ``set``, ``seed``, ``mode``, ``task``;
- analysis: ``w_eq7``, ``w_eq11``, ``w_sch``, ``w_rta``, ``g``, ``wcrt`` (exact RTA at w_sch,
  suspension-oblivious WCET), ``deadline`` (relative, at w_sch);
- simulation at w_sch (paper) or over the hyperperiod(s) (random): ``sim_max``, ``p50``,
  ``p99``, ``p999``, ``jobs``, ``misses``;
- search (paper): ``w_sim``, ``evaluations``, ``nonmonotone``;
- ratios: ``w_sch_over_w_sim``, ``w_rta_over_w_sim``, ``wcrt_over_sim_max``;
- beams (paper): ``points_min``, ``points_max``, ``points_mean``, ``points_wcet``,
  ``tracks_lost``, ``tracks_lost_sensor`` (those whose follower returned fewer than
  ``min_points`` beams: the sensor's limit), ``beyond_wcet``; ``assumption_ok`` (false
  when counted beams exceeded Eq 1's k·n in some window of a ``counted-idle`` run);
- suspension-aware (paper): ``w_susp`` (Δt with the CPU idle), ``w_susp_over_w_sim`` and
  ``w_geo_over_w_sim`` (``counted-idle`` rows only: the model they assume);
  ``w_susp_geo`` (w_susp with the geometric ``k_geo`` for followers at ≥ ``rho_min`` cm),
  ``beyond_geo`` (windows whose scan counted more than min(361, k_geo·n)),
  ``geo_assumption_ok`` (false when beyond_geo > 0 in a ``counted-idle`` run);
  ``wcrt_susp`` (the suspension-aware WCRT at w_sch) and ``wcrt_susp_over_sim_max``
  (``counted-idle`` rows);
- EDF (paper): ``w_edf`` (the EDF demand criterion, Δt as CPU time) and
  ``w_edf_over_w_sim`` (``edf-cpu`` rows, whose ``wcrt`` is Spuri's bound at w_sch).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import pandas as pd

from rtsim.validate.points import PAPER_MODES, RANDOM_MODES

__all__ = ["COLUMNS", "tidy_paper", "tidy_random"]

COLUMNS: tuple[str, ...] = (
    "source",
    "config",
    "n",
    "r_H",
    "set",
    "seed",
    "mode",
    "task",
    "w_eq7",
    "w_eq11",
    "w_sch",
    "w_rta",
    "g",
    "wcrt",
    "deadline",
    "sim_max",
    "p50",
    "p99",
    "p999",
    "jobs",
    "misses",
    "w_sim",
    "evaluations",
    "nonmonotone",
    "w_sch_over_w_sim",
    "w_rta_over_w_sim",
    "wcrt_over_sim_max",
    "points_min",
    "points_max",
    "points_mean",
    "points_wcet",
    "tracks_lost",
    "tracks_lost_sensor",
    "beyond_wcet",
    "assumption_ok",
    "w_susp",
    "w_susp_over_w_sim",
    "rho_min",
    "k_geo",
    "w_susp_geo",
    "w_geo_over_w_sim",
    "beyond_geo",
    "geo_assumption_ok",
    "wcrt_susp",
    "wcrt_susp_over_sim_max",
    "w_edf",
    "w_edf_over_w_sim",
)
_PER_TASK = ("sim_max", "p50", "p99", "p999", "jobs", "misses")


def _tasks(row: Mapping[Any, Any]) -> list[str]:
    return [k.split(".", 1)[1] for k in row if k.startswith("wcrt.")]


def _div(a: Any, b: Any) -> float:
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return math.nan
    return a / b if math.isfinite(a) and math.isfinite(b) and b > 0 else math.nan


def _rows(row: Mapping[Any, Any], modes: tuple[str, ...], base: dict[str, Any]) -> list[dict]:
    out = []
    for mode in modes:
        for task in _tasks(row):
            r = dict(base)
            wcrt_key = f"wcrt_edf.{task}" if mode == "edf-cpu" else f"wcrt.{task}"
            r.update(
                mode=mode,
                task=task,
                wcrt=row.get(wcrt_key, math.nan),
                deadline=row.get(f"deadline.{task}", math.nan),
            )
            for m in _PER_TASK:
                r[m] = row.get(f"{m}.{mode}.{task}", math.nan)
            for m in ("w_sim", "evaluations", "nonmonotone"):
                r[m] = row.get(f"{m}.{mode}", math.nan)
            r["w_sch_over_w_sim"] = _div(r.get("w_sch"), r["w_sim"])
            r["w_rta_over_w_sim"] = _div(r.get("w_rta"), r["w_sim"])
            r["wcrt_over_sim_max"] = _div(r["wcrt"], r["sim_max"])
            if mode == "edf-cpu":
                r["w_edf_over_w_sim"] = _div(r.get("w_edf"), r["w_sim"])
            if mode == "counted-idle":  # the model of w_susp: Δt with the CPU idle
                r["w_susp_over_w_sim"] = _div(r.get("w_susp"), r["w_sim"])
                r["w_geo_over_w_sim"] = _div(r.get("w_susp_geo"), r["w_sim"])
                r["wcrt_susp"] = row.get(f"wcrt_susp.{task}", math.nan)
                r["wcrt_susp_over_sim_max"] = _div(r["wcrt_susp"], r["sim_max"])
                r["assumption_ok"] = int(row.get("beyond_wcet", 0) or 0) == 0
                r["geo_assumption_ok"] = int(row.get("beyond_geo", 0) or 0) == 0
            out.append(r)
    return out


def _frame(rows: list[dict[str, Any]]) -> pd.DataFrame:
    df = pd.DataFrame.from_records(rows, columns=list(COLUMNS))
    df["assumption_ok"] = df["assumption_ok"].fillna(True).astype(bool)
    df["geo_assumption_ok"] = df["geo_assumption_ok"].fillna(True).astype(bool)
    return df


def tidy_paper(results: pd.DataFrame) -> pd.DataFrame:
    """Validation rows of the paper sweep (its ``ok`` points; ``results.parquet`` rows)."""
    rows: list[dict[str, Any]] = []
    for row in results[results["status"] == "ok"].to_dict("records"):
        base = {
            k: row.get(k, math.nan)
            for k in (
                "w_eq7",
                "w_eq11",
                "w_sch",
                "w_rta",
                "g",
                "points_min",
                "points_max",
                "points_mean",
                "points_wcet",
                "tracks_lost",
                "tracks_lost_sensor",
                "beyond_wcet",
                "w_susp",
                "rho_min",
                "k_geo",
                "w_susp_geo",
                "beyond_geo",
                "w_edf",
            )
        }
        base.update(
            source="paper",
            config=f"n={int(row['n'])},r_H={float(row['r_H']):g}",
            n=int(row["n"]),
            r_H=float(row["r_H"]),
            set=math.nan,
            seed=row["point_seed"],  # the seed the point ran with
            assumption_ok=True,
            geo_assumption_ok=True,
        )
        rows += _rows(row, PAPER_MODES, base)
    return _frame(rows)


def tidy_random(results: pd.DataFrame) -> pd.DataFrame:
    """Validation rows of the random-set sweep (its ``ok`` points)."""
    rows: list[dict[str, Any]] = []
    for row in results[results["status"] == "ok"].to_dict("records"):
        base = {
            "source": "random",
            "config": f"random-{int(row['set'])}",
            "n": math.nan,
            "r_H": math.nan,
            "set": int(row["set"]),
            "seed": row["point_seed"],  # the seed the point ran with
            "assumption_ok": True,
            "geo_assumption_ok": True,
        }
        rows += _rows(row, RANDOM_MODES, base)
    return _frame(rows)
