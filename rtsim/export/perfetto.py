"""A run's schedule in the Chrome Trace Event Format, for Perfetto (ui.perfetto.dev) and
chrome://tracing.

Built from the tables a run already has — the job records (:data:`rtsim.sim.records.
JOB_COLUMNS`), the execution-interval trace (:data:`~rtsim.sim.records.TRACE_COLUMNS`) and,
for a coupled run, ``windows.csv`` — never from the simulator's internals.

- Timestamps are µs of *simulated* time (``ts = ms × 1000``), in one process ("rtsim,
  simulated time").
- One track (a thread) per task, in priority order. Each job is a complete slice (``X``)
  from its first start to its finish, named ``<task> #<job>``; its trace intervals are slices
  nested in it, named by segment (``scan``, ``hough``, ``estimate[1]``, ``send[1]``,
  ``radio`` …). A preempted segment shows as several pieces with the gap between them;
  a suspension (the radio round trip) has category ``suspension``, compute ``compute``;
  the time a job waits for the holder of a shared resource (trace kind ``blocked``,
  docs/resources.md) is a slice ``blocked by <task> on <resource>`` of category ``blocked``.
- Jobs of one task that overlap in time (a backlog) go to further tracks of the task
  (``<task> (2)``, ``<task> (3)`` …), so every track nests strictly.
- Instant events (``i``) on the task's track: ``deadline miss`` at the job's deadline,
  ``aborted``, ``skipped release``; for a coupled run ``track lost`` at the window's release
  (``windows.tracks_lost`` > 0) on a "world" track.
- Counters (``C``) from ``windows.csv``: ``w`` and ``w_sch`` (ms), ``leader speed`` (cm/s),
  ``min MSB`` (ms, when finite), at each window's release.

Open the file in Perfetto with "Open trace file", or in chrome://tracing with "Load".
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import pandas as pd

__all__ = ["trace_events", "write_perfetto", "PID"]

#: The one process id of every event.
PID = 1
_US = 1000.0  # µs per ms


def _us(ms: float) -> float:
    return float(ms) * _US


def _ms(v: Any) -> float | None:
    return None if pd.isna(v) else float(v)


def _with_unfinished(jobs: pd.DataFrame, trace: pd.DataFrame) -> pd.DataFrame:
    """``jobs`` plus a row for each job that ran but had not finished when the run ended
    (it has trace intervals but no record): first start to last interval end, no release."""
    have = set(zip(jobs["task"].astype(str), jobs["job"].astype(int), strict=True))
    if not len(trace):
        return jobs
    span = trace.groupby([trace["task"].astype(str), trace["job"].astype(int)], sort=False).agg(
        start=("start", "min"), finish=("end", "max")
    )
    extra = [
        {
            "task": t,
            "job": j,
            "release": math.nan,
            "start": s,
            "finish": f,
            "response": math.nan,
            "deadline": math.nan,
            "preemptions": 0,
            "missed": False,
            "aborted": False,
            "skipped": False,
        }
        for (t, j), s, f in zip(span.index, span["start"], span["finish"], strict=True)
        if (t, j) not in have
    ]
    if not extra:
        return jobs
    return pd.concat([jobs, pd.DataFrame(extra)], ignore_index=True)


def _lanes(jobs: pd.DataFrame) -> dict[tuple[str, int], int]:
    """Lane (0, 1, …) of each (task, job): the first lane whose last job finished by its start."""
    out: dict[tuple[str, int], int] = {}
    ran = jobs[jobs["start"].notna()].sort_values(["start", "job"], kind="stable")
    ends: dict[str, list[float]] = {}
    for task, job, start, finish in zip(
        ran["task"], ran["job"], ran["start"], ran["finish"], strict=True
    ):
        lanes = ends.setdefault(str(task), [])
        fin = float(finish) if pd.notna(finish) else math.inf
        for i, end in enumerate(lanes):
            if end <= float(start):
                lanes[i] = fin
                out[(str(task), int(job))] = i
                break
        else:
            lanes.append(fin)
            out[(str(task), int(job))] = len(lanes) - 1
    return out


def trace_events(
    jobs: pd.DataFrame,
    trace: pd.DataFrame,
    *,
    tasks: Sequence[str] | None = None,
    windows: pd.DataFrame | None = None,
    title: str = "rtsim, simulated time",
) -> list[dict[str, Any]]:
    """The Trace Event list (module docstring) of one run.

    ``tasks``: track order (default: order of first appearance in ``jobs``); ``windows``:
    a coupled run's ``windows.csv`` table for the counters and lost tracks.
    """
    jobs = _with_unfinished(jobs, trace)
    names = list(tasks) if tasks is not None else list(dict.fromkeys(jobs["task"].astype(str)))
    names += [t for t in dict.fromkeys(jobs["task"].astype(str)) if t not in names]
    lanes = _lanes(jobs)
    nlanes = {t: 1 + max([v for (tt, _), v in lanes.items() if tt == t], default=0) for t in names}
    tid: dict[tuple[str, int], int] = {}
    events: list[dict[str, Any]] = [
        {"ph": "M", "pid": PID, "tid": 0, "name": "process_name", "args": {"name": title}},
    ]
    nxt = 1
    for order, t in enumerate(names):
        for lane in range(nlanes[t]):
            tid[(t, lane)] = nxt
            label = t if lane == 0 else f"{t} ({lane + 1})"
            events.append(
                {"ph": "M", "pid": PID, "tid": nxt, "name": "thread_name", "args": {"name": label}}
            )
            events.append(
                {
                    "ph": "M",
                    "pid": PID,
                    "tid": nxt,
                    "name": "thread_sort_index",
                    "args": {"sort_index": order * 100 + lane},
                }
            )
            nxt += 1

    def job_tid(task: str, job: int) -> int:
        return tid[(task, lanes.get((task, job), 0))]

    r: Any  # a row (its fields typed by the columns, not by pandas)
    for r in jobs.itertuples(index=False):
        task, job = str(r.task), int(r.job)
        thread = job_tid(task, job)
        args = {
            "job": job,
            "release_ms": _ms(r.release),
            "deadline_ms": _ms(r.deadline),
            "response_ms": None if pd.isna(r.response) else float(r.response),
            "preemptions": int(r.preemptions),
            "missed": bool(r.missed),
        }
        if pd.notna(r.start) and pd.notna(r.finish):
            unfinished = " (unfinished)" if pd.isna(r.release) else ""
            events.append(
                {
                    "ph": "X",
                    "pid": PID,
                    "tid": thread,
                    "cat": "job",
                    "name": f"{task} #{job}{unfinished}",
                    "ts": _us(r.start),
                    "dur": _us(r.finish) - _us(r.start),
                    "args": args,
                }
            )
        if bool(r.skipped):
            events.append(
                {
                    "ph": "i",
                    "s": "t",
                    "pid": PID,
                    "tid": thread,
                    "cat": "skip",
                    "name": "skipped release",
                    "ts": _us(r.release),
                    "args": args,
                }
            )
        elif bool(r.aborted):
            events.append(
                {
                    "ph": "i",
                    "s": "t",
                    "pid": PID,
                    "tid": thread,
                    "cat": "abort",
                    "name": "aborted",
                    "ts": _us(r.deadline),
                    "args": args,
                }
            )
        if bool(r.missed) and not bool(r.skipped):
            events.append(
                {
                    "ph": "i",
                    "s": "t",
                    "pid": PID,
                    "tid": thread,
                    "cat": "miss",
                    "name": "deadline miss",
                    "ts": _us(r.deadline),
                    "args": args,
                }
            )
    for r in trace.itertuples(index=False):
        task, job = str(r.task), int(r.job)
        events.append(
            {
                "ph": "X",
                "pid": PID,
                "tid": job_tid(task, job),
                "cat": "compute"
                if bool(r.on_cpu)
                else ("blocked" if str(r.kind) == "blocked" else "suspension"),
                "name": str(r.segment),
                "ts": _us(r.start),
                "dur": _us(r.end) - _us(r.start),
                "args": {"job": job, "kind": str(r.kind), "on_cpu": bool(r.on_cpu)},
            }
        )
    if windows is not None and len(windows):
        world = nxt
        events.append(
            {"ph": "M", "pid": PID, "tid": world, "name": "thread_name", "args": {"name": "world"}}
        )
        events.append(
            {
                "ph": "M",
                "pid": PID,
                "tid": world,
                "name": "thread_sort_index",
                "args": {"sort_index": -1},
            }
        )
        for r in windows.itertuples(index=False):
            ts = _us(r.t)
            events.append(
                {
                    "ph": "C",
                    "pid": PID,
                    "tid": 0,
                    "name": "window (ms)",
                    "ts": ts,
                    "args": {"w": float(r.w), "w_sch": float(r.w_sch)},
                }
            )
            events.append(
                {
                    "ph": "C",
                    "pid": PID,
                    "tid": 0,
                    "name": "leader speed (cm/s)",
                    "ts": ts,
                    "args": {"v_leader": float(r.v_leader)},
                }
            )
            if math.isfinite(float(r.msb_min)):
                events.append(
                    {
                        "ph": "C",
                        "pid": PID,
                        "tid": 0,
                        "name": "min MSB (ms)",
                        "ts": ts,
                        "args": {"msb_min": float(r.msb_min)},
                    }
                )
            if int(r.tracks_lost) > 0:
                events.append(
                    {
                        "ph": "i",
                        "s": "t",
                        "pid": PID,
                        "tid": world,
                        "cat": "world",
                        "name": "track lost",
                        "ts": ts,
                        "args": {"window": int(r.window), "lost": int(r.tracks_lost)},
                    }
                )
    return events


def write_perfetto(
    path: str | os.PathLike[str],
    jobs: pd.DataFrame,
    trace: pd.DataFrame,
    *,
    tasks: Sequence[str] | None = None,
    windows: pd.DataFrame | None = None,
    metadata: dict[str, Any] | None = None,
) -> Path:
    """Write ``{"traceEvents": [...], "displayTimeUnit": "ms", "otherData": metadata}``
    atomically to ``path`` (JSON) and return it."""
    from rtsim.io.atomic import atomic_path

    doc = {
        "traceEvents": trace_events(jobs, trace, tasks=tasks, windows=windows),
        "displayTimeUnit": "ms",
        "otherData": {"time_unit": "µs of simulated time", **(metadata or {})},
    }
    p = Path(path)
    with atomic_path(p) as tmp:
        Path(tmp).write_text(json.dumps(doc, separators=(",", ":"), allow_nan=False), "utf-8")
    return p
