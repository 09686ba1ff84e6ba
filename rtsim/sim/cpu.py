"""The virtual CPU: preemptive scheduling of job chains on one processor, by a policy.

The specification — what the dispatcher owns, the order of things at one instant, and how
suspensions, overload, overhead, jitter, periods, critical sections and time slices enter —
is docs/cpu-events.md. In short: ONE SimPy process, the dispatcher (`CPU._dispatcher`),
owns a timer heap, a ready heap keyed by the policy's (key, tie) (`rtsim.sim.policy`)
and the running job; at each instant it (1) ends the running segment if its work is done,
(2) handles the timers due (idle suspensions ending, aborts, the window's release, other
releases by priority, ends of time slices), (3) gives the CPU to the first eligible job if
the policy says it preempts, and (4) waits for the earlier of the segment's end and the
next timer. Preemption is bookkeeping, not interrupts. The rooms: this module (dispatch and
the jobs' bookkeeping), `rtsim.sim.inline` (jobs of a simple top task booked inline,
bit-identically), `rtsim.sim.resources` (the resource protocols) and `rtsim.sim.slices`
(time slices).
"""

from __future__ import annotations

import heapq
import itertools
import math
from collections.abc import Callable
from typing import Any, Literal

import numpy as np
import simpy

from rtsim.errors import InputError, RtsimError
from rtsim.model.task import RESOURCE_PROTOCOLS, Task
from rtsim.sim.execution import WCET, ExecSpec, jitter_rngs, resolve_exec_model, task_rngs
from rtsim.sim.inline import Booked, Top, top_jobs
from rtsim.sim.job import (
    _ABORT,
    _JREL,
    _RELEASE,
    _RESUME,
    _SLICE,
    Job,
    JobHook,
    PeriodProvider,
    SegmentHook,
    _TaskState,
    _Totals,
)
from rtsim.sim.policy import FixedPriority, PolicySpec, SchedulingPolicy, resolve_scheduler
from rtsim.sim.records import (
    EPS,
    ResponseHistogram,
    RowBuffer,
    SimResult,
    TaskStats,
    jobs_frame,
    trace_frame,
)
from rtsim.sim.resources import ResourceProtocols
from rtsim.sim.slices import TimeSlices, with_quantum

__all__ = [
    "CPU",
    "Job",
    "HookEvent",
    "HOOK_EVENTS",
    "SegmentHook",
    "JobHook",
    "JitterMode",
    "JITTER_MODES",
]

HookEvent = Literal["release", "segment_start", "segment_end", "job_end"]
HOOK_EVENTS: tuple[str, ...] = ("release", "segment_start", "segment_end", "job_end")
JitterMode = Literal["random", "worst", "none"]
JITTER_MODES: tuple[str, ...] = ("random", "worst", "none")

_INF = math.inf
#: Doubles near t are ulp(t) = 2^(⌊log2 t⌋ − 52) ms apart, so beyond about 2^22 ms an absolute
#: 1e-9 ms cannot be resolved. The coincidence window at t (docs/time.md) is
#: max(EPS, ULPS·ulp(t)): two instants closer than it are one, a finish within it after the
#: deadline meets it. EPS is the larger up to t = 2^19 ms (8.7 minutes).
ULPS = 16


def _end_of(start: float, rem: float, lag: float) -> tuple[float, float]:
    """The end of ``rem`` ms of work started at ``start`` whose exact start is ``start +
    lag``, and that end's rounding error (Knuth's TwoSum; docs/time.md). The dispatcher's
    hot paths write the same four operations inline."""
    x = rem + lag
    end = start + x
    y = end - start
    return end, (start - (end - y)) + (x - y)


def coincidence(t: float) -> tuple[float, float]:
    """(the coincidence window at time ``t``, the time from which it is larger): the window
    is constant over [2^(e−1), 2^e), the binade of t."""
    _, e = math.frexp(t)  # 2^(e−1) ≤ t < 2^e
    return max(EPS, math.ldexp(float(ULPS), e - 53)), math.ldexp(1.0, e)


class CPU(ResourceProtocols, TimeSlices):
    """One processor under a scheduling policy, ``scheduler``: ``"fp"``, ``"edf"``, another
    registered name, ``"package.module:Name"`` or a
    [`SchedulingPolicy`][rtsim.sim.policy.SchedulingPolicy] (docs/cpu-events.md;
    `rtsim.sim.policy`).

    Usage: ``cpu = CPU(env)``; ``cpu.add_task(...)`` for each task; register hooks with
    `on` and per-segment execution times with `set_exec_time`; ``cpu.start(H)``
    returns the dispatcher process (run ``env.run(until=proc)``); ``cpu.result()``.
    ``job_sink`` / ``trace_sink``: where job records / trace rows go in chunks during the
    run (`RowBuffer`; the result's ``jobs`` / ``trace`` are then
    None), so that a long run keeps neither in memory.
    """

    def __init__(
        self,
        env: simpy.Environment | None = None,
        *,
        suspension: Literal["cpu", "idle"] = "cpu",
        exec_model: ExecSpec = "wcet",
        seed: int | np.random.SeedSequence | np.random.Generator | None = 0,
        overhead: float = 0.0,
        record_jobs: bool = False,
        record_trace: bool = False,
        hist_bin: float | None = None,
        jitter: JitterMode = "random",
        job_sink: Callable[[Any], None] | None = None,
        scheduler: PolicySpec = "fp",
        resources: str | None = None,
        trace_sink: Any = None,
        quantum: float | None = None,
    ) -> None:
        self.policy: SchedulingPolicy = with_quantum(resolve_scheduler(scheduler), quantum)
        #: the time slice of a time-sliced policy (ms; None: jobs are not sliced)
        self.quantum = self.policy.quantum
        self._init_slices()
        if resources is not None and resources not in RESOURCE_PROTOCOLS:
            raise InputError(
                f"resources must be one of {', '.join(RESOURCE_PROTOCOLS)}, got {resources!r}"
            )
        #: the resource protocol asked for (None: the policy's default, docs/resources.md)
        self.resources = resources
        # preemption by "strictly smaller key" (the base class's test): evaluated inline
        self._by_key = type(self.policy).preempts is SchedulingPolicy.preempts
        if jitter not in JITTER_MODES:
            raise InputError(f"jitter must be one of {', '.join(JITTER_MODES)}, got {jitter!r}")
        if suspension not in ("cpu", "idle"):
            raise InputError(f"suspension must be 'cpu' or 'idle', got {suspension!r}")
        if not (isinstance(overhead, int | float) and math.isfinite(overhead) and overhead >= 0):
            raise InputError(f"overhead must be a non-negative number of ms, got {overhead!r}")
        if hist_bin is not None and not (math.isfinite(hist_bin) and hist_bin > 0):
            raise InputError(f"hist_bin must be a positive number of ms, got {hist_bin!r}")
        self.env = simpy.Environment() if env is None else env
        self.suspension = suspension
        self.exec_model = resolve_exec_model(exec_model)
        self.exec_model_name = (
            exec_model
            if isinstance(exec_model, str)
            else str(getattr(exec_model, "name", getattr(exec_model, "__name__", "callable")))
        )
        self.seed = seed
        self.overhead = float(overhead)
        self.record_jobs = record_jobs or job_sink is not None
        self.job_sink = job_sink  # job records go there in chunks (records.RowBuffer)
        self.record_trace = record_trace or trace_sink is not None
        self.trace_sink = trace_sink  # trace rows go there in chunks (records.RowBuffer)
        self.hist_bin = hist_bin
        self.jitter = jitter
        self._states: list[_TaskState] = []
        self._by_name: dict[str, _TaskState] = {}
        self._hooks: list[tuple[str, Callable[..., None], str | None, str | None, str | None]] = []
        self._overrides: dict[tuple[str, str], Callable[..., float]] = {}
        self._timers: list[tuple[Any, ...]] = []
        self._ready: list[tuple[Any, Any, Job]] = []  # (job.key, job.tie, job)
        self._seq = itertools.count()
        self._job_rows = RowBuffer(jobs_frame, job_sink)
        self._trace_rows: list[tuple[Any, ...]] = (
            [] if trace_sink is None else RowBuffer(trace_frame, trace_sink)
        )
        self._w: float | None = None
        self._totals = _Totals()
        self._end_time = 0.0
        self._lag = 0.0  # the dispatcher's now_lag while it calls _segment_done
        self._tol = EPS  # the coincidence window at the dispatcher's now
        self._t0 = 0.0
        self._horizon: float | None = None
        self._last_release = 0.0  # t0 + horizon − EPS: the last time a job is released
        self.process: simpy.Process | None = None
        self._init_resources()  # critical sections (rtsim.sim.resources)

    # -- configuration -------------------------------------------------------------------
    def add_task(
        self, task: Task, *, period_provider: PeriodProvider | None = None, window: bool = False
    ) -> None:
        """Add a periodic task.

        ``period_provider()`` (optional) is called at each release and returns the period
        that starts there (ms); the relative deadline keeps the task's deadline/period ratio.
        ``window=True`` marks the processing-window task: the period of its latest release is
        the *w in force*, and tasks with ``per_window=True`` take period and deadline as
        multiples of it at their release.
        """
        if self.process is not None:
            raise RtsimError("add_task: the CPU has already started")
        if task.name in self._by_name:
            raise InputError(f"task '{task.name}': duplicate task name")
        for st in self._states:
            if st.priority == task.priority and not self.policy.shared_priorities:
                raise InputError(
                    f"task '{task.name}': priority {task.priority} is already "
                    f"used by task '{st.name}' (tasks share a priority only under a "
                    f"time-sliced policy: rr)"
                )
        if window and any(st.is_window for st in self._states):
            raise InputError(f"task '{task.name}': only one window task is allowed")
        if task.per_window and period_provider is not None:
            raise InputError(f"task '{task.name}': a per-window task cannot have a provider")
        st = _TaskState(task, period_provider, window)
        st.index = len(self._states)  # (orders the releases of tasks that share a priority)
        self._states.append(st)
        self._by_name[task.name] = st

    def on(
        self,
        event: HookEvent,
        fn: Callable[..., None],
        *,
        task: str | None = None,
        segment: str | None = None,
        role: str | None = None,
    ) -> None:
        """Register a hook: ``fn(job, segment)`` for segment events, ``fn(job)`` for job events.

        ``event``: ``release`` (after the job is created; not for skipped releases),
        ``segment_start``, ``segment_end``, ``job_end`` (completion, or abort with
        ``job.aborted``). Filters (None = any): task name, segment name, segment role.
        Hooks run synchronously inside the dispatcher, in registration order; they must not
        yield, and may read ``cpu.env.now`` and the job. See docs/cpu-events.md for the order.
        """
        if event not in HOOK_EVENTS:
            raise InputError(f"hook event must be one of {', '.join(HOOK_EVENTS)}, got {event!r}")
        self._hooks.append((event, fn, task, segment, role))
        if self.process is not None:
            self._compile()

    def set_exec_time(self, task: str, segment: str, fn: Callable[..., float]) -> None:
        """Override the execution-time model for one segment: ``fn(job, segment, rng)``."""
        self._overrides[(task, segment)] = fn
        if self.process is not None:
            self._compile()

    @property
    def window(self) -> float | None:
        """The w in force: the period of the window task's latest release."""
        return self._w

    def stats(self, name: str) -> TaskStats:
        """Running statistics of task ``name``."""
        return self._by_name[name].stats

    def _compile(self) -> None:
        rngs = task_rngs(self.seed, [st.name for st in self._states]) if self._states else {}
        jittered = [st.name for st in self._states if st.task.jitter > 0]
        jrngs = jitter_rngs(self.seed, jittered) if jittered and self.jitter == "random" else {}
        by_priority = getattr(self.policy.order, "__func__", None) is FixedPriority.order
        for st in self._states:
            st.order = self.policy.order
            st.by_priority = by_priority
            if st.rng is None:
                st.rng = rngs[st.name]
            st.jitter = 0.0 if self.jitter == "none" else st.task.jitter
            if st.jrng is None and st.name in jrngs:
                st.jrng = jrngs[st.name]
            st.idle_kind = [self.suspension == "idle" and s.kind == "suspend" for s in st.segs]
            st.exec_fns, st.const_exec = [], []
            for s in st.segs:
                fn = self._overrides.get((st.name, s.name), self.exec_model)
                st.exec_fns.append(fn)
                st.const_exec.append(s.wcet if isinstance(fn, WCET) else None)
            st.release_hooks, st.job_end_hooks = [], []
            st.start_hooks = [[] for _ in st.segs]
            st.end_hooks = [[] for _ in st.segs]
            for event, hook, tname, sname, role in self._hooks:
                if tname is not None and tname != st.name:
                    continue
                if event in ("release", "job_end"):
                    if sname is None and role is None:
                        (st.release_hooks if event == "release" else st.job_end_hooks).append(hook)
                    continue
                for i, s in enumerate(st.segs):
                    if (sname is None or sname == s.name) and (role is None or role == s.role):
                        (st.start_hooks if event == "segment_start" else st.end_hooks)[i].append(
                            hook
                        )
            st.simple = len(st.segs) == 1 and not st.end_hooks[0] and not st.idle_kind[0]
            st.fast_release = (
                st.provider is None
                and not st.per_window
                and not st.is_window
                and st.policy == "finish-late"
                and not st.release_hooks
                and not st.idle_kind[0]
                and st.jitter == 0.0
            )
            st.fast_start = st.const_exec[0] if st.simple and not st.start_hooks[0] else None
            st.seg_const = [None if st.start_hooks[i] else c for i, c in enumerate(st.const_exec)]
            segs = st.segs
            st.zero_tail = [
                i > 0 and all(s.wcet == 0.0 and s.resource is None for s in segs[i:])
                for i in range(len(segs))
            ]
            st.plain_next = [
                not st.end_hooks[i]
                and i + 1 < len(segs)
                and not st.idle_kind[i + 1]
                and not st.zero_tail[i + 1]
                for i in range(len(segs))
            ]
            # segment i has end hooks and i + 1 is a CPU segment: the hooks, called by the
            # dispatcher itself (what `_segment_done` and `_continue` do there)
            # segment i is the last and has no end hooks: its end completes the job (and the
            # next job of the task does not start with an idle suspension: `_continue` would
            # time it with the dispatcher's lag)
            st.last_plain = [
                i + 1 == len(segs) and not st.end_hooks[i] and not st.idle_kind[0]
                for i in range(len(segs))
            ]
            # segment i + 1 is an idle suspension (not an empty step): `_segment_done` starts it
            st.idle_next = [
                i + 1 < len(segs) and st.idle_kind[i + 1] and not st.zero_tail[i + 1]
                for i in range(len(segs))
            ]
            st.hooked_next = [
                st.end_hooks[i]
                if st.end_hooks[i]
                and i + 1 < len(segs)
                and not st.idle_kind[i + 1]
                and not st.zero_tail[i + 1]
                else None
                for i in range(len(segs))
            ]
        # the highest-priority task: the one whose jobs may be booked inline (`top_jobs`)
        top = self._top_state = min(self._states, key=lambda x: x.priority, default=None)
        for st in self._states:
            st.fast_top = (
                st is top
                and st.fast_release
                and st.fast_start is not None
                and not st.job_end_hooks
                and self._by_key
                and self.quantum is None
            )
        self._compile_resources()

    # -- running -------------------------------------------------------------------------
    def start(self, horizon: float) -> simpy.Process:
        """Start the dispatcher: jobs released in [now, now + horizon) run to completion/abort."""
        if self.process is not None:
            raise RtsimError("the CPU has already started")
        if not (isinstance(horizon, int | float) and math.isfinite(horizon) and horizon > 0):
            raise InputError(f"horizon must be a positive number of ms, got {horizon!r}")
        if not self._states:
            raise InputError("the CPU has no tasks")
        self._compile()
        self._t0 = self.env.now
        self._horizon = float(horizon)
        end = self._t0 + self._horizon
        self._last_release = end - EPS  # (jobs are released in [t0, end))
        if self.jitter == "worst":  # the critical instant: all first releases at t0 = max J
            jmax = max(st.jitter for st in self._states)
            for st in self._states:
                st.offset = st.task.offset + (jmax - st.jitter)
        for st in self._states:
            st.first = st.next_release = self._t0 + st.offset
            if st.next_release < self._last_release:
                heapq.heappush(
                    self._timers,
                    (st.next_release, st.rank, st.priority, next(self._seq), _RELEASE, st),
                )
        self.process = self.env.process(self._dispatcher())
        return self.process

    def _dispatcher(self) -> Any:
        """The one SimPy process: steps 1-4 of each instant (docs/cpu-events.md; by calls)."""
        env = self.env
        timers, ready, seqs, totals = self._timers, self._ready, self._seq, self._totals
        heappush, heappop, heapreplace = heapq.heappush, heapq.heappop, heapq.heapreplace
        ovh, res, sliced = self.overhead, self._res_on, self.quantum is not None
        preempts, by_key, last_release = self.policy.preempts, self._by_key, self._last_release
        plain, jump, queue, inline_ok, book = self._modes()
        top: Top | None = None  # a job of the top task released at now, for step 3
        running: Job | None = None
        last: Job | None = None  # (the job that ran last: a switch to another costs overhead)
        run_end, now_lag, work_lag, run_lag, tol_next = _INF, 0.0, 0.0, 0.0, -_INF  # (time.md)
        piece_start = work_start = now = env.now
        while True:
            if now >= tol_next:  # the clock entered the next binade: a wider window
                tol, tol_next = coincidence(now)
                self._tol = tol
            limit = now + tol  # what is due by limit happens at now
            # 1. the running segment ends (run_end is finite only while a started one runs)
            if run_end <= limit:
                job: Job = running  # type: ignore[assignment]  # (run_end finite: a job runs)
                if plain:
                    worked = now - work_start
                    job.executed += worked
                    totals.busy += worked
                    job.rem = 0.0
                else:
                    self._close_piece(job, piece_start, work_start, now, done=True)
                piece_start = work_start = now
                run_end, work_lag = _INF, now_lag
                st = job._st
                if st.simple:
                    self._complete(job, now)
                    running = None
                elif st.plain_next[i := job.seg_index]:  # _segment_done without a hook
                    job.seg_index, job.rem = i + 1, None
                elif (hooks := st.hooked_next[i]) is not None:  # _segment_done, _continue:
                    for h in hooks:  # no calls but the hooks'
                        h(job, st.segs[i])
                    job.seg_index, job.rem, run_lag = i + 1, None, 0.0
                elif st.last_plain[i]:  # the job completes (_segment_done, _continue)
                    job.seg_index, job.rem = i + 1, None
                    self._complete(job, now)
                    running, run_lag = None, 0.0
                else:
                    running, run_end, run_lag = self._segment_ends(job, now, now_lag, work_lag)
            # 2. timers due (then t_next: the next timer)
            while (t_next := timers[0][0] if timers else _INF) <= limit:  # (t_next: kept)
                entry = timers[0]  # (popped below: a release's successor replaces it)
                st = entry[5]
                if entry[4] != _RELEASE or not st.fast_release:  # (popped by _on_timer)
                    if (kind := entry[4]) == _RELEASE or kind == _RESUME:  # (one call less: a
                        heappop(timers)  # release without the fast path, a suspension's end)
                        (self._release if kind == _RELEASE else self._resume)(st, now)
                    elif self._on_timer(
                        entry, running, now, now_lag, piece_start, work_start, work_lag
                    ):
                        running, run_end = None, _INF  # it left the CPU
                    continue
                k = st.k  # a release of a fixed period, finish-late, without hooks and jitter
                st.k = k + 1
                r, p = st.next_release, st.period
                nxt = st.first + (k + 1) * p
                if nxt < last_release:
                    st.next_release = nxt
                    heapreplace(timers, (nxt, st.rank, st.priority, st.index, _RELEASE, st))
                else:
                    heappop(timers)
                stats = st.stats
                stats.released += 1
                pending = st.pending
                if st.fast_top and inline_ok and not pending:  # its Job: see 3.
                    if stats.max_backlog < 1:
                        stats.max_backlog = 1
                    top = (st, k, r, next(seqs))
                    continue
                job = Job(st, k, r, r + st.deadline, p, next(seqs))
                pending.append(job)
                n = len(pending)
                if n > stats.max_backlog:
                    stats.max_backlog = n
                if n == 1:
                    heappush(ready, (job.key, job.tie, job))
            # 3. dispatch: the top task's job booked inline if it can be (rtsim.sim.inline)
            if (
                top is None
                or (
                    booked := book(
                        top, running, now, now_lag, work_start, work_lag, t_next, tol, tol_next
                    )
                )
                is None
            ):
                top = None
                if res:  # the resource protocol picks (rtsim.sim.resources), by calls
                    state = (running, last, piece_start, work_start, work_lag, run_end, run_lag)
                    state = self._res_dispatch(state, now, now_lag)
                    running, last, piece_start, work_start, work_lag, run_end, run_lag = state
                elif ready:  # the switch, inline on purpose (folding it with the
                    key = ready[0][0]  # one above, by calls, costs 3-4 % in bench_sim)
                    if running is None or (key < running.key if by_key else preempts(key, running)):
                        if running is not None:
                            self._preempt(running, now, now_lag, piece_start, work_start, work_lag)
                        running = heappop(ready)[2]
                        piece_start = work_start = now
                        work_lag = now_lag
                        if running is not last:
                            totals.switches += 1
                            last = running
                            work_start = now + ovh
                        if running.rem is not None:
                            x = running.rem + work_lag
                            run_end = work_start + x
                            y = run_end - work_start
                            run_lag = (work_start - (run_end - y)) + (x - y)
                if running is not None and running.rem is None:
                    c = running._st.seg_const[running.seg_index]
                    if c is not None:  # _start_segment without a hook or an exec-time call
                        if running.start is None:
                            running.start = now
                        running.seg_start = now
                        running.seg_exec = running.rem = c
                    else:
                        self._start_segment(running, now)
                    x = running.rem + work_lag  # type: ignore[operator]
                    run_end = work_start + x
                    y = run_end - work_start
                    run_lag = (work_start - (run_end - y)) + (x - y)
                    if run_end <= limit:
                        continue
            else:  # booked inline: the instant is settled, or the clock moved on (moved)
                moved, top, running, now, now_lag, work_start, work_lag, run_end, run_lag = booked
                piece_start, last = work_start, running
                if moved:
                    continue
                t_next = timers[0][0] if timers else _INF  # (the booking moved timers)
            if sliced and running is not self._slice_job:  # a new slice (rtsim.sim.slices)
                t_next = self._new_slice(running, now)
            target, now_lag = run_end, run_lag  # 4. wait (run_end: _INF when nothing runs)
            if t_next < target:  # (the next timer: timers move only in steps 1-2 and above)
                target, now_lag = t_next, 0.0
            if target == _INF:
                self._end_time = now
                return
            if jump and (not queue or target < queue[0][0]):  # nothing else is due up to
                env._now = now = target  # target: move the clock without a SimPy Timeout
                continue
            yield env.timeout(target - now if target > now else 0.0)
            now = target

    def _modes(self) -> tuple[bool, bool, list[Any], bool, Callable[..., Booked | None]]:
        """The dispatcher's set-up: (plain: no trace and no overhead, so progress is booked
        inline; jump: the clock can be moved without SimPy; SimPy's queue; inline_ok: top-task
        jobs may be booked inline; the function that books them, `rtsim.sim.inline`)."""
        env = self.env
        plain = not self.record_trace and self.overhead == 0.0
        has_abort = any(st.policy == "abort" for st in self._states)
        # Jump ahead without yielding when nothing else is scheduled before the wake-up
        # (only on the plain Environment: a RealtimeEnvironment must pace every step).
        jump = type(env) is simpy.Environment and isinstance(getattr(env, "_queue", None), list)
        queue: list[Any] = env._queue if jump else []  # type: ignore[attr-defined]
        # Inline jobs of the top task (docs/cpu-events.md; step 3): only without trace,
        # overhead, aborts and sections, and only when the clock can be moved without SimPy.
        inline_ok = plain and jump and not has_abort and not self._res_on
        record = self._top_record if self.record_jobs else None
        book = top_jobs(self, queue, self.policy.top_task_first, record)
        return plain, jump, queue, inline_ok, book

    def _segment_ends(
        self, job: Job, now: float, now_lag: float, work_lag: float
    ) -> tuple[Job | None, float, float]:
        """Step 1 in general: the segment of ``job`` ends at ``now`` (its resource unlocked,
        hooks, on to the next segment); (the job if it goes on to a CPU segment, the end of its
        work and that end's lag if it has work: an empty step an execution-time model gave
        work, docs/time.md; else _INF)."""
        if self._res_on and job._st.res[job.seg_index] is not None:
            self._unlock(job)
        self._lag = now_lag
        nxt = self._segment_done(job, now)
        self._lag = 0.0
        if nxt is not None and nxt.rem is not None:
            return nxt, *_end_of(now, nxt.rem, work_lag)
        return nxt, _INF, 0.0

    def _res_dispatch(self, state: tuple[Any, ...], now: float, now_lag: float) -> tuple[Any, ...]:
        """Step 3 under a resource protocol (docs/resources.md): the job `_res_pick` chooses
        gets the CPU (the dispatcher's switch, by calls), and a section that starts locks its
        resource. ``state``: the dispatcher's (running, last, piece_start, work_start,
        work_lag, run_end, run_lag), returned as it is after."""
        running, last, piece_start, work_start, work_lag, run_end, run_lag = state
        cand = self._res_pick(running, now)
        if cand is not None:
            if running is not None:
                self._preempt(running, now, now_lag, piece_start, work_start, work_lag)
            running = cand
            piece_start = work_start = now
            work_lag = now_lag
            if running is not last:
                self._totals.switches += 1
                last = running
                work_start = now + self.overhead
            if running.rem is not None:
                run_end, run_lag = _end_of(work_start, running.rem, work_lag)
        if (
            running is not None
            and running.rem is None
            and running._st.res[running.seg_index] is not None
        ):
            self._lock(running)
        return running, last, piece_start, work_start, work_lag, run_end, run_lag

    # -- the steps (internal) ------------------------------------------------------------
    def _on_timer(
        self,
        entry: tuple[Any, ...],
        running: Job | None,
        now: float,
        now_lag: float,
        piece_start: float,
        work_start: float,
        work_lag: float,
    ) -> bool:
        """A timer is due at ``now`` (step 2; popped here) that the dispatcher does not handle
        itself (releases and the ends of idle suspensions, `_release` and `_resume`, it calls):
        a jittered job is released, a time slice ends or a job is aborted at its deadline. True
        if ``running`` left the CPU."""
        heapq.heappop(self._timers)
        kind = entry[4]
        job = entry[5]
        if kind == _JREL:
            self._jittered_release(job, now)
        elif kind == _SLICE:  # (rtsim.sim.slices)
            return self._slice_ends(entry, running, now, now_lag, piece_start, work_start, work_lag)
        elif job.finish is None and not job.aborted:
            on_cpu = job is running
            if on_cpu:
                self._close_piece(job, piece_start, work_start, now, done=False)
            self._abort(job, now)
            return on_cpu
        return False

    def _preempt(
        self,
        job: Job,
        now: float,
        now_lag: float,
        piece_start: float,
        work_start: float,
        work_lag: float,
    ) -> None:
        """``job`` leaves the CPU at ``now`` and goes back into the ready heap: its progress
        booked (the rest of its work carrying the lag, docs/time.md), a preemption counted.
        (The dispatch of runs without sections does the same inline.)"""
        if job.rem is not None:
            self._close_piece(job, piece_start, work_start, now, done=False)
            if now > work_start:
                job.rem -= now_lag - work_lag
        job.preemptions += 1
        heapq.heappush(self._ready, (job.key, job.tie, job))

    def _close_piece(
        self, job: Job, piece_start: float, work_start: float, now: float, done: bool
    ) -> None:
        """Book the CPU time ``job`` got since it was dispatched (and trace it)."""
        if self.record_trace and work_start > piece_start and now > piece_start:
            self._trace_rows.append(
                (job.name, job.index, "switch", "overhead", True, piece_start, min(now, work_start))
            )
        if work_start > piece_start:
            self._totals.busy += min(now, work_start) - piece_start
        if now > work_start:
            worked = now - work_start
            job.executed += worked
            self._totals.busy += worked
            if self.record_trace:
                seg = job._st.segs[job.seg_index]
                self._trace_rows.append(
                    (job.name, job.index, seg.name, seg.kind, True, work_start, now)
                )
            if not done:
                job.rem = job.rem - worked  # type: ignore[operator]
        if done:
            job.rem = 0.0

    def _start_segment(self, job: Job, now: float) -> None:
        st = job._st
        i = job.seg_index
        seg = st.segs[i]
        if job.start is None:
            job.start = now
        job.seg_start = now
        for h in st.start_hooks[i]:
            h(job, seg)
        c = st.const_exec[i]
        if c is None:
            c = st.exec_fns[i](job, seg, st.rng)
            if type(c) is not float or not 0.0 <= c < _INF:  # (a finite float >= 0 as it is)
                if not isinstance(c, int | float) or not math.isfinite(c) or c < 0:
                    raise RtsimError(
                        f"task '{st.name}' segment '{seg.name}': execution time must "
                        f"be a non-negative number of ms, got {c!r}"
                    )
                c = float(c)
        job.seg_exec = c
        job.rem = c

    def _segment_done(self, job: Job, now: float) -> Job | None:
        """End the current segment; return the job if it goes on to a CPU segment."""
        st = job._st
        i = job.seg_index
        seg = st.segs[i]
        for h in st.end_hooks[i]:
            h(job, seg)
        job.seg_index, job.rem = i + 1, None
        if st.plain_next[i] or st.hooked_next[i] is not None:  # on to a CPU segment
            return job
        if st.idle_next[i]:  # into an idle suspension (`_continue` without its call)
            self._suspend(job, now)
            return None
        return self._continue(job, now)

    def _continue(self, job: Job, now: float) -> Job | None:
        """Move ``job`` to its current segment: complete it, suspend it, or return it.

        Empty steps past the chain's real end (``zero_tail``: no time, no resource) run here
        and then, at once: nothing released at this instant preempts them, so the job
        completes when its last real step ends, as the analyses count it."""
        st = job._st
        i = job.seg_index
        n = len(st.segs)
        started = False
        while i < n and st.zero_tail[i]:
            self._start_segment(job, now)
            if job.rem:  # an execution-time model gave it work: it runs as any segment
                started = True
                break
            for h in st.end_hooks[i]:
                h(job, st.segs[i])
            i = job.seg_index = i + 1
            job.rem = None
        if i >= n:
            self._complete(job, now)
            return None
        if st.idle_kind[i]:
            self._suspend(job, now, start=not started)
            return None
        return job

    def _suspend(self, job: Job, now: float, start: bool = True) -> None:
        """``job``'s current segment, an idle suspension, starts at ``now`` (``start`` False:
        started already); a timer resumes the job at its end (with the dispatcher's lag
        ``_lag``, docs/time.md)."""
        if start:
            self._start_segment(job, now)
        heapq.heappush(
            self._timers,
            (
                now + (job.rem + self._lag),  # type: ignore[operator]
                _RESUME,
                job.priority,
                next(self._seq),
                _RESUME,
                job,
            ),
        )

    def _resume(self, job: Job, now: float) -> None:
        """An idle-mode suspension ends: trace it, then the job is eligible again (if it was not
        aborted meanwhile)."""
        if job.aborted:
            return
        if self.record_trace and now > job.seg_start:  # type: ignore[operator]
            seg = job._st.segs[job.seg_index]
            self._trace_rows.append(
                (job.name, job.index, seg.name, seg.kind, False, job.seg_start, now)
            )
        job.rem = 0.0
        nxt = self._segment_done(job, now)
        if nxt is not None:
            if self.quantum is not None:  # back from a suspension (rtsim.sim.slices)
                self._requeue_resumed(nxt)
            heapq.heappush(self._ready, (nxt.key, nxt.tie, nxt))

    def _eligible(self, job: Job, now: float) -> None:
        """``job`` became the oldest pending job of its task (eligible once released)."""
        if job.held:
            return
        if job._st.idle_kind[0] and job.seg_index == 0 and job.rem is None:
            if self._continue(job, now) is None:
                return
        heapq.heappush(self._ready, (job.key, job.tie, job))

    def _release(self, st: _TaskState, now: float) -> None:
        """Release job k of ``st`` (a task without ``fast_release``: the dispatcher does those)."""
        k = st.k
        st.k = k + 1
        r = st.next_release
        if st.provider is None and not st.per_window:
            p, d = st.period, st.deadline
            nxt = st.first + (k + 1) * p
        else:
            if st.provider is not None:
                p = st.provider()
                if type(p) is not float or not 0.0 < p < _INF:  # (a finite float > 0 as it is)
                    if not isinstance(p, int | float) or not math.isfinite(p) or p <= 0:
                        raise RtsimError(
                            f"task '{st.name}': period provider returned {p!r} at "
                            f"t={now:g} ms; need a positive number of ms"
                        )
                    p = float(p)
                d = st.deadline / st.period * p
            else:
                w = self._w
                if w is None:
                    raise RtsimError(
                        f"task '{st.name}': released at t={now:g} ms before the first window "
                        "release"
                    )
                p, d = st.period * w, st.deadline * w
            # a period decided at each arrival: the arrival after job k is anchor + (k + 1 −
            # k_anchor)·p, the stream restarting (anchor = r, k_anchor = k) whenever p differs
            # from the period in force; a constant period therefore gives t0 + k·p exactly,
            # never a running sum (docs/cpu-events.md: Times)
            if p != st.stream_p:
                st.stream_p, st.stream_t, st.stream_k = p, r, k
            nxt = st.stream_t + (k + 1 - st.stream_k) * p
        if st.is_window:
            self._w = p
        if nxt < self._last_release:
            st.next_release = nxt
            heapq.heappush(self._timers, (nxt, st.rank, st.priority, next(self._seq), _RELEASE, st))
        stats = st.stats
        if st.policy == "skip" and st.pending:
            stats.skipped += 1
            stats.misses += 1
            if self.record_jobs:
                self._job_rows.append(
                    (
                        st.name,
                        k,
                        r,
                        math.nan,
                        math.nan,
                        math.nan,
                        r + d,
                        p,
                        True,
                        0,
                        False,
                        True,
                        0.0,
                        r,
                    )
                )
            return
        if st.jitter:
            self._jittered(st, k, r, d, p, now)
            return
        job = Job(st, k, r, r + d, p, next(self._seq))
        pending = st.pending
        pending.append(job)
        stats.released += 1
        if len(pending) > stats.max_backlog:
            stats.max_backlog = len(pending)
        if st.policy == "abort":
            heapq.heappush(self._timers, (r + d, _ABORT, st.priority, job.seq, _ABORT, job))
        for h in st.release_hooks:
            h(job)
        if len(pending) == 1:
            if st.idle_kind[0]:
                self._eligible(job, now)
            else:  # (_eligible of a job just released: it joins the ready heap)
                heapq.heappush(self._ready, (job.key, job.tie, job))

    def _jittered(self, st: _TaskState, k: int, r: float, d: float, p: float, now: float) -> None:
        """Job ``k`` arrives at ``r`` and is released after its drawn delay (docs/cpu-events.md)."""
        if self.jitter == "worst":
            delay = st.jitter if k == 0 else 0.0
        else:
            delay = float(st.jrng.uniform(0.0, st.jitter))  # type: ignore[union-attr]
        job = Job(st, k, r + delay, r + d, p, next(self._seq), arrival=r)
        stats = st.stats
        st.pending.append(job)
        stats.released += 1
        if len(st.pending) > stats.max_backlog:
            stats.max_backlog = len(st.pending)
        if st.policy == "abort":
            heapq.heappush(self._timers, (r + d, _ABORT, st.priority, job.seq, _ABORT, job))
        if delay > 0.0:
            job.held = True
            heapq.heappush(
                self._timers, (r + delay, st.rank, st.priority, next(self._seq), _JREL, job)
            )
        else:
            self._jittered_release(job, now)

    def _jittered_release(self, job: Job, now: float) -> None:
        """A jittered job is released: release hooks; eligible if it is its task's oldest."""
        if job.aborted:
            return
        job.held = False
        st = job._st
        for h in st.release_hooks:
            h(job)
        if st.pending and st.pending[0] is job:
            self._eligible(job, now)

    def _top_record(
        self, st: _TaskState, k: int, r: float, start: float, f: float, missed: bool
    ) -> None:
        """The job record of job ``k`` of the top task, booked inline (run from ``start`` to
        ``f``): the same floats as `_record` of its Job."""
        self._job_rows.append(
            (
                st.name,
                k,
                r,
                start,
                f,
                f - r,
                r + st.deadline,
                st.period,
                missed,
                0,
                False,
                False,
                0.0 + (f - start),
                r,
            )
        )

    def _record(self, job: Job, missed: bool) -> None:
        resp = math.nan if job.finish is None else job.finish - job.arrival
        self._job_rows.append(
            (
                job.name,
                job.index,
                job.release,
                math.nan if job.start is None else job.start,
                math.nan if job.finish is None else job.finish,
                resp,
                job.deadline,
                job.period,
                missed,
                job.preemptions,
                job.aborted,
                False,
                job.executed,
                job.arrival,
            )
        )

    def _count_response(
        self, stats: TaskStats, resp: float, rel_deadline: float
    ) -> tuple[int, dict[int, int]]:
        """Count ``resp`` in the task's histogram (made on first use: ``hist_bin`` or a
        hundredth of the relative deadline wide); returns its bin and the counts."""
        hist = stats.histogram
        if hist is None:
            hist = stats.histogram = ResponseHistogram(self.hist_bin or rel_deadline / 100.0)
        i = int(resp / hist.bin_width)
        counts = hist.counts
        counts[i] = counts.get(i, 0) + 1
        return i, counts

    def _complete(self, job: Job, now: float) -> None:
        st = job._st
        stats = st.stats
        job.finish = now
        resp = now - job.arrival
        stats.completed += 1
        stats.sum_response += resp
        if stats.max_response is None or resp > stats.max_response:
            stats.max_response = resp
        if now > job.deadline + self._tol:  # (a comparison the interpreter specializes in a jump)
            missed = True
            stats.misses += 1
        else:
            missed = False
        stats.preemptions += job.preemptions
        self._count_response(stats, resp, job.deadline - job.arrival)
        if self.record_jobs:
            self._record(job, missed)
        pending = st.pending
        if pending[0] is job:  # (_retire of its task's oldest job, without its call)
            pending.popleft()
            for h in st.job_end_hooks:
                h(job)
            if pending:
                self._eligible(pending[0], now)
        else:
            self._retire(job, now)

    def _abort(self, job: Job, now: float) -> None:
        st = job._st
        i = job.seg_index
        if (
            self.record_trace
            and i < len(st.segs)
            and st.idle_kind[i]
            and job.rem is not None
            and job.seg_start is not None
            and now > job.seg_start
        ):
            # aborted while suspended (idle mode): trace the partial suspension
            seg = st.segs[i]
            self._trace_rows.append(
                (job.name, job.index, seg.name, seg.kind, False, job.seg_start, now)
            )
        if self._res_on:
            self._unlock(job)
            if job in self._blocked:
                self._unblock(job, now)
        job.aborted = True
        if any(e[2] is job for e in self._ready):  # it leaves the ready heap at once
            self._ready[:] = [e for e in self._ready if e[2] is not job]
            heapq.heapify(self._ready)
        st.stats.aborted += 1
        st.stats.misses += 1
        st.stats.preemptions += job.preemptions
        if self.record_jobs:
            self._record(job, True)
        self._retire(job, now)

    def _retire(self, job: Job, now: float) -> None:
        """Remove a finished or aborted job; its task's next pending job becomes eligible."""
        st = job._st
        head = st.pending[0] is job
        st.pending.remove(job)
        for h in st.job_end_hooks:
            h(job)
        if head and st.pending:
            self._eligible(st.pending[0], now)

    # -- results -------------------------------------------------------------------------
    def result(self, window: dict[str, Any] | None = None) -> SimResult:
        """Statistics (and job table / trace if recorded) of the run so far; with a job sink
        the records left are flushed to it and ``jobs`` is None."""
        self._job_rows.flush()
        if self.trace_sink is not None:
            self._trace_rows.flush()  # type: ignore[attr-defined]
        return SimResult(
            tasks={st.name: st.stats for st in sorted(self._states, key=lambda x: x.priority)},
            horizon=self._horizon if self._horizon is not None else 0.0,
            seed=self.seed,
            suspension=self.suspension,
            exec_model=self.exec_model_name,
            overhead=self.overhead,
            end_time=self._end_time,
            busy_time=self._totals.busy,
            context_switches=self._totals.switches,
            window=window,
            jitter=self.jitter,
            scheduler=self.policy.name or type(self.policy).__name__,
            resources=self.protocol,
            blocking=dict(self.blocking) if self.protocol is not None else None,
            jobs=self._job_rows.frame() if self.record_jobs and self.job_sink is None else None,
            trace=trace_frame(self._trace_rows)
            if self.record_trace and self.trace_sink is None
            else None,
        )
