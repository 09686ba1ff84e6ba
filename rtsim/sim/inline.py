"""Jobs of a simple top task booked inline, without a `Job`: a room of the virtual CPU.

The dispatcher (`rtsim.sim.cpu`) hands a job of its top task, released at now, to the
function `top_jobs` made for its run (docs/cpu-events.md, step 3: inline jobs of the top
task, runs of inline jobs). If nothing can happen while the job runs, that function books
the preemption at now, the completion at f = now + c and the dispatch at f in one step, with
the same float operations in the same order as the general path, then goes on to the top
task's next release itself while that is the next thing to happen; when the job after it
ends first, that job completes and the next gets the CPU there too (`_job_ends`). Any other
case goes back to the dispatcher's loop, in the state the loop would have there. The call is
made for every run of inline jobs, so its constants are bound once per run (closure cells),
and what it adds to or moves (the CPU's busy time and switches; the task's completions,
responses, releases and release timer; the progress of the job after it; the sequence
numbers) is kept in locals and stored when the booking ends: the same float additions in
the same order, and nothing reads them meanwhile.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from heapq import heappop, heappush
from itertools import islice
from typing import Any, Protocol

from rtsim.sim.job import _RELEASE, Job, _TaskState, _Totals
from rtsim.sim.records import TaskStats

__all__ = ["Book", "Booked", "Dispatcher", "Record", "Top", "top_jobs"]

_INF = math.inf

#: A job of the top task released at now and not booked yet: (its task, k, release, seq).
Top = tuple[_TaskState, int, float, int]
#: What the booking of a run of inline jobs leaves (module doc): (moved: the loop goes on at
#: now, from its top; the top task's job released at now and not booked yet, running, now,
#: now_lag, work_start, work_lag, run_end, run_lag).
Booked = tuple[bool, Top | None, Job | None, float, float, float, float, float, float]
#: The booking `top_jobs` makes for a run, and the job records' writer it may be given.
Book = Callable[..., Booked | None]
Record = Callable[[_TaskState, int, float, float, float, bool], None]


class Dispatcher(Protocol):
    """What `top_jobs` takes from the CPU whose run it books (`rtsim.sim.cpu.CPU`)."""

    env: Any  # (a plain SimPy environment)
    _timers: list[tuple[Any, ...]]
    _ready: list[tuple[Any, Any, Job]]
    _totals: _Totals
    _top_state: _TaskState | None  # (the task whose jobs are booked: its fast_top)
    _last_release: float
    _tol: float

    @property
    def _seq(self) -> Iterator[int]: ...

    def _count_response(
        self, stats: TaskStats, resp: float, rel_deadline: float
    ) -> tuple[int, dict[int, int]]: ...

    def _complete(self, job: Job, now: float) -> None: ...


def top_jobs(cpu: Dispatcher, queue: list[Any], top_first: bool, top_record: Record | None) -> Book:
    """The booking for a run of ``cpu`` (module doc; ``top_record`` None: no job records)."""
    top_resp, top_bin, top_counts = math.nan, 0, dict[int, int]()  # the latest response, its bin
    env, timers, ready, totals, seqs = cpu.env, cpu._timers, cpu._ready, cpu._totals, cpu._seq
    last_release, inf, tst = cpu._last_release, _INF, cpu._top_state  # (the run's constants,
    assert tst is not None  # as closure cells; tst: the task booked, a CPU has one: `CPU.start`)
    stats, first, period, rel_deadline = tst.stats, tst.first, tst.period, tst.deadline
    c = tst.fast_start  # (a constant time: its jobs are booked)

    def book(top, running, now, now_lag, work_start, work_lag, t_next, tol, tol_next):
        """Book ``top``'s job if it can be (module doc): `Booked`; None if not: its Job is ready."""
        nonlocal top_resp, top_bin, top_counts
        st, k, r, seq = top
        limit, job, nxt_job, from_ready, rn = now + tol, None, running, False, r  # (due by
        if ready:  # limit: at now) nxt_job: the first in the ready order after the top task's
            h = ready[0]  # job, at f
            if running is None or (
                h[0] <= running.key and (h[0] < running.key or h[1] < running.tie)
            ):
                nxt_job, from_ready = h[2], True
        wins = nxt_job is None or nxt_job.rem is not None  # (it has started: no hook at f; so
        unbooked = moved = due = held = False  # has each job after it; wins: then always
        top_n, released, sum_resp, switches = 0, 0, stats.sum_response, 0  # under fp) (moved:
        while True:  # the clock, to a release) one pass for the first job, then after each release
            if not top_first:  # (its key, a deadline, is compared with the others')
                job = Job(st, k, r, r + rel_deadline, period, seq)
                jk = job.key
                ok = (running is None or jk < running.key) and (
                    not ready or jk < ready[0][0] or (jk == ready[0][0] and job.tie < ready[0][1])
                )
                wins = wins and ok
            x = c + now_lag  # type: ignore[operator]
            f = now + x
            y = f - now
            f_lag = (now - (f - y)) + (x - y)
            if not (wins and limit < f and f + tol < t_next and t_next < inf) or (
                queue and queue[0][0] <= f
            ):  # (nothing happens in (now, f], and no hook runs at f)
                unbooked = True
                break
            if not moved and from_ready:  # the first: the job running (if any) is preempted
                busy, jrem, jex, jpre = _preempted(  # at now; the job after, from the ready heap
                    running, nxt_job, now, now_lag, work_start, work_lag, cpu
                )  # (its progress in locals while it runs)
                running, now_lag, moved, switches = nxt_job, 0.0, True, 2
            else:  # (top_n: the responses = top_resp not in its bin yet) the first: the job
                if not moved:  # after, if any, is the one running (it has started: wins);
                    busy, moved = totals.busy, True  # its progress in locals while it runs
                    if running is not None:
                        jrem, jex, jpre = running.rem, running.executed, running.preemptions
                if nxt_job is not None:  # the job after is preempted at now
                    jpre, switches = jpre + 1, switches + 2
                    if now > work_start:  # (always, but at the first)
                        worked = now - work_start
                        jex, busy = jex + worked, busy + worked
                        jrem = jrem - worked - (now_lag - work_lag)
                else:
                    switches += 1
                now_lag = 0.0
            busy += f - now  # its completion at f: step 1 and CPU._complete, no Job
            resp = f - r
            sum_resp += resp
            deadline = r + rel_deadline
            if f > deadline + tol:
                stats.misses += 1
            if resp == top_resp:  # (nearly always: its bin exists, the maximum is at least
                top_n += 1  # resp; top_n goes into the bin when the booking ends, or before
            else:  # another bin is counted)
                if top_n:
                    top_counts[top_bin] += top_n
                top_bin, top_counts = _new_bin(cpu, stats, resp, deadline - r)
                top_resp, top_n = resp, 0
            if top_record is not None:
                top_record(st, k, r, now, f, f > deadline + tol)
            now, work_start, work_lag = f, f, f_lag  # (env._now is set where the clock stops)
            run_end = f + (xr := jrem + f_lag) if nxt_job is not None else inf  # (the job after
            while not (t_next < run_end and (not queue or t_next < queue[0][0])):  # gets the CPU)
                if nxt_job is None or not (js := nxt_job._st).simple or js.job_end_hooks:
                    moved = False  # (not here, as `_job_ends` would find: to the wait)
                    break  # Next, as the loop would: 4. the wait; 1. the job after ends (1, 3
                if held:  # here: nothing else due); else 2. the top task's release
                    heappush(timers, (rn, st.rank, st.priority, st.index, _RELEASE, st))
                held = False  # (the heap whole again: CPU._complete may add a timer)
                e = _job_ends(cpu, nxt_job, work_start, run_end, xr, jex, jpre, t_next, tol_next)
                if e is None:
                    moved = False
                    break  # (to the wait)
                go, now, lag, n, nxt_job, jrem, xr, run_end, t_next, jex, jpre = e
                busy += now - work_start
                running, work_start, work_lag, switches = nxt_job, now, lag, switches + n
                if not go:  # (the loop goes on at now: a timer due, a job to start or ending)
                    now_lag = lag
                    break
            else:
                now = t_next  # (now_lag is 0.0)
                limit = now + tol
                if now >= tol_next or run_end <= limit:
                    break
                if not held:  # the first timer must be the top task's release: out of the heap
                    if timers[0][5] is not st:
                        break
                    heappop(timers)
                    held = True
                    if not released:  # the top task's next release (k, t) in locals while
                        kn, rn = st.k, st.next_release  # its timer is out of the heap (held)
                    other, ot = (timers[0], timers[0][0]) if timers else (None, inf)
                k, r, kn, released = kn, rn, kn + 1, released + 1  # the release of step 2's fast
                if not top_first:  # path (stats.max_backlog is 1 already; under fp its sequence
                    seq = next(seqs)  # number is drawn at the end)
                after = first + kn * period
                if after < last_release:  # (first if earlier, or at once with a later entry)
                    if after < ot or (after == ot and _first(after, st, other)):
                        rn = t_next = after
                    else:  # (the first timer is another one: the release's back in the heap)
                        rn, t_next, held = after, ot, False
                        heappush(timers, (rn, st.rank, st.priority, st.index, _RELEASE, st))
                else:  # (none in the horizon)
                    t_next, held = ot, False
                if t_next > limit:
                    continue  # (the next job: booked as the first was, or not)
                due = True  # (another timer is due: step 2 goes on, then this job)
            break
        if released:
            if top_first:  # (the releases' sequence numbers, drawn in one call)
                seq = next(seqs) if released == 1 else next(islice(seqs, released - 1, None))
            if held:  # (its timer back in the heap)
                heappush(timers, (rn, st.rank, st.priority, st.index, _RELEASE, st))
            st.k, st.next_release = kn, rn
            stats.released += released
        if unbooked:  # (the job released at now: not booked, ready; or booked at step 3)
            _enqueue(job, st, k, r, period, seq, ready)
            if not moved:  # (the first)
                return None
        if nxt_job is not None:  # (its progress, and the lag of its end)
            nxt_job.rem, nxt_job.executed, nxt_job.preemptions = jrem, jex, jpre
            y = run_end - work_start
            run_lag = (work_start - (run_end - y)) + (xr - y)
        else:
            run_lag = 0.0
        if top_n:
            top_counts[top_bin] += top_n
        totals.busy, totals.switches = busy, totals.switches + switches
        stats.completed += released if unbooked or due else released + 1  # (jobs booked)
        stats.sum_response = sum_resp
        env._now = now
        nxt = (st, k, r, seq) if due else None
        return moved, nxt, running, now, now_lag, work_start, work_lag, run_end, run_lag

    return book


def _preempted(
    running: Job | None,
    nxt_job: Job,
    now: float,
    now_lag: float,
    work_start: float,
    work_lag: float,
    cpu: Dispatcher,
) -> tuple[float, float, float, int]:
    """The first job of a run is booked and ``nxt_job``, the first ready job, gets the CPU
    after it: ``running`` (if any) is preempted at ``now``, its progress booked (the
    dispatcher's switch), and ``nxt_job`` leaves the ready heap. Returns the CPU's busy time
    and ``nxt_job``'s remaining work, CPU time and preemptions. (When the job after is the
    one running, or none, `top_jobs` books the same in its locals.)"""
    if running is not None:
        if running.rem is not None and now > work_start:
            worked = now - work_start
            running.executed += worked
            cpu._totals.busy += worked
            running.rem = running.rem - worked - (now_lag - work_lag)
        running.preemptions += 1
        heappush(cpu._ready, (running.key, running.tie, running))
    heappop(cpu._ready)
    return cpu._totals.busy, nxt_job.rem, nxt_job.executed, nxt_job.preemptions  # type: ignore[return-value]


def _job_ends(
    cpu: Dispatcher,
    job: Job,
    start: float,
    end: float,
    x: float,
    executed: float,
    preemptions: int,
    t_next: float,
    tol_next: float,
) -> tuple[bool, float, float, int, Job | None, float, float, float, float, float, int] | None:
    """Steps 4, 1 and 3 of the dispatcher's loop, made as it would make them, when ``job``
    (the job after the top task's, simple and without job-end hooks: the caller checks that;
    running since ``start``, its work ``x`` with the lag ends at ``end``, its progress
    ``executed`` and ``preemptions``) ends before the next timer ``t_next``: it completes
    (`CPU._complete`) and the first ready job gets the CPU, its segment started (a constant
    time, no hook). None if not done here: a wider coincidence window (``tol_next``), a timer
    or SimPy event due at its end. Else (go on: nothing else happens at now; now, its lag,
    switches, the job that runs or None, its remaining work, that plus the lag, its end or
    inf, the next timer, its CPU time and preemptions): no job runs (it is not started) if a
    timer is due at now or its segment starts by a call, and the loop goes on at now, as it
    does if the job ends at once."""
    queue, tol = cpu.env._queue, cpu._tol  # (SimPy's: runs are booked where the clock jumps;
    # the coincidence window at ``start``, as in the run: it ends where the window widens)
    if end >= tol_next or t_next <= end + tol or (queue and queue[0][0] <= end):
        return None
    y = end - start  # (the end's lag: the wait's now_lag)
    lag = (start - (end - y)) + (x - y)
    job.rem, job.executed, job.preemptions = 0.0, executed + (end - start), preemptions
    cpu.env._now = end
    cpu._complete(job, end)
    timers, ready = cpu._timers, cpu._ready
    t_next = timers[0][0] if timers else _INF
    nxt = ready[0][2] if ready else None  # (step 3: it gets the CPU; now + overhead 0.0 = now)
    if t_next <= end + tol or nxt is None:  # (the CPU idles if nothing is due)
        return t_next > end + tol, end, lag, 0, None, 0.0, 0.0, _INF, t_next, 0.0, 0
    rem = nxt.rem
    if rem is None:
        rem = nxt._st.seg_const[nxt.seg_index]
        if rem is None:
            return False, end, lag, 0, None, 0.0, 0.0, _INF, t_next, 0.0, 0
        if nxt.start is None:
            nxt.start = end
        nxt.seg_start = end
        nxt.seg_exec = nxt.rem = rem
    heappop(ready)
    x = rem + lag
    run_end = end + x
    return (
        run_end > end + tol,
        end,
        lag,
        1,
        nxt,
        rem,
        x,
        run_end,
        t_next,
        nxt.executed,
        nxt.preemptions,
    )


def _first(t: float, st: _TaskState, other: tuple[Any, ...]) -> bool:
    """Whether the top task's release timer at ``t`` comes before the timer ``other`` of the
    same time in the heap's order."""
    return (t, st.rank, st.priority, st.index) < other


def _new_bin(
    cpu: Dispatcher, stats: TaskStats, resp: float, rel_deadline: float
) -> tuple[int, dict[int, int]]:
    """The top task's response ``resp`` differs from the last one: the maximum is updated, and
    ``resp`` is counted (`CPU._count_response`: its bin and the counts)."""
    if stats.max_response is None or resp > stats.max_response:
        stats.max_response = resp
    return cpu._count_response(stats, resp, rel_deadline)


def _enqueue(
    job: Job | None,
    st: _TaskState,
    k: int,
    r: float,
    period: float,
    seq: int,
    ready: list[tuple[Any, Any, Job]],
) -> None:
    """The top task's job ``k`` released at ``r`` is not booked: its `Job` (if not made yet)
    joins its task's pending jobs and the ready heap."""
    if job is None:
        job = Job(st, k, r, r + st.deadline, period, seq)
    st.pending.append(job)
    heappush(ready, (job.key, job.tie, job))
