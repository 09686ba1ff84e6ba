"""Response-time histograms per task with the analytic bounds drawn in, from any run.

Sources (each returns a `JobSource`: the job table, the bounds per task, a description):

- `from_simulation` — a task set and ``simulate`` options;
- `from_scenario_dir` — the ``jobs.csv`` (or ``jobs.parquet``) that ``rtsim scenario
  --out DIR`` writes (columns task, job, release, start, finish, response, deadline, missed);
  w is taken from ``summary.json``'s ``w_sch`` when present;
- `from_sweep_point` — point I of a ``simulate`` sweep directory, re-run from the sweep
  file recorded in its ``manifest.json`` (the same point seed, so the same run).

`write_histograms` writes, into one directory: ``histograms.png``, the run in one figure as
wide as a paper's page with a panel per task
([`rtsim.plots.histogram.response_histograms`][rtsim.plots.histogram.response_histograms],
300 dpi, integer count ticks), and ``histogram-<task>.png`` per task
(a task name with other characters than letters, digits, ``_ . -`` gets them as ``_`` and
a hash of its name: ``histogram-a_b-c14cddc0.png`` for ``a/b``)
([`rtsim.plots.histogram.response_histogram`][rtsim.plots.histogram.response_histogram] with
vertical lines for the exact WCRT,
the deadline and, for the window chain and tasks whose period follows w, w_sch),
``histogram.csv`` (task, bin, lo, hi, count), ``bounds.csv`` (task, line, value) and
``manifest.json``.

Bounds come from `rtsim.analysis.validation.task_bounds`: the suspension-oblivious
exact RTA at the window the run used (w_sch by default). For a dynamic window it is the
analysis at w_sch, labelled so.
"""

from __future__ import annotations

import json
import math
import os
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rtsim.analysis.validation import TaskBounds, task_bounds
from rtsim.config.scenario import parse_scenario
from rtsim.config.taskset import load_taskset, parse_taskset
from rtsim.errors import InputError
from rtsim.io.atomic import write_table
from rtsim.io.manifest import write_manifest
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate
from rtsim.sweep.grid import point_input, points
from rtsim.sweep.spec import parse_sweep

#: Resolution (dots per inch) of the PNG histograms.
DPI = 300  # rtsim.plots.style.DPI: print resolution

__all__ = [
    "JobSource",
    "from_simulation",
    "from_scenario_dir",
    "from_sweep_point",
    "histogram_table",
    "write_histograms",
    "HISTOGRAM_COLUMNS",
]

HISTOGRAM_COLUMNS: tuple[str, ...] = ("task", "bin", "lo", "hi", "count")
_JOB_COLS = ("task", "response")


@dataclass(frozen=True)
class JobSource:
    """Job records (at least ``task`` and ``response``), bounds per task, a description."""

    jobs: pd.DataFrame
    bounds: Mapping[str, TaskBounds]
    info: Mapping[str, Any] = field(default_factory=dict)


def from_simulation(ts: TaskSet, horizon: float, **simulate_kwargs: Any) -> JobSource:
    """Simulate ``ts`` (``rtsim.sim.simulate`` keyword options) with job records."""
    simulate_kwargs["record_jobs"] = True
    res = simulate(ts, horizon, **simulate_kwargs)
    assert res.jobs is not None  # (record_jobs)
    w = res.window["w"] if res.window and "w" in res.window else None
    info = {
        "source": "simulation",
        "horizon": horizon,
        "window": res.window,
        **{k: v for k, v in simulate_kwargs.items() if isinstance(v, str | int | float)},
    }
    return JobSource(
        res.jobs, task_bounds(ts, w) if ts.window is not None else task_bounds(ts), info
    )


def _read_json(path: Path) -> dict[str, Any]:
    try:
        data = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def _scenario_taskset(directory: Path, ts: TaskSet | None) -> TaskSet:
    if ts is not None:
        return ts

    inputs = _read_json(directory / "manifest.json").get("inputs", {})
    inputs = inputs if isinstance(inputs, dict) else {}
    text = inputs.get("scenario_text")
    if isinstance(text, str) and text:  # rtsim scenario's manifest: the scenario's task set
        import tomllib

        src = str(inputs.get("scenario_file") or directory / "manifest.json")
        return parse_scenario(tomllib.loads(text), src, Path(src).parent).load_taskset()
    data = inputs.get("taskset")
    if isinstance(data, dict) and ("tasks" in data or "window" in data):
        return parse_taskset(data, f"{directory / 'manifest.json'}: inputs.taskset")
    return load_taskset()


def _scenario_followers(directory: Path) -> int | None:
    path = directory / "windows.csv"
    if not path.exists():
        return None
    header = path.open("r", encoding="utf-8").readline()
    nums = {int(m.group(1)) for m in re.finditer(r"\bf(\d+)_x\b", header)}
    return max(nums) if nums else None


def from_scenario_dir(
    directory: str | os.PathLike[str],
    ts: TaskSet | None = None,
    *,
    n: int | None = None,
    r_H: float | None = None,
    w: float | None = None,
) -> JobSource:
    """The jobs of a scenario output directory; bounds from ``ts`` (default: the scenario's
    task set, from the scenario text in the directory's ``manifest.json``; else the packaged
    paper set) at n (default: the followers in ``windows.csv``), r_H and w (default:
    ``summary.json``'s w_sch, else w_sch)."""
    d = Path(directory)
    path = next((p for p in (d / "jobs.csv", d / "jobs.parquet") if p.exists()), None)
    if path is None:
        raise InputError(
            f"{d}: no jobs.csv or jobs.parquet (the job table of rtsim scenario --out DIR)"
        )
    try:
        if path.suffix == ".csv":
            jobs = pd.read_csv(path)
        else:
            with open(path, "rb") as fh:  # (pyarrow takes a path only as UTF-8)
                jobs = pd.read_parquet(fh)
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: cannot read the job table: {exc}") from None
    missing = [c for c in _JOB_COLS if c not in jobs.columns]
    if missing:
        raise InputError(f"{path}: missing column '{missing[0]}' (need task, response)")
    ts = _scenario_taskset(d, ts)
    changes: dict[str, Any] = {}
    n = n if n is not None else _scenario_followers(d)
    if n is not None:
        changes["n"] = int(n)
    if r_H is not None:
        changes["r_H"] = float(r_H)
    if changes and ts.window is not None:
        ts = ts.with_window(**changes)
    if w is None and ts.window is not None:
        v = _read_json(d / "summary.json").get("w_sch")
        w = float(v) if isinstance(v, int | float) and math.isfinite(v) else None
    bounds = task_bounds(ts, w) if ts.window is not None else task_bounds(ts)
    return JobSource(
        jobs, bounds, {"source": "scenario", "dir": str(d), "w": w, "n": changes.get("n")}
    )


def from_sweep_point(directory: str | os.PathLike[str], index: int) -> JobSource:
    """Point ``index`` of a ``simulate`` sweep in ``directory``, re-run with job records.

    The sweep file is rebuilt from ``manifest.json`` (its text and path); a base file that
    changed since (fingerprint mismatch) is refused.
    """
    import tomllib

    d = Path(directory)
    man = _read_json(d / "manifest.json")
    text, fp = man.get("sweep_text"), man.get("fingerprint")
    src = (man.get("inputs") or {}).get("sweep_file")
    if not isinstance(text, str) or not text or not isinstance(src, str):
        raise InputError(f"{d}: not a sweep directory (no manifest.json with the sweep file)")
    spec = parse_sweep(tomllib.loads(text), src, Path(src).resolve().parent, text)
    if fp is not None and spec.fingerprint() != fp:
        raise InputError(
            f"{d}: the sweep's base file changed since the sweep ran; "
            f"cannot re-run point {index} as it was"
        )
    if spec.kind != "simulate":
        raise InputError(f"{d}: histograms need a 'simulate' sweep, this one is '{spec.kind}'")
    pts = points(spec)
    if not 0 <= index < len(pts):
        raise InputError(f"{d}: --point {index} out of range (0..{len(pts) - 1})")
    pin = point_input(spec, pts[index])
    src_ = from_simulation(pin.taskset(), float(pin.options["horizon"]), **pin.simulate_options())
    return JobSource(
        src_.jobs,
        src_.bounds,
        {
            **src_.info,
            "source": "sweep",
            "dir": str(d),
            "point": index,
            "params": dict(pts[index].params),
        },
    )


def _edges(values: np.ndarray, bins: int, extra: Sequence[float] = ()) -> np.ndarray:
    """``bins`` equal bins from the least value to the largest value or bound line, so that
    the bars stay visible beside the bounds drawn in."""
    if values.size == 0:
        return np.array([0.0, 1.0])
    lo = float(values.min())
    hi = max([float(values.max()), *(float(x) for x in extra if math.isfinite(x) and x > lo)])
    if hi - lo < 1e-9 * max(1.0, abs(hi)):
        half = max(1e-3, 0.005 * abs(hi))
        return np.array([lo - half, hi + half])
    return np.histogram_bin_edges(values, bins=bins, range=(lo, hi))


def histogram_table(
    jobs: pd.DataFrame, bins: int = 50, bounds: Mapping[str, TaskBounds] | None = None
) -> pd.DataFrame:
    """Per-task histogram of the finite response times: task, bin, lo, hi, count.

    Bins span from the least response to the largest response or bound line of the task."""
    rows = []
    for task in pd.unique(jobs["task"].astype(str)):
        v = jobs.loc[jobs["task"].astype(str) == task, "response"].to_numpy(dtype=float)
        v = v[np.isfinite(v)]
        b = (bounds or {}).get(task)
        extra = [x for x in b.lines().values() if x is not None] if b is not None else []
        edges = _edges(v, bins, extra)
        counts, _ = np.histogram(v, bins=edges)
        rows += [
            (task, i, float(edges[i]), float(edges[i + 1]), int(c)) for i, c in enumerate(counts)
        ]
    return pd.DataFrame(rows, columns=list(HISTOGRAM_COLUMNS))


#: Longest task name used whole in a file name (a file name is at most 255 bytes, the
#: staging names beside it add about 30); longer names are cut to `_NAME_CUT`.
_NAME_WHOLE = 100
_NAME_CUT = 80


def _safe(name: str) -> str:
    """A file-name part for task ``name``: the name itself when it has only letters, digits,
    ``_``, ``.`` and ``-`` and at most 100 of them; else those kept (the first 80), the rest
    ``_``, and 8 hex digits of the name's sha256, so that ``a/b``, ``a:b`` and ``a_b`` get
    three files and a 250-character name a file name the file system takes."""
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name)
    if safe == name and len(name) <= _NAME_WHOLE:
        return name
    import hashlib

    digest = hashlib.sha256(name.encode("utf-8", "surrogatepass")).hexdigest()[:8]
    return f"{safe[:_NAME_CUT]}-{digest}"


def write_histograms(
    source: JobSource,
    out_dir: str | os.PathLike[str],
    *,
    bins: int = 50,
    suffix: str = "",
    title: str = "",
    argv: Sequence[str] | None = None,
    manifest: bool = True,
    fmt: str = "png",
    dpi: int = DPI,
) -> list[Path]:
    """Write the figures (``fmt``: png, svg or pdf; ``dpi`` for PNG), ``histogram<suffix>.csv``,
    ``bounds<suffix>.csv`` (and manifest.json) into ``out_dir``; return the paths written
    (module doc)."""
    from rtsim.plots.histogram import (  # lazy: only this needs matplotlib
        response_histogram,
    )
    from rtsim.plots.scenario import (  # lazy: only this needs matplotlib
        save_figure,
    )

    if bins < 1:
        raise InputError(f"--bins must be at least 1, got {bins}")
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    jobs = source.jobs
    table = histogram_table(jobs, bins, source.bounds)
    written: list[Path] = []
    brows = []
    panels: dict[str, tuple[np.ndarray, dict[str, float | None]]] = {}
    edges_of: dict[str, list[float]] = {}
    for task in pd.unique(table["task"]):
        sub = table[table["task"] == task]
        edges = np.append(sub["lo"].to_numpy(), sub["hi"].to_numpy()[-1])
        vals = jobs.loc[jobs["task"].astype(str) == task, "response"].to_numpy(dtype=float)
        b = source.bounds.get(task)
        lines = b.lines() if b is not None else {}
        for label, value in lines.items():
            brows.append((task, label, math.nan if value is None else float(value)))
        name = f"{title} — {task}" if title else task
        if b is not None and b.w is not None and b.per_window | b.is_window:
            name += f" (bounds at w = {b.w:.6g} ms)"
        fig = response_histogram(vals, lines=lines, bins=list(edges), title=name)
        written.append(
            save_figure(fig, out / f"histogram{suffix}-{_safe(task)}.{fmt}", dpi=dpi, fmt=fmt)
        )
        panels[str(task)], edges_of[str(task)] = (vals, dict(lines)), list(edges)
    if panels:  # the run in one figure, a panel per task
        from rtsim.plots.histogram import (  # lazy: only this needs matplotlib
            response_histograms,
        )

        fig = response_histograms(panels, bins=edges_of, title=title or None)
        written.insert(0, save_figure(fig, out / f"histograms{suffix}.{fmt}", dpi=dpi, fmt=fmt))
    csv = out / f"histogram{suffix}.csv"
    write_table(csv, table)
    bcsv = out / f"bounds{suffix}.csv"
    write_table(bcsv, pd.DataFrame(brows, columns=["task", "line", "value"]))
    written += [csv, bcsv]
    if manifest:
        write_manifest(
            out,
            command="histogram",
            seed=source.info.get("seed"),  # type: ignore[arg-type]
            inputs=dict(source.info),
            argv=None if argv is None else list(argv),
            extra={"outputs": [p.name for p in written]},
        )
    return written
