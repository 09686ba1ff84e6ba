"""Jobs of a simple top task booked inline, without a `Job`: a room of the virtual CPU.

The dispatcher (`rtsim.sim.cpu`) hands a job of its top task, released at now, to the
function `top_jobs` made for its run (docs/cpu-events.md, step 3: inline jobs of the top
task, runs of inline jobs). If nothing can happen while the job runs, that function books
the preemption at now, the completion at f = now + c and the dispatch at f in one step, with
the same float operations in the same order as the general path, then goes on to the top
task's next release itself while that is the next thing to happen. Any other case goes back
to the dispatcher's loop, in the state the loop would have there. The call is made for every
run of inline jobs, so its constants are bound once per run (default arguments: locals), and
the sums it adds to (the CPU's busy time and switches; the task's completions, responses and
releases) are kept in locals and stored when the booking ends: the same float additions in
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

__all__ = ["Booked", "Dispatcher", "Top", "top_jobs"]

_INF = math.inf

#: A job of the top task released at now and not booked yet: (its task, k, release, seq).
Top = tuple[_TaskState, int, float, int]
#: What the booking of a run of inline jobs leaves (module doc): (moved: the loop goes on at
#: now, from its top; the top task's job released at now and not booked yet, running, now,
#: now_lag, work_start, work_lag, run_end, run_lag).
Booked = tuple[bool, Top | None, Job | None, float, float, float, float, float, float]


class Dispatcher(Protocol):
    """What `top_jobs` takes from the CPU whose run it books (`rtsim.sim.cpu.CPU`)."""

    env: Any  # (a plain SimPy environment)
    _timers: list[tuple[Any, ...]]
    _ready: list[tuple[Any, Any, Job]]
    _totals: _Totals
    _last_release: float

    @property
    def _seq(self) -> Iterator[int]: ...

    def _count_response(
        self, stats: TaskStats, resp: float, rel_deadline: float
    ) -> tuple[int, dict[int, int]]: ...


def top_jobs(
    cpu: Dispatcher,
    queue: list[Any],
    top_first: bool,
    top_record: Callable[[_TaskState, int, float, float, float, bool], None] | None,
) -> Callable[..., Booked | None]:
    """The booking for a run of ``cpu`` (module doc; ``top_record`` None: no job records)."""
    top_resp, top_bin, top_counts = math.nan, 0, dict[int, int]()  # the latest response, its bin

    def book(  # (the dispatcher's state, then its constants bound as locals for the run)
        top: Top,
        running: Job | None,
        now: float,
        now_lag: float,
        work_start: float,
        work_lag: float,
        t_next: float,
        tol: float,
        tol_next: float,
        env: Any = cpu.env,
        timers: list[tuple[Any, ...]] = cpu._timers,
        ready: list[tuple[Any, Any, Job]] = cpu._ready,
        queue: list[Any] = queue,
        totals: _Totals = cpu._totals,
        seqs: Iterator[int] = cpu._seq,
        top_first: bool = top_first,
        last_release: float = cpu._last_release,
        top_record: Callable[..., None] | None = top_record,
        inf: float = _INF,
    ) -> Booked | None:
        """Book ``top``'s job if it can be (module doc); None if not: its `Job` is ready."""
        nonlocal top_resp, top_bin, top_counts
        st, k, r, seq = top
        limit = now + tol  # (what is due by limit happens at now)
        stats, c = st.stats, st.fast_start  # (constant for the run, as these:)
        first, period, rel_deadline = st.first, st.period, st.deadline
        # (job wins under fp; else if it comes first and preempts); nxt_job: the first in the
        job, wins, nxt_job, from_ready = None, True, running, False  # ready order after it, at f
        if ready:  # (key, tie) < running's? (the common "key greater" case first)
            h = ready[0]
            if running is None or (
                h[0] <= running.key and (h[0] < running.key or h[1] < running.tie)
            ):
                nxt_job, from_ready = h[2], True
        if not timers:  # (t_next: the next timer, inf if none)
            t_next = inf
        nxt_ok = nxt_job is None or nxt_job.rem is not None  # (it has started: no hook at f)
        unbooked = moved = due = False  # (when the clock moved on: the job released then)
        # the top task's next release (k, time) in locals; once its timer is out of the heap
        # (held; live: before the horizon), ot/other: the first timer left in it
        kn, rn, held, live, rel_first, ot, other = (
            st.k,
            st.next_release,
            False,
            True,
            False,
            inf,
            None,
        )
        top_n, released, sum_resp = 0, 0, stats.sum_response  # (top_n: responses = top_resp
        busy = jrem = jex = xr = 0.0  # not yet in its bin; the job after: its progress, set
        switches = jpre = 0  # once the first job is booked)
        while True:  # (one pass for the first job, then after each release: the next)
            if not top_first:  # (its key, a deadline, is compared with the others')
                job = Job(st, k, r, r + rel_deadline, period, seq)
                jk = job.key
                wins = (running is None or jk < running.key) and (
                    not ready or jk < ready[0][0] or (jk == ready[0][0] and job.tie < ready[0][1])
                )
            x = c + now_lag  # type: ignore[operator]
            f = now + x
            y = f - now
            f_lag = (now - (f - y)) + (x - y)
            if not (  # nothing happens in (now, f], and no hook runs at f
                wins
                and limit < f
                and f + tol < t_next
                and t_next < inf
                and nxt_ok
                and (not queue or queue[0][0] > f)
            ):
                unbooked = True
                break
            if moved:  # the job running since its last dispatch is preempted at now (> it)
                if nxt_job is not None:
                    worked = now - work_start
                    jex += worked
                    busy += worked
                    jrem = jrem - worked - (now_lag - work_lag)
                    jpre += 1
                    switches += 2
                else:
                    switches += 1
            else:  # the first: the job running (if any) is preempted at now
                _preempted(running, nxt_job, from_ready, now, now_lag, work_start, work_lag, cpu)
                running, now_lag, moved, nxt_ok = nxt_job, 0.0, True, True
                if nxt_job is not None:  # (its progress in locals while it runs)
                    jrem, jex, jpre = nxt_job.rem, nxt_job.executed, nxt_job.preemptions
                busy, switches = totals.busy, 2 if nxt_job is not None else 1
            busy += f - now  # its completion at f: step 1 and CPU._complete, no Job
            resp = f - r
            sum_resp += resp
            deadline = r + rel_deadline
            if f > deadline + tol:
                stats.misses += 1
            if resp == top_resp:  # (nearly always: its bin exists, the maximum is at least
                top_n += 1  # resp; top_n goes into the bin when the booking ends, or before
            else:  # another bin is counted)
                top_bin, top_counts = _new_bin(
                    cpu, stats, resp, deadline - r, top_n, top_bin, top_counts
                )
                top_resp, top_n = resp, 0
            if top_record is not None:
                top_record(st, k, r, now, f, f > deadline + tol)
            now = work_start = f  # (env._now is set where the clock stops)
            work_lag = f_lag
            if nxt_job is not None:  # it gets the CPU at f (a second switch); run_lag at the end
                xr = jrem + f_lag
                run_end = f + xr
            else:
                run_end = inf
            # Next, as the loop would: 4. the wait; 1. the job after ends (steps 1 and 3 here,
            # it is simple and nothing else is due); 2. the top task's release alone (else on)
            while not (t_next < run_end and (not queue or t_next < queue[0][0])):
                if (
                    nxt_job is None
                    or t_next <= run_end + tol
                    or run_end >= tol_next
                    or (queue and queue[0][0] <= run_end)
                    or not nxt_job._st.simple
                    or nxt_job._st.job_end_hooks
                ):
                    moved = False
                    break  # (to the wait)
                y = run_end - work_start  # it ends at run_end (its lag: the wait's now_lag)
                lag = (work_start - (run_end - y)) + (xr - y)
                now = run_end
                worked = now - work_start
                busy += worked
                nxt_job.rem, nxt_job.executed, nxt_job.preemptions = 0.0, jex + worked, jpre
                if held:  # (the heap whole again: _complete may add a timer)
                    if live:
                        heappush(timers, (rn, st.rank, st.priority, st.index, _RELEASE, st))
                    held = False
                env._now = now
                cpu._complete(nxt_job, now)
                t_next = timers[0][0] if timers else inf
                work_start = now  # (= now + overhead 0.0: now > 0)
                work_lag, limit, run_end = lag, now + tol, inf
                running = nxt_job = ready[0][2] if ready else None  # (step 3: it gets the CPU)
                if t_next > limit:
                    if nxt_job is None:
                        continue  # (the CPU idles)
                    if (
                        nxt_job.rem is not None
                        or nxt_job._st.seg_const[nxt_job.seg_index] is not None
                    ):
                        jrem, xr, run_end = _dispatch(nxt_job, now, lag, ready)
                        jex, jpre = nxt_job.executed, nxt_job.preemptions
                        switches += 1
                        if run_end > limit:
                            continue
                        now_lag = lag  # (it ends at once: step 1 at now)
                        break
                running = nxt_job = None  # (a timer due at now, or a segment starts by a call:
                now_lag = lag  # the loop goes on at now, at step 2)
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
                    other = timers[0] if timers else None
                    ot = other[0] if other is not None else inf
                elif not rel_first:  # (the first timer is another one)
                    break
                k, r = kn, rn  # the release of step 2's fast path (stats.max_backlog is 1 already)
                kn = k + 1
                released += 1  # (its sequence number drawn at the end under fp)
                if not top_first:
                    seq = next(seqs)
                after = first + kn * period
                if after < last_release:
                    rn = after  # (comes first if earlier, or at once with a later entry)
                    rel_first = after < ot or (
                        after == ot and (after, st.rank, st.priority, st.index) < other
                    )
                    t_next = after if rel_first else ot
                else:
                    live = rel_first = False
                    t_next = ot
                if t_next > limit:
                    continue  # (the next job: booked as the first was, or not)
                due = True  # (another timer is due: step 2 goes on, then this job)
            break
        if unbooked and not moved:  # the first job is not booked: its Job is ready
            _enqueue(job, st, k, r, period, seq, ready)
            return None
        if top_first and released:  # (the releases' sequence numbers, drawn in one call)
            seq = next(islice(seqs, released - 1, None))
        nxt = None
        if unbooked:  # (the job released at now: not booked, ready; or booked at step 3)
            _enqueue(job, st, k, r, period, seq, ready)
        elif due:
            nxt = (st, k, r, seq)
        if held and live:  # (its timer back in the heap)
            heappush(timers, (rn, st.rank, st.priority, st.index, _RELEASE, st))
        st.k, st.next_release = kn, rn
        if nxt_job is not None:  # (its progress, and the lag of its end)
            nxt_job.rem, nxt_job.executed, nxt_job.preemptions = jrem, jex, jpre
            y = run_end - work_start
            run_lag = (work_start - (run_end - y)) + (xr - y)
        else:
            run_lag = 0.0
        if top_n:
            top_counts[top_bin] += top_n
        done = released if unbooked or due else released + 1  # (jobs booked)
        totals.busy, totals.switches = busy, totals.switches + switches
        stats.completed += done
        stats.sum_response, stats.released = sum_resp, stats.released + released
        env._now = now
        return moved, nxt, running, now, now_lag, work_start, work_lag, run_end, run_lag

    return book


def _preempted(
    running: Job | None,
    nxt_job: Job | None,
    from_ready: bool,
    now: float,
    now_lag: float,
    work_start: float,
    work_lag: float,
    cpu: Dispatcher,
) -> None:
    """The first job of a run is booked: ``running`` (if any) is preempted at ``now``, its
    progress booked (the dispatcher's switch), and ``nxt_job`` leaves the ready heap if it
    comes from it (``from_ready``)."""
    if running is not None:
        if running.rem is not None and now > work_start:
            worked = now - work_start
            running.executed += worked
            cpu._totals.busy += worked
            running.rem = running.rem - worked - (now_lag - work_lag)
        running.preemptions += 1
        if from_ready:
            heappush(cpu._ready, (running.key, running.tie, running))
    if from_ready:
        heappop(cpu._ready)


def _dispatch(
    job: Job, now: float, lag: float, ready: list[tuple[Any, Any, Job]]
) -> tuple[float, float, float]:
    """Step 3 at ``now`` (its lag ``lag``), nothing running: ``job``, the first in the ready
    heap, gets the CPU; its segment starts if it has not (a constant time, no hook). Returns
    (its remaining work, that plus ``lag``, the end of its work)."""
    heappop(ready)
    rem = job.rem
    if rem is None:
        if job.start is None:
            job.start = now
        job.seg_start = now
        job.seg_exec = job.rem = rem = job._st.seg_const[job.seg_index]
    x = rem + lag  # type: ignore[operator]
    return rem, x, now + x  # type: ignore[return-value]


def _new_bin(
    cpu: Dispatcher,
    stats: TaskStats,
    resp: float,
    rel_deadline: float,
    top_n: int,
    top_bin: int,
    top_counts: dict[int, int],
) -> tuple[int, dict[int, int]]:
    """The top task's response ``resp`` differs from the last one: the ``top_n`` responses
    equal to that are counted in its bin ``top_bin`` of ``top_counts``, the maximum is
    updated, and ``resp`` is counted (`CPU._count_response`: its bin and the counts)."""
    if top_n:
        top_counts[top_bin] += top_n
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
