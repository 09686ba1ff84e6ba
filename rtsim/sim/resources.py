"""The resource protocols of the virtual CPU (``pcp``, ``srp``, ``npr``): a room of it.

A task's critical sections are segments of its chain marked with a ``resource``
(docs/resources.md). When some task has one, the dispatcher (`rtsim.sim.cpu`) asks
`ResourceProtocols._res_pick` which job takes the CPU, locks a section's resource when
the section starts and unlocks it when it ends (or its job is aborted); a set without
sections never calls in here. The rules (docs/cpu-events.md: Shared resources): each job
has a preemption level (−priority, or −relative deadline under a deadline-ordered policy),
each resource a ceiling (the highest level of its users; +inf under ``npr``), the system
ceiling is the highest ceiling of the resources held; a job runs if it holds a resource,
or if its level is above the system ceiling and — when it has not started yet — it comes
first among the active jobs (Baker's start rule). Jobs passed over that come before the job
that runs are blocked (traced, and counted in ``blocking``).
"""

from __future__ import annotations

import heapq
import math
from typing import Any

from rtsim.errors import InputError, RtsimError
from rtsim.sim.job import Job, _TaskState
from rtsim.sim.policy import SchedulingPolicy

__all__ = ["ResourceProtocols"]

_INF = math.inf


class ResourceProtocols:
    """The CPU's resource protocols (module doc); a mixin of `rtsim.sim.cpu.CPU`."""

    policy: SchedulingPolicy
    resources: str | None
    record_trace: bool
    _by_key: bool
    _states: list[_TaskState]
    _ready: list[tuple[Any, Any, Job]]
    _trace_rows: list[tuple[Any, ...]]

    def _init_resources(self) -> None:
        self._res_on = False  # only if a task has a critical section
        self.protocol: str | None = None  # the protocol in force once started
        self._ceil: dict[str, float] = {}
        self._locked: dict[str, Job] = {}  # resource -> the job holding it
        self._holding: dict[Job, tuple[str, float]] = {}  # job -> (resource, its ceiling)
        self._blocked: dict[Job, tuple[float, str]] = {}  # job -> (blocked since, by what)
        self._level_by = getattr(self.policy, "resource_levels", "priority")
        #: per task, the longest time one job was blocked (ms; tasks that never were: absent)
        self.blocking: dict[str, float] = {}

    def _compile_resources(self) -> None:
        """Ceilings of the resources (module doc); a task with a critical
        section takes the general path: its sections start and end with a lock and unlock."""
        users: dict[str, list[_TaskState]] = {}
        for st in self._states:
            st.res = [s.resource for s in st.segs]
            for r in st.res:
                if r is not None and st not in users.setdefault(r, []):
                    users[r].append(st)
        self._res_on = bool(users)
        if not users:
            return
        by = self._level_by
        protocol = self.resources or ("srp" if by == "deadline" else "pcp")
        if protocol == "pcp" and by == "deadline":
            raise InputError(
                f"resources: pcp needs fixed priorities; under "
                f"{self.policy.name or type(self.policy).__name__} use srp or npr"
            )
        self.protocol = protocol
        for r, sts in users.items():
            if protocol == "npr":
                self._ceil[r] = _INF
                continue
            lv = []
            for st in sts:
                if by == "deadline" and (st.provider is not None or st.per_window or st.is_window):
                    raise InputError(
                        f"task '{st.name}': a critical section under a "
                        f"deadline-ordered policy needs a deadline in ms (not "
                        f"one that follows the window)"
                    )
                lv.append(-float(st.deadline) if by == "deadline" else -float(st.priority))
            self._ceil[r] = max(lv)
        for st in self._states:
            if any(r is not None for r in st.res):
                st.simple = False
                st.fast_start = None
                st.fast_top = False
                for i, r in enumerate(st.res):
                    if r is not None:
                        st.seg_const[i] = None
                        st.plain_next[i] = False
                        st.hooked_next[i] = None
                        st.last_plain[i] = False

    def _level(self, job: Job) -> float:
        """The job's preemption level (larger = higher): −priority, or −relative deadline."""
        if self._level_by == "deadline":
            st = job._st
            if st.provider is not None or st.per_window or st.is_window:
                return -(job.deadline - job.arrival)  # the deadline in force at its arrival
            return -float(st.deadline)  # exactly as the ceilings count it
        return -float(job.priority)

    def _lock(self, job: Job) -> None:
        r = job._st.res[job.seg_index]
        assert r is not None
        if r in self._locked:  # the ceiling rule makes this impossible
            raise RtsimError(
                f"task '{job.name}': resource '{r}' is held by "
                f"'{self._locked[r].name}' (a ceiling violation)"
            )
        self._locked[r] = job
        self._holding[job] = (r, self._ceil[r])

    def _unlock(self, job: Job) -> None:
        held = self._holding.pop(job, None)
        if held is not None:
            del self._locked[held[0]]

    def _res_pick(self, running: Job | None, now: float) -> Job | None:
        """The job that takes the CPU under the resource protocol (removed from the ready
        heap), or None: the first eligible job in the policy's order that holds a resource,
        or whose level is above the system ceiling and, if it has not started yet, comes
        before every job passed over (Baker's start rule: a job starts only when it is first
        among the active jobs and above the ceiling) — if it preempts ``running``. Jobs
        passed over that come before the job that runs are blocked (traced)."""
        ready = self._ready
        hold = self._holding
        ceiling = max(c for _, c in hold.values()) if hold else -_INF
        skipped: list[tuple[Any, Any, Job]] = []
        while ready:
            job = ready[0][2]
            if job.aborted:
                heapq.heappop(ready)
                continue
            if job in hold or (
                self._level(job) > ceiling and (not skipped or job.start is not None)
            ):
                break
            skipped.append(heapq.heappop(ready))
        cand = ready[0][2] if ready else None
        if (
            cand is not None
            and running is not None
            and not (
                cand.key < running.key if self._by_key else self.policy.preempts(cand.key, running)
            )
        ):
            cand = None
        if cand is not None:
            heapq.heappop(ready)
        for e in skipped:
            heapq.heappush(ready, e)
        run = cand if cand is not None else running
        blocked = self._blocked
        now_blocked = [
            e[2] for e in skipped if run is not None and (e[0], e[1]) < (run.key, run.tie)
        ]
        for job in [j for j in blocked if j not in now_blocked]:
            self._unblock(job, now)
        if now_blocked:
            by = ""
            if hold:
                holder, (r, _) = max(hold.items(), key=lambda kv: kv[1][1])
                by = f" by {holder.name} on {r}"
            for job in now_blocked:
                if job not in blocked:
                    blocked[job] = (now, f"blocked{by}")
        return cand

    def _unblock(self, job: Job, now: float) -> None:
        since, what = self._blocked.pop(job)
        if now > since:
            total = getattr(job, "blocked", 0.0) + (now - since)
            job.blocked = total
            if total > self.blocking.get(job.name, 0.0):
                self.blocking[job.name] = total
            if self.record_trace:
                self._trace_rows.append((job.name, job.index, what, "blocked", False, since, now))
