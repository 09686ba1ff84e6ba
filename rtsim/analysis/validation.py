"""Analytic-versus-simulated validation, the pure parts: bounds per task, the w_sim search,
percentiles, the failure checker and the summary numbers (docs/model/lower-bound.md).

No simulator here: the search takes the simulation as a predicate ``passes(w) -> bool``
("no deadline miss at window w"), and the checker reads a results table.

**w_sim search**: `rtsim.analysis.search.smallest_passing` (re-exported here).

**Checks** (`check_results`), on the tidy table of `rtsim.validate` (one row per
configuration, task and mode): a simulated maximum response above the exact WCRT (the
suspension-oblivious WCET analysis, which also bounds idle suspensions and execution times
at or below WCET); a w_sim above w_rta + tol; w_sch below w_rta. Rows whose execution times
broke the WCET assumption (``assumption_ok`` false: more beams counted than Eq 1's k·n) are
not checked against the WCRT but reported as warnings.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from rtsim.analysis.bounds import w_sch_of
from rtsim.analysis.rta import analyze
from rtsim.analysis.search import SEARCH_TOL, SearchResult, smallest_passing

if TYPE_CHECKING:
    import pandas as pd

    from rtsim.model.taskset import TaskSet

__all__ = [
    "BOUND_TOL",
    "SEARCH_TOL",
    "PERCENTILES",
    "TaskBounds",
    "task_bounds",
    "SearchResult",
    "smallest_passing",
    "percentiles",
    "Failure",
    "check_results",
    "summarize",
]

#: A simulated response up to BOUND_TOL ms above its analytic bound is not a failure.
BOUND_TOL = 1e-6
#: Percentiles reported for each task's response times.
PERCENTILES: tuple[float, ...] = (50.0, 99.0, 99.9)


@dataclass(frozen=True)
class TaskBounds:
    """One task's analytic lines (ms): exact WCRT at ``w`` (None: above the deadline), its
    relative deadline at ``w``, and w_sch (None for a set without a window)."""

    name: str
    wcrt: float | None
    deadline: float
    w: float | None
    w_sch: float | None
    per_window: bool
    is_window: bool

    def lines(self) -> dict[str, float | None]:
        """The vertical lines of a histogram: WCRT, deadline, and w_sch for w-related tasks."""
        out: dict[str, float | None] = {"WCRT (exact RTA)": self.wcrt, "deadline": self.deadline}
        if self.w_sch is not None and (self.is_window or self.per_window):
            out["w_sch"] = self.w_sch
        return out


def task_bounds(ts: TaskSet, w: float | None = None) -> dict[str, TaskBounds]:
    """Exact WCRT and deadline of every task of ``ts`` at window ``w`` (default w_sch).

    For a set with a ``[window]`` the chain is one task of cost g (suspension-oblivious,
    [`rtsim.analysis.rta.analyze`][rtsim.analysis.rta.analyze]); w_sch is Eq 7/11.
    """
    w_sch: float | None = None
    per_window: set[str] = set()
    win_name: str | None = None
    if ts.window is not None:
        w_sch = w_sch_of(ts)
        w = w_sch if w is None else w  # (w_sch itself is needed too: not window_or_w_sch)
        per_window = {t.name for t in ts.tasks if t.per_window}
        win_name = ts.window.name
    a = analyze(ts, w) if ts.window is not None else analyze(ts)
    return {
        t.name: TaskBounds(
            t.name, t.wcrt, t.deadline, w, w_sch, t.name in per_window, t.name == win_name
        )
        for t in a.tasks
    }


def percentiles(values: Iterable[float], qs: Sequence[float] = PERCENTILES) -> dict[float, float]:
    """Percentiles of the finite ``values`` (numpy's linear interpolation); NaN if none."""
    arr = np.asarray(list(values) if not isinstance(values, np.ndarray) else values, dtype=float)
    arr = arr[np.isfinite(arr)]
    if arr.size == 0:
        return {q: math.nan for q in qs}
    vals = np.percentile(arr, list(qs))
    return {q: float(v) for q, v in zip(qs, vals, strict=True)}


@dataclass(frozen=True)
class Failure:
    """One flagged result: where (config, task, mode), which check, the value and the bound."""

    config: str
    task: str
    mode: str
    check: str
    value: float
    bound: float
    severity: str = "failure"  # or "warning" (assumption broken, not checked)

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _f(x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        return math.nan
    return v


def _held(flag: Any) -> bool:
    """An assumption flag of the table: held unless it is false (missing or NaN: held)."""
    return True if flag is None or (isinstance(flag, float) and math.isnan(flag)) else bool(flag)


def _above(
    where: tuple[str, str, str],
    what: str,
    value: float,
    bound: float,
    tol: float,
    held: bool = True,
) -> list[Failure]:
    """[the failure ``what`` at ``where`` (config, task, mode)] when ``value`` > ``bound`` +
    ``tol``, both finite (a warning where the bound's assumption did not hold); else []."""
    if math.isfinite(value) and math.isfinite(bound) and value > bound + tol:
        return [Failure(*where, what, value, bound, "failure" if held else "warning")]
    return []


def check_results(
    rows: pd.DataFrame | Iterable[Mapping[str, Any]],
    *,
    bound_tol: float = BOUND_TOL,
    search_tol: float = SEARCH_TOL,
) -> list[Failure]:
    """Every failure (and warning) in a validation table (columns: module doc of
    `rtsim.validate.tidy`; missing columns are skipped).

    Checks per row: ``sim_max > wcrt + bound_tol`` (finite WCRT; a warning instead when
    ``assumption_ok`` is false); a task with no finite WCRT is not checked. Per paper
    configuration and mode: ``w_sim > w_rta + search_tol``, ``w_sch < w_rta − bound_tol``
    and ``w_susp > w_rta + bound_tol``; in ``counted-idle`` (w_susp's model, Δt idle) also
    ``w_sim > w_susp + search_tol`` and ``w_sim > w_susp_geo + search_tol`` (warnings where
    the beams broke that bound's k: ``assumption_ok`` / ``geo_assumption_ok`` false). So
    w_sim ≤ w_susp ≤ w_rta ≤ w_sch is checked under the matching model. In ``edf-cpu`` (the
    CPU under EDF, Δt as CPU time): ``w_sim > w_edf + search_tol`` and
    ``w_edf > w_rta + bound_tol`` (EDF is optimal there), so w_sim ≤ w_edf ≤ w_rta.
    """
    records = rows.to_dict("records") if hasattr(rows, "to_dict") else list(rows)
    out: list[Failure] = []
    seen: set[tuple[str, str]] = set()
    for r in records:
        config, task, mode = (str(r.get(k, "")) for k in ("config", "task", "mode"))
        sim, wcrt = _f(r.get("sim_max")), _f(r.get("wcrt"))
        ok = _held(r.get("assumption_ok"))
        out += _above((config, task, mode), "response above WCRT", sim, wcrt, bound_tol, ok)
        if mode == "counted-idle":
            what = "response above the suspension-aware WCRT"
            out += _above((config, task, mode), what, sim, _f(r.get("wcrt_susp")), bound_tol, ok)
        w_sim, w_rta, w_sch = _f(r.get("w_sim")), _f(r.get("w_rta")), _f(r.get("w_sch"))
        key = (config, mode)
        if key in seen:
            continue
        seen.add(key)
        where = (config, "*", mode)
        out += _above(where, "w_sim above w_rta", w_sim, w_rta, search_tol, ok)
        if math.isfinite(w_sch) and math.isfinite(w_rta) and w_sch < w_rta - bound_tol:
            out.append(Failure(config, "*", mode, "w_sch below w_rta", w_sch, w_rta))
        w_susp = _f(r.get("w_susp"))
        out += _above(where, "w_susp above w_rta", w_susp, w_rta, bound_tol)
        if mode == "edf-cpu":  # w_edf's model: the CPU under EDF, Δt as CPU time
            w_edf = _f(r.get("w_edf"))
            out += _above(where, "w_sim above w_edf", w_sim, w_edf, search_tol)
            out += _above(where, "w_edf above w_rta", w_edf, w_rta, bound_tol)
        if mode == "counted-idle":  # w_susp's model: Δt with the CPU idle
            out += _above(where, "w_sim above w_susp", w_sim, w_susp, search_tol, ok)
            geo, geo_ok = _f(r.get("w_susp_geo")), _held(r.get("geo_assumption_ok"))
            out += _above(where, "w_sim above w_susp_geo", w_sim, geo, search_tol, geo_ok)
    return out


def _range(s: pd.Series) -> dict[str, float | None]:
    v = s.astype(float)
    v = v[np.isfinite(v)]
    if v.empty:
        return {"min": None, "median": None, "max": None}
    return {"min": float(v.min()), "median": float(v.median()), "max": float(v.max())}


def summarize(df: pd.DataFrame) -> dict[str, Any]:
    """Headline numbers of a validation table: ranges (min, median, max) of the pessimism
    ratios per source and mode, and the number of rows, configurations and failures."""
    out: dict[str, Any] = {"rows": int(len(df))}
    for (source, mode), g in df.groupby(["source", "mode"], sort=False):
        key = f"{source}/{mode}"
        per_cfg = g.drop_duplicates("config")
        entry: dict[str, Any] = {"configs": int(per_cfg.shape[0])}
        for col in (
            "w_sch_over_w_sim",
            "w_rta_over_w_sim",
            "w_susp_over_w_sim",
            "w_geo_over_w_sim",
            "w_edf_over_w_sim",
        ):
            if col in g:
                entry[col] = _range(per_cfg[col])
        if "wcrt_over_sim_max" in g:
            entry["wcrt_over_sim_max"] = _range(g["wcrt_over_sim_max"])
        if "wcrt_susp_over_sim_max" in g:
            entry["wcrt_susp_over_sim_max"] = _range(g["wcrt_susp_over_sim_max"])
        out[key] = entry
    fails = check_results(df)
    out["failures"] = sum(1 for f in fails if f.severity == "failure")
    out["warnings"] = sum(1 for f in fails if f.severity == "warning")
    return out
