"""The CPU books jobs of the top task inline (no Job object, one dispatcher step) when nothing
else happens while they run. That must be unobservable: a run with the inline path and the
same run with it switched off (a no-op job-end hook on the top task disables it) give
bit-identical job tables, statistics, hook calls (order, times, job fields) and probes of a
second SimPy process; and the inline path must actually be taken."""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import pandas as pd
import pytest
import simpy
from hypothesis import given, settings
from hypothesis import strategies as st

from rtsim.model.task import Segment, Task
from rtsim.sim import CPU


@dataclass
class Spec:
    top: Task
    others: list[Task]
    window: Task | None
    periods: list[float]
    per_window: Task | None
    fracs: list[float]
    horizon: float
    mode: str
    probes: list[float]


@st.composite
def specs(draw: st.DrawFn) -> Spec:
    period = float(draw(st.integers(4, 40)))
    top = Task(
        "top",
        draw(st.sampled_from([0.5, 1.0, 2.0, 5.0, 3.3])),
        period,
        priority=1,
        offset=draw(st.floats(0, period, exclude_max=True)) if draw(st.booleans()) else 0.0,
    )
    others = []
    for k in range(draw(st.integers(0, 3))):
        segs = tuple(
            Segment(
                f"s{i}",
                draw(st.sampled_from([0.5, 1.0, 1.5, 2.0, 3.0, 4.5, 0.1])),
                draw(st.sampled_from(["compute", "compute", "suspend"])),
            )
            for i in range(draw(st.integers(1, 3)))
        )
        p = float(draw(st.integers(4, 30))) + draw(st.sampled_from([0.0, 0.1, 1 / 3]))
        others.append(
            Task(
                f"t{k}",
                sum(s.wcet for s in segs),
                p,
                priority=k + 3,
                offset=draw(st.floats(0, p, exclude_max=True)),
                segments=segs,
                overload=draw(st.sampled_from(["finish-late", "finish-late", "skip", "abort"])),
            )
        )
    window = per_window = None
    periods: list[float] = []
    if draw(st.booleans()):
        segs = (Segment("scan", 3.0), Segment("radio", 4.0, "suspend"), Segment("recv", 1.0))
        window = Task("win", 8.0, 10.0, priority=2, segments=segs)
        periods = draw(
            st.lists(st.sampled_from([10.0, 12.0, 15.5, 40.0, 7.0]), min_size=1, max_size=4)
        )
        if draw(st.booleans()):
            per_window = Task("lp", 2.5, 2.0, priority=99, per_window=True)
    fracs = draw(
        st.lists(st.sampled_from([0.0, 0.25, 0.5, 1.0]) | st.floats(0, 1), min_size=1, max_size=5)
    )
    probes = draw(st.lists(st.floats(0, 150), max_size=4))
    return Spec(
        top,
        others,
        window,
        periods,
        per_window,
        fracs,
        float(draw(st.integers(20, 150))),
        draw(st.sampled_from(["cpu", "idle"])),
        probes,
    )


def run(spec: Spec, inline: bool, scheduler: str = "fp", hooks: bool = True) -> dict[str, Any]:
    env = simpy.Environment()
    cpu = CPU(
        env,
        suspension=spec.mode,
        record_jobs=True,  # type: ignore[arg-type]
        scheduler=scheduler,
    )
    cpu.add_task(spec.top)
    if spec.window is not None:
        cyc = itertools.cycle(spec.periods)
        cpu.add_task(spec.window, period_provider=lambda: next(cyc), window=True)
    if spec.per_window is not None:
        cpu.add_task(spec.per_window)
    for t in spec.others:
        cpu.add_task(t)
    log: list[tuple[Any, ...]] = []

    def seg_hook(event: str):  # noqa: ANN202
        def h(job, seg) -> None:  # noqa: ANN001
            log.append(
                (
                    event,
                    job.name,
                    job.index,
                    seg.name,
                    env.now,
                    job.start,
                    job.seg_start,
                    job.rem,
                    job.executed,
                    job.preemptions,
                    cpu.stats("top").completed,
                    cpu.stats("top").sum_response,
                )
            )

        return h

    def job_hook(event: str):  # noqa: ANN202
        def h(job) -> None:  # noqa: ANN001
            log.append(
                (
                    event,
                    job.name,
                    job.index,
                    env.now,
                    job.executed,
                    job.preemptions,
                    cpu.window,
                    cpu.stats("top").completed,
                )
            )

        return h

    # hooks on every task but the top one (a hook on it switches the inline path off); none
    # and constant execution times: the jobs after the top task's may end inside a run too
    names = [t.name for t in (spec.window, spec.per_window, *spec.others) if t is not None]
    if not hooks:
        names = []
    for name in names:
        for ev in ("segment_start", "segment_end"):
            cpu.on(ev, seg_hook(ev), task=name)  # type: ignore[arg-type]
        for ev in ("release", "job_end"):
            cpu.on(ev, job_hook(ev), task=name)  # type: ignore[arg-type]
    for t in spec.others if hooks else ():
        for i, s in enumerate(t.segments):

            def fn(job, seg, rng, i=i, t=t) -> float:  # noqa: ANN001
                frac = spec.fracs[(job.index * 3 + i + 5 * int(t.name[1:])) % len(spec.fracs)]
                return seg.wcet * frac

            cpu.set_exec_time(t.name, s.name, fn)
    if not inline:
        cpu.on("job_end", lambda job: None, task="top")

    def prober() -> Any:
        last = 0.0
        for t in sorted(spec.probes):
            yield env.timeout(t - last)
            last = t
            log.append(
                (
                    "probe",
                    env.now,
                    cpu.stats("top").completed,
                    cpu.stats("top").sum_response,
                    cpu.result().busy_time,
                )
            )

    env.process(prober())
    proc = cpu.start(spec.horizon)
    env.run(until=proc)
    res = cpu.result()
    return {
        "jobs": res.jobs,
        "log": log,
        "stats": [
            (s.as_dict(), s.histogram.as_dict() if s.histogram else None)
            for s in res.tasks.values()
        ],
        "facts": (res.busy_time, res.context_switches, res.end_time, env.now),
    }


def assert_same(a: dict[str, Any], b: dict[str, Any]) -> None:
    pd.testing.assert_frame_equal(a["jobs"], b["jobs"], check_exact=True)
    assert a["stats"] == b["stats"]
    assert a["facts"] == b["facts"]  # exact floats
    assert len(a["log"]) == len(b["log"])
    for x, y in zip(a["log"], b["log"], strict=True):
        assert x == y or all(
            u == v or (isinstance(u, float) and math.isnan(u) and math.isnan(v))
            for u, v in zip(x, y, strict=True)
        ), (x, y)


@settings(max_examples=100, deadline=None)
@given(specs())
def test_inline_top_jobs_are_unobservable(spec: Spec) -> None:
    assert_same(run(spec, inline=True), run(spec, inline=False))


@settings(max_examples=100, deadline=None)
@given(specs())
def test_inline_top_jobs_are_unobservable_under_edf(spec: Spec) -> None:
    """Under EDF the top task's job is booked inline only when it comes first (its deadline,
    then creation order) and preempts; the job after it is the first of the others."""
    assert_same(run(spec, inline=True, scheduler="edf"), run(spec, inline=False, scheduler="edf"))


@st.composite
def plain_specs(draw: st.DrawFn) -> Spec:
    """Sets of one-segment tasks of constant time below the top task, periods long beside
    its: the jobs after the top task's end inside runs of inline jobs."""
    period = float(draw(st.sampled_from([4, 5, 8, 10, 40])))
    top = Task("top", draw(st.sampled_from([0.5, 1.0, 1.5, 3.3])), period, priority=1)
    others = []
    for k in range(draw(st.integers(1, 3))):
        p = period * draw(st.integers(2, 12)) + draw(st.sampled_from([0.0, 0.0, 0.1, 1 / 3]))
        c = p * draw(st.sampled_from([0.05, 0.1, 0.2, 0.3])) + draw(st.sampled_from([0.0, 0.7]))
        others.append(
            Task(
                f"t{k}",
                c,
                p,
                priority=k + 3,
                offset=draw(st.sampled_from([0.0, 0.0, p / 3, 2.5])),
                overload=draw(st.sampled_from(["finish-late", "finish-late", "skip"])),
            )
        )
    probes = draw(st.lists(st.floats(0, 300), max_size=2))
    h = float(draw(st.integers(100, 2000)))
    mode = draw(st.sampled_from(["cpu", "idle"]))
    return Spec(top, others, None, [], None, [1.0], h, mode, probes)


@settings(max_examples=100, deadline=None)
@given(st.one_of(specs(), plain_specs()), st.sampled_from(["fp", "edf"]))
def test_inline_runs_across_the_jobs_after_are_unobservable(spec: Spec, scheduler: str) -> None:
    """Without hooks and with constant execution times, a run of inline jobs also ends the job
    after the top task's (a simple one) and gives the CPU to the next (steps 1 and 3)."""
    assert_same(
        run(spec, inline=True, scheduler=scheduler, hooks=False),
        run(spec, inline=False, scheduler=scheduler, hooks=False),
    )


def test_inline_path_is_taken_and_exact(monkeypatch: pytest.MonkeyPatch) -> None:
    calls = []
    orig = CPU._top_record  # called once per job booked inline (run() records the jobs)

    def counting(self, *args):  # noqa: ANN001, ANN202
        calls.append(args)
        return orig(self, *args)

    monkeypatch.setattr(CPU, "_top_record", counting)
    # the paper's set at w = 240: dead reckoning (5, 40) above the window chain, T_lp below
    spec = Spec(
        Task("top", 5.0, 40.0, priority=1),
        [Task("t0", 25.0, 480.0, priority=3)],
        Task(
            "win",
            182.3,
            240.0,
            priority=2,
            segments=(
                Segment("scan", 106.0),
                Segment("hough", 7.3),
                Segment("radio", 67.0, "suspend"),
                Segment("recv", 2.0),
            ),
        ),
        [240.0, 236.7, 251.1],
        None,
        [1.0, 0.7],
        5000.0,
        "idle",
        [13.0, 333.3],
    )
    a = run(spec, inline=True)
    n_inline = len(calls)
    b = run(spec, inline=False)
    assert len(calls) == n_inline  # the no-op hook switches the inline path off
    assert_same(a, b)
    top = a["jobs"][a["jobs"]["task"] == "top"]
    assert len(top) == 125
    assert n_inline > len(top) // 2  # most dead-reckoning jobs run inline
    # under EDF too, where the dead-reckoning job comes first (its deadline is 40 ms away)
    calls.clear()
    a = run(spec, inline=True, scheduler="edf")
    n_edf = len(calls)
    b = run(spec, inline=False, scheduler="edf")
    assert len(calls) == n_edf
    assert_same(a, b)
    assert n_edf > 10
    # hand check: job 1 is released at 40 and runs 40..45 alone (the scan runs 0+5..111)
    row = top[top["job"] == 1].iloc[0]
    assert (row["start"], row["finish"], row["response"], row["exec_time"]) == (
        40.0,
        45.0,
        5.0,
        5.0,
    )


def _through_calls(monkeypatch: pytest.MonkeyPatch) -> None:
    """Switch off the dispatcher's direct segment ends (a segment's end hooks before a CPU
    segment, the last segment's end without hooks): every such end goes through
    `CPU._segment_ends`, as before they existed."""
    orig = CPU._compile

    def compile_(self: CPU) -> None:
        orig(self)
        for s in self._states:
            s.hooked_next = [None] * len(s.segs)
            s.last_plain = [False] * len(s.segs)

    monkeypatch.setattr(CPU, "_compile", compile_)


@settings(max_examples=100, deadline=None)
@given(st.one_of(specs(), plain_specs()), st.sampled_from(["fp", "edf"]), st.booleans())
def test_direct_segment_ends_are_unobservable(spec: Spec, scheduler: str, hooks: bool) -> None:
    """The dispatcher ends a segment whose end hooks come before a CPU segment, and the last
    segment of a job without end hooks, in its loop (no `_segment_ends` call): the same job
    tables, statistics, hook calls and probes as through the calls."""
    a = run(spec, inline=True, scheduler=scheduler, hooks=hooks)
    with pytest.MonkeyPatch.context() as mp:
        _through_calls(mp)
        b = run(spec, inline=True, scheduler=scheduler, hooks=hooks)
    assert_same(a, b)


def test_direct_segment_ends_are_taken(monkeypatch: pytest.MonkeyPatch) -> None:
    """A segment whose end hooks come before a CPU segment ends in the dispatcher's loop:
    with hooks on every segment's end, of a chain of three only the last one's end (hooks,
    then the job's completion) goes through `_segment_ends`."""
    calls = []
    orig = CPU._segment_ends

    def counting(self, *args):  # noqa: ANN001, ANN202
        calls.append(args)
        return orig(self, *args)

    monkeypatch.setattr(CPU, "_segment_ends", counting)
    segs = (Segment("scan", 3.0), Segment("send", 1.0), Segment("recv", 1.0))
    spec = Spec(
        Task("top", 1.0, 7.0, priority=1),
        [],
        Task("win", 5.0, 10.0, priority=2, segments=segs),
        [10.0],
        None,
        [1.0],
        100.0,
        "cpu",
        [],
    )
    counts, outs = [], []
    for through in (False, True):
        if through:
            _through_calls(monkeypatch)
        for hooks in (True, False):
            calls.clear()
            outs.append(run(spec, inline=True, hooks=hooks))
            counts.append(len(calls))
    assert_same(outs[0], outs[2])
    assert_same(outs[1], outs[3])
    jobs = counts[2] // 3  # (through the calls, with hooks: every segment's end, 3 a job)
    assert jobs > 0
    # with hooks, scan's and send's ends are made in the loop; without, the last one's too
    assert counts == [jobs, 0, 3 * jobs, jobs]
