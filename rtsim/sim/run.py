"""High-level runs: a task set on the virtual CPU, with a fixed or dynamic processing window.

[`build_cpu`][rtsim.sim.run.build_cpu] puts a [`TaskSet`][rtsim.model.taskset.TaskSet] on a
[`CPU`][rtsim.sim.cpu.CPU]
(in a given SimPy environment, so that a coupling layer can run its world processes beside
it); [`simulate`][rtsim.sim.run.simulate] builds, runs to completion and returns the
[`SimResult`][rtsim.sim.run.SimResult].

For a set with a ``[window]`` the chain T_w becomes the window task (``ts.window_task``),
whose period and deadline are the w in force: ``window`` is a float (fixed w), a callable
(a period provider called at each window release) or None (the analytic w_sch,
docs/model/lower-bound.md).
Tasks with a per-window period (the command task's 2w) take multiples of the w in force at
their release.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import Any, Literal

import numpy as np
import simpy

from rtsim._numbers import is_real
from rtsim.analysis.sufficient import as_taskset, w_sch_of, window_or_w_sch
from rtsim.errors import InputError
from rtsim.io.limits import check
from rtsim.io.work import check_seed, check_simulate
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim.cpu import CPU, JitterMode
from rtsim.sim.execution import ExecSpec
from rtsim.sim.policy import PolicySpec, resolve_scheduler
from rtsim.sim.progress import TICKS, Progress, start_ticker
from rtsim.sim.records import SimResult

__all__ = ["simulate", "build_cpu", "resolve_window", "worst_jitter_shifts", "WindowArg"]

#: ``window=`` of [`simulate`][rtsim.sim.run.simulate]: fixed w (ms), a period provider, or None for
#: w_sch.
WindowArg = float | Callable[[], float] | None


def _as_taskset(ts: TaskSet | Sequence[Task]) -> TaskSet:
    """A TaskSet, or one of a list of tasks; a file is read above the simulator
    (`rtsim.load_taskset`, or the facade's [`rtsim.simulate`][rtsim.simulate], which takes a
    path)."""
    if isinstance(ts, TaskSet | str | os.PathLike):
        return as_taskset(ts, "simulate")
    if not isinstance(ts, Sequence) or not all(isinstance(t, Task) for t in ts):
        raise InputError(
            f"simulate: expected a TaskSet, a list of Tasks or the path of a "
            f"task-set file, got {type(ts).__name__}"
        )
    return TaskSet(tuple(ts))


def _window_estimate(ts: TaskSet, window: WindowArg) -> float | None:
    """The window a run of ``ts`` would use, for the work estimate (None: unknown)."""
    if ts.window is None:
        return None
    if is_real(window):
        return float(window)  # type: ignore[arg-type]
    try:
        w = w_sch_of(ts)  # (only w_sch: the other bounds, w_edf's QPA, can take long)
    except (InputError, ValueError, ArithmeticError):
        return None
    return w if math.isfinite(w) and w > 0 else None


def resolve_window(ts: TaskSet, window: WindowArg) -> tuple[Callable[[], float], dict[str, Any]]:
    """The window provider for ``ts`` and a description of it (for results and manifests)."""
    if window is None:
        w = window_or_w_sch(ts)
        return (lambda: w), {"mode": "w_sch", "w": w}
    if callable(window):
        return window, {"mode": "dynamic"}
    if not is_real(window) or not math.isfinite(window) or window <= 0:
        raise InputError(f"window must be a positive number of ms, got {window!r}")
    w = float(window)
    return (lambda: w), {"mode": "fixed", "w": w}


def worst_jitter_shifts(ts: TaskSet) -> tuple[dict[str, float], list[str]]:
    """Where ``jitter="worst"`` puts the per-window tasks of ``ts``, and which it cannot move.

    The critical instant (`rtsim.sim.cpu`) shifts every task's arrivals by
    max_j J_j − J_i, so a per-window task (period m·w) would arrive J_w − J_i after the
    window's arrivals, past its own offset Φ_i. It cannot arrive before the window's first
    arrival (its period is decided there), so its shift is max(J_w − J_i, −Φ_i).
    Returns the shifts (ms, per-window tasks, against their offsets from the window's
    arrivals: the ``shifts`` of `rtsim.analysis.transaction.transactions_of`) and the
    names of the tasks whose first release therefore misses the critical instant."""
    if ts.window is None:
        return {}, []
    jw = ts.window.jitter
    shifts: dict[str, float] = {}
    late: list[str] = []
    for t in ts.tasks:
        if not t.per_window:
            continue
        shifts[t.name] = max(jw - t.jitter, -t.offset)
        if jw - t.jitter < -t.offset:
            late.append(t.name)
    return shifts, late


def build_cpu(
    ts: TaskSet | Sequence[Task],
    *,
    env: simpy.Environment | None = None,
    window: WindowArg = None,
    **cpu_kwargs: Any,
) -> tuple[CPU, dict[str, Any] | None]:
    """A [`CPU`][rtsim.sim.run.CPU] loaded with the tasks of ``ts`` (and its window chain), not
    started.

    Returns the CPU and the window description (None for a set without a window).
    ``cpu_kwargs`` go to [`CPU`][rtsim.sim.run.CPU] (suspension, exec_model, seed, overhead,
    record_jobs, record_trace, hist_bin, jitter, job_sink, trace_sink, scheduler, resources,
    quantum; the scheduler, the resource protocol and a time-sliced policy's quantum default
    to the set's).
    """
    ts = _as_taskset(ts)
    cpu_kwargs.setdefault("scheduler", ts.scheduler)
    cpu_kwargs.setdefault("resources", ts.resources)
    if ts.quantum is not None and cpu_kwargs.get("quantum") is None:
        policy = resolve_scheduler(cpu_kwargs["scheduler"])
        if policy.takes_quantum and policy.quantum is None:  # the set's time slice
            cpu_kwargs["quantum"] = ts.quantum
    cpu = CPU(env, **cpu_kwargs)
    info: dict[str, Any] | None = None
    if ts.window is not None:
        provider, info = resolve_window(ts, window)
        cpu.add_task(ts.window_task(1.0), period_provider=provider, window=True)
    elif window is not None:
        raise InputError(
            f"{ts.source or ts.name or 'task set'}: has no [window], so a window does not apply"
        )
    worst = worst_jitter_shifts(ts)[0] if cpu_kwargs.get("jitter") == "worst" else {}
    for task in ts.tasks:
        if task.per_window and ts.window is not None:
            # a per-window task counts its offset from the window stream's first arrival;
            # under jitter "worst" it cannot arrive before it (worst_jitter_shifts): the CPU
            # moves it by J_w - J_i against the window, the rest is added here
            extra = worst[task.name] - (ts.window.jitter - task.jitter) if worst else 0.0
            if ts.window.offset or extra:
                task = replace(task, offset=task.offset + ts.window.offset + extra)
        cpu.add_task(task)
    return cpu, info


def simulate(
    ts: TaskSet | Sequence[Task],
    horizon: float,
    *,
    seed: int | np.random.SeedSequence | np.random.Generator | None = 0,
    exec_model: ExecSpec = "wcet",
    suspension: Literal["cpu", "idle"] = "cpu",
    window: WindowArg = None,
    record_jobs: bool = False,
    record_trace: bool = False,
    overhead: float | None = None,
    hist_bin: float | None = None,
    env: simpy.Environment | None = None,
    jitter: JitterMode = "random",
    job_sink: Callable[[Any], None] | Any = None,
    scheduler: PolicySpec | None = None,
    force: bool = False,
    progress: Progress | None = None,
    trace_sink: Any = None,
) -> SimResult:
    """Simulate ``ts`` for jobs released in [0, horizon) ms until they complete or abort.

    Example: ``simulate(load_taskset(), 60_000, window=250.0, record_jobs=True).jobs``.
    ``overhead`` defaults to the set's (0 for a list of tasks). ``jitter``: release delays
    of tasks with a jitter, ``random``/``worst``/``none`` (`rtsim.sim.cpu`).
    ``job_sink``: a callable that receives the job records as DataFrame chunks during the
    run, or a `rtsim.io.columns.ChunkWriter` that formats them without a DataFrame
    (implies ``record_jobs``; ``result.jobs`` is then None) — memory stays flat for a
    long horizon (`rtsim.sim.records.RowBuffer`). ``trace_sink``: the same for the
    execution trace (implies ``record_trace``; ``result.trace`` is then None).
    ``scheduler``: the scheduling policy (`rtsim.sim.policy`), default the set's
    (``[scheduler] policy``; ``fp`` for a list of tasks).
    The work limits of the command line apply (`rtsim.io.work`: at most 5e7 jobs, and
    1e6 jobs waiting at once on an overloaded CPU); ``force=True`` is ``--force``. A seed
    outside [0, 2**63) is refused as ``--seed`` is. ``progress(share, t_ms)`` is called at
    every percent of the horizon (`rtsim.sim.progress`; the results do not change).
    """
    ts = _as_taskset(ts)
    if overhead is None:
        overhead = ts.overhead
    # a bool is not a number (True would run 1 ms): refused here, as the options are
    for name, value in (("horizon", horizon), ("overhead", overhead), ("hist_bin", hist_bin)):
        if not is_real(value) and not (name == "hist_bin" and value is None):
            raise InputError(f"simulate: {name} must be a number of ms, got {value!r}")
    horizon = float(horizon) if is_real(horizon) else horizon  # numpy scalars too

    check("option: --horizon", horizon, "simulate: horizon", magnitude_only=True)  # <= 11.6 d

    if isinstance(seed, int) and seed >= 0:  # (a negative seed: build_cpu's message)
        check_seed(seed, "simulate: seed")
    if is_real(horizon) and 0 < horizon < math.inf:  # (others: build_cpu's message)
        check_simulate(
            ts, horizon, _window_estimate(ts, window), f"simulate: horizon {horizon:g}", force=force
        )
    overhead = float(overhead) if is_real(overhead) else overhead
    if scheduler is None:
        scheduler = ts.scheduler
    cpu, info = build_cpu(
        ts,
        env=env,
        window=window,
        suspension=suspension,
        exec_model=exec_model,
        seed=seed,
        overhead=overhead,
        record_jobs=record_jobs,
        record_trace=record_trace,
        hist_bin=hist_bin,
        jitter=jitter,
        job_sink=job_sink,
        scheduler=scheduler,
        trace_sink=trace_sink,
    )
    proc = cpu.start(horizon)
    if progress is not None and is_real(horizon) and 0 < horizon < math.inf:
        start_ticker(cpu.env, horizon / TICKS, lambda now: now / horizon, progress)
    cpu.env.run(until=proc)
    if progress is not None:
        progress(1.0, float(cpu.env.now))
    return cpu.result(window=info)
