"""The SimPy virtual CPU: preemptive scheduling of job chains by a policy (fp, edf, yours).

``simulate(ts, horizon, ...)`` is the entry point; [`CPU`][rtsim.sim.CPU] is the lower-level object
a
coupling layer drives inside its own SimPy environment (hooks at segment boundaries,
per-segment execution-time callables, dynamic windows).
"""

from rtsim.sim.cpu import CPU, HOOK_EVENTS, HookEvent, Job
from rtsim.sim.execution import (
    WCET,
    Empirical,
    ExecModel,
    Uniform,
    resolve_exec_model,
    task_rngs,
)
from rtsim.sim.policy import (
    SCHEDULERS,
    EarliestDeadlineFirst,
    FixedPriority,
    SchedulingPolicy,
    register_scheduler,
    resolve_scheduler,
)
from rtsim.sim.records import (
    EPS,
    JOB_COLUMNS,
    TRACE_COLUMNS,
    ResponseHistogram,
    SimResult,
    TaskStats,
)
from rtsim.sim.run import build_cpu, resolve_window, simulate

__all__ = [
    "CPU",
    "EPS",
    "EarliestDeadlineFirst",
    "FixedPriority",
    "SCHEDULERS",
    "SchedulingPolicy",
    "Empirical",
    "ExecModel",
    "HOOK_EVENTS",
    "HookEvent",
    "JOB_COLUMNS",
    "Job",
    "ResponseHistogram",
    "SimResult",
    "TRACE_COLUMNS",
    "TaskStats",
    "Uniform",
    "WCET",
    "build_cpu",
    "register_scheduler",
    "resolve_scheduler",
    "resolve_exec_model",
    "resolve_window",
    "simulate",
    "task_rngs",
]
