"""A run's schedule in the Chrome Trace Event Format, for Perfetto and chrome://tracing, built
from the tables a run already has (job records, the execution trace and, for a coupled run,
``windows.csv``): [`write_perfetto`][rtsim.export.perfetto.write_perfetto] from tables in
memory, `stream_perfetto` the same bytes from records on disk. The tracks, slices, events and
counters: docs/getting-started/perfetto.md.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import pandas as pd

from rtsim.io.atomic import atomic_path
from rtsim.io.columns import iter_columns, read_columns
from rtsim.sim.records import JOB_COLUMNS, TRACE_COLUMNS, jobs_frame, trace_frame

__all__ = ["trace_events", "write_perfetto", "stream_perfetto", "PID"]

#: The one process id of every event.
PID = 1
_US = 1000.0  # µs per ms


def _us(ms: float) -> float:
    return float(ms) * _US


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
    events, tid = _tracks(title, names, nlanes)

    def job_tid(task: str, job: int) -> int:
        return tid[(task, lanes.get((task, job), 0))]

    for row in jobs.reindex(columns=JOB_COLUMNS[:12]).itertuples(index=False, name=None):
        _job_event(row, job_tid(str(row[0]), int(row[1])), bool(pd.isna(row[2])), events)
    for row in trace[list(TRACE_COLUMNS)].itertuples(index=False, name=None):
        events.append(_slice(row, job_tid(str(row[0]), int(row[1]))))
    if windows is not None and len(windows):
        world = len(tid) + 1
        events.extend(_thread_meta(world, "world", -1))
        for r in windows.itertuples(index=False):
            events.extend(_window_events(r, world))
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
    doc = {
        "traceEvents": trace_events(jobs, trace, tasks=tasks, windows=windows),
        "displayTimeUnit": "ms",
        "otherData": {"time_unit": "µs of simulated time", **(metadata or {})},
    }
    p = Path(path)
    with atomic_path(p) as tmp:
        Path(tmp).write_text(json.dumps(doc, separators=(",", ":"), allow_nan=False), "utf-8")
    return p


# -- streaming ---------------------------------------------------------------------------------
#: Events per ``json.dumps`` call of `stream_perfetto` (a list's items joined by ",").
BATCH = 4096
_WINDOW_COLUMNS = ["t", "w", "w_sch", "v_leader", "msb_min", "tracks_lost", "window"]


def _nan(v: Any) -> bool:
    return v is None or v != v


class _IntSet:
    """A set of non-negative integers as sorted disjoint ranges (job indices of one task,
    nearly contiguous): memory grows with the gaps, not the members."""

    def __init__(self) -> None:
        self.lo: list[int] = []
        self.hi: list[int] = []

    def add(self, i: int) -> None:
        lo, hi = self.lo, self.hi
        if hi and hi[-1] + 1 == i:  # the common case: the next index
            hi[-1] = i
            return
        if not hi or hi[-1] + 1 < i:
            lo.append(i)
            hi.append(i)
            return
        import bisect

        k = bisect.bisect_right(lo, i) - 1  # the range starting at or before i
        if k >= 0 and i <= hi[k]:
            return
        if k >= 0 and hi[k] + 1 == i:
            hi[k] = i
        elif k + 1 < len(lo) and lo[k + 1] == i + 1:
            lo[k + 1] = i
            return
        else:
            lo.insert(k + 1, i)
            hi.insert(k + 1, i)
            return
        if k + 1 < len(lo) and lo[k + 1] == hi[k] + 1:  # merge with the next range
            hi[k] = hi[k + 1]
            del lo[k + 1], hi[k + 1]

    def __contains__(self, i: int) -> bool:
        import bisect

        k = bisect.bisect_right(self.lo, i) - 1
        return k >= 0 and i <= self.hi[k]


class _Lanes:
    """`_lanes` of one task, fed its started jobs in (start, job) order."""

    def __init__(self) -> None:
        self.ends: list[float] = []
        self.dead = 0  # lanes [0, dead) end at infinity (an aborted job's): never free again
        self.last: tuple[float, int] | None = None
        # the jobs on a lane other than 0, as runs of consecutive indices: first, last, lane
        self.first: list[int] = []
        self.final: list[int] = []
        self.lane: list[int] = []

    def add(self, job: int, start: float, finish: float) -> bool:
        """Place one job; False when it does not come after the last one placed."""
        key = (start, job)
        if self.last is not None and (key <= self.last or job <= self.last[1]):
            return False
        self.last = key
        ends = self.ends
        fin = math.inf if _nan(finish) else finish
        while self.dead < len(ends) and ends[self.dead] == math.inf:
            self.dead += 1
        for i in range(self.dead, len(ends)):
            if ends[i] <= start:
                ends[i] = fin
                break
        else:
            ends.append(fin)
            i = len(ends) - 1
        if i:
            if self.lane and self.lane[-1] == i and self.final[-1] + 1 == job:
                self.final[-1] = job
            else:
                self.first.append(job)
                self.final.append(job)
                self.lane.append(i)
        return True

    def of(self, job: int) -> int:
        import bisect

        k = bisect.bisect_right(self.first, job) - 1
        return self.lane[k] if k >= 0 and job <= self.final[k] else 0


class _Unordered(Exception):
    """Records not in start order: the streaming writer falls back to whole tables."""


def _job_event(row: tuple[Any, ...], t: int, unfinished: bool, out: list[dict[str, Any]]) -> None:
    """The events of one job record (as [`trace_events`][rtsim.export.perfetto.trace_events] makes
    them)."""
    task, job = str(row[0]), int(row[1])
    release, start, finish = row[2], row[3], row[4]
    response, deadline = row[5], row[6]
    args = {
        "job": job,
        "release_ms": None if _nan(release) else float(release),
        "deadline_ms": None if _nan(deadline) else float(deadline),
        "response_ms": None if _nan(response) else float(response),
        "preemptions": int(row[9]),
        "missed": bool(row[8]),
    }
    if not _nan(start) and not _nan(finish):
        suffix = " (unfinished)" if unfinished else ""
        out.append(
            {
                "ph": "X",
                "pid": PID,
                "tid": t,
                "cat": "job",
                "name": f"{task} #{job}{suffix}",
                "ts": _us(start),
                "dur": _us(finish) - _us(start),
                "args": args,
            }
        )
    if bool(row[11]):
        out.append(_instant(t, "skip", "skipped release", release, args))
    elif bool(row[10]):
        out.append(_instant(t, "abort", "aborted", deadline, args))
    if bool(row[8]) and not bool(row[11]):
        out.append(_instant(t, "miss", "deadline miss", deadline, args))


def _instant(t: int, cat: str, name: str, ms: float, args: dict[str, Any]) -> dict[str, Any]:
    """An instant event on the track ``t`` at ``ms``."""
    return {
        "ph": "i",
        "s": "t",
        "pid": PID,
        "tid": t,
        "cat": cat,
        "name": name,
        "ts": _us(ms),
        "args": args,
    }


def _slice(row: Sequence[Any], t: int) -> dict[str, Any]:
    """The slice of one execution-trace row (`TRACE_COLUMNS` order) on the track ``t``: its
    category ``compute``, ``blocked`` (waiting for a resource) or ``suspension``."""
    job, kind, on_cpu = int(row[1]), str(row[3]), bool(row[4])
    return {
        "ph": "X",
        "pid": PID,
        "tid": t,
        "cat": "compute" if on_cpu else ("blocked" if kind == "blocked" else "suspension"),
        "name": str(row[2]),
        "ts": _us(row[5]),
        "dur": _us(row[6]) - _us(row[5]),
        "args": {"job": job, "kind": kind, "on_cpu": on_cpu},
    }


class _Writer:
    """Events written as the items of one JSON array, `BATCH` at a time."""

    def __init__(self, fh: Any) -> None:
        self.fh = fh
        self.batch: list[dict[str, Any]] = []
        self.any = False

    def flush(self) -> None:
        if not self.batch:
            return
        text = json.dumps(self.batch, separators=(",", ":"), allow_nan=False)[1:-1]
        self.fh.write(("," if self.any else "") + text)
        self.any = True
        self.batch.clear()

    def maybe_flush(self) -> None:
        if len(self.batch) >= BATCH:
            self.flush()


def _window_chunks(windows: str | os.PathLike[str] | None) -> Any:
    if windows is None:
        return
    yield from iter_columns(windows, _WINDOW_COLUMNS)


def stream_perfetto(
    path: str | os.PathLike[str],
    jobs: Any,
    trace: Any,
    *,
    tasks: Sequence[str] | None = None,
    windows: str | os.PathLike[str] | None = None,
    metadata: dict[str, Any] | None = None,
    title: str = "rtsim, simulated time",
) -> Path:
    """Write the file of [`write_perfetto`][rtsim.export.perfetto.write_perfetto] (the same bytes)
    atomically to ``path``,
    from records on disk: ``jobs`` and ``trace`` iterate (again at each pass) chunks of row
    tuples in `JOB_COLUMNS` / `TRACE_COLUMNS` order (a `rtsim.io.spool.Spool`); ``windows`` is the
    path of a
    coupled run's ``windows.csv`` (read in chunks)."""
    p = Path(path)
    try:
        plan = _plan(jobs, trace, tasks)
    except _Unordered:
        jt = jobs_frame([r for chunk in jobs for r in chunk])
        tt = trace_frame([r for chunk in trace for r in chunk])
        wt = None
        if windows is not None:
            wt = read_columns(windows)
        return write_perfetto(p, jt, tt, tasks=tasks, windows=wt, metadata=metadata)
    names, lanes, extras, nlanes = plan
    other = json.dumps(
        {"time_unit": "µs of simulated time", **(metadata or {})},
        separators=(",", ":"),
        allow_nan=False,
    )
    with atomic_path(p) as tmp, open(tmp, "w", encoding="utf-8") as fh:
        fh.write('{"traceEvents":[')
        out = _Writer(fh)
        ev = out.batch
        meta, tid = _tracks(title, names, nlanes)
        ev.extend(meta)
        out.maybe_flush()

        def job_tid(task: str, job: int) -> int:
            ln = lanes.get(task)
            return tid[(task, ln.of(job) if ln is not None else 0)]

        for chunk in jobs:
            for row in chunk:
                _job_event(row, job_tid(str(row[0]), int(row[1])), False, ev)
            out.maybe_flush()
        for (task, job), (s, f) in extras.items():
            _job_event(
                (task, job, math.nan, s, f, math.nan, math.nan, math.nan, False, 0, False, False),
                job_tid(task, job),
                True,
                ev,
            )
        out.maybe_flush()
        for chunk in trace:
            for r in chunk:
                ev.append(_slice(r, job_tid(str(r[0]), int(r[1]))))
            out.maybe_flush()
        world = len(tid) + 1
        first = True
        for w in _window_chunks(windows):
            if not len(w):
                continue
            if first:
                ev.extend(_thread_meta(world, "world", -1))
                first = False
            for r in w.itertuples(index=False):
                ev.extend(_window_events(r, world))
                if len(ev) >= BATCH:
                    out.flush()
        out.flush()
        fh.write('],"displayTimeUnit":"ms","otherData":' + other + "}")
        fh.flush()
        os.fsync(fh.fileno())
    return p


def _thread_meta(tid: int, name: str, sort_index: int) -> list[dict[str, Any]]:
    """The metadata events that name the track ``tid`` and place it in the sort order (the
    world's track, -1, first)."""
    return [
        {"ph": "M", "pid": PID, "tid": tid, "name": "thread_name", "args": {"name": name}},
        {
            "ph": "M",
            "pid": PID,
            "tid": tid,
            "name": "thread_sort_index",
            "args": {"sort_index": sort_index},
        },
    ]


def _tracks(
    title: str, names: list[str], nlanes: Mapping[str, int]
) -> tuple[list[dict[str, Any]], dict[tuple[str, int], int]]:
    """The metadata events of the process and of every task's tracks (``nlanes[t]`` of task
    ``t``, default 1, in the order of ``names``), and the track id of each (task, lane): 1, 2,
    ..., so the next free id is ``len`` of it + 1."""
    events = [{"ph": "M", "pid": PID, "tid": 0, "name": "process_name", "args": {"name": title}}]
    tid: dict[tuple[str, int], int] = {}
    for order, t in enumerate(names):
        for lane in range(nlanes.get(t, 1)):
            tid[(t, lane)] = len(tid) + 1
            label = t if lane == 0 else f"{t} ({lane + 1})"
            events += _thread_meta(tid[(t, lane)], label, order * 100 + lane)
    return events, tid


def _window_events(r: Any, world: int) -> list[dict[str, Any]]:
    """One windows.csv row's events: the window, leader speed and min MSB counters, and a
    "track lost" instant on the world's track when the window lost any."""
    ts = _us(r.t)
    ev: list[dict[str, Any]] = [
        {
            "ph": "C",
            "pid": PID,
            "tid": 0,
            "name": "window (ms)",
            "ts": ts,
            "args": {"w": float(r.w), "w_sch": float(r.w_sch)},
        },
        {
            "ph": "C",
            "pid": PID,
            "tid": 0,
            "name": "leader speed (cm/s)",
            "ts": ts,
            "args": {"v_leader": float(r.v_leader)},
        },
    ]
    if math.isfinite(float(r.msb_min)):
        ev.append(
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
        ev.append(
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
    return ev


def _plan(
    jobs: Any, trace: Any, tasks: Sequence[str] | None
) -> tuple[list[str], dict[str, _Lanes], dict[tuple[str, int], list[float]], dict[str, int]]:
    """The first passes of `stream_perfetto`: track names, the lanes of each task, the
    jobs that ran but have no record (first start, last end), lanes per task."""
    seen: dict[str, None] = {}
    recorded: dict[str, _IntSet] = {}
    lanes: dict[str, _Lanes] = {}
    for chunk in jobs:
        for row in chunk:
            task, job = str(row[0]), int(row[1])
            seen[task] = None
            rec = recorded.get(task)
            if rec is None:
                rec = recorded[task] = _IntSet()
            rec.add(job)
            if not _nan(row[3]):
                ln = lanes.get(task)
                if ln is None:
                    ln = lanes[task] = _Lanes()
                if not ln.add(job, float(row[3]), row[4]):
                    raise _Unordered
    extras: dict[tuple[str, int], list[float]] = {}
    for chunk in trace:
        for r in chunk:
            task, job = str(r[0]), int(r[1])
            rec = recorded.get(task)
            if rec is not None and job in rec:
                continue
            span = extras.get((task, job))
            if span is None:
                extras[(task, job)] = [r[5], r[6]]
            else:
                if r[5] < span[0]:
                    span[0] = r[5]
                if r[6] > span[1]:
                    span[1] = r[6]
    for (task, job), (s, f) in extras.items():
        seen[task] = None
        ln = lanes.get(task)
        if ln is None:
            ln = lanes[task] = _Lanes()
        if not ln.add(job, float(s), f):
            raise _Unordered
    names = list(tasks) if tasks is not None else list(seen)
    names += [t for t in seen if t not in names]
    nlanes = {t: max(1, len(ln.ends)) for t, ln in lanes.items()}
    return names, lanes, extras, nlanes
