"""Task-set files (TOML, read with `tomllib`): loading, validation and the reverse.

The generic shape any user can write::

    name = "example"            # optional
    overhead = 0                # optional: context-switch cost in ms (analysis and simulation)
    [scheduler]                 # optional
    policy = "fp"               # the CPU's scheduling policy: "fp" (default), "edf", or a
                                # registered name / "package.module:Name" (sim.policy)
    [[tasks]]
    name = "tau1"
    wcet = 5                    # ms
    period = 40                 # ms, or a multiple of the window: "2w", "w", "1.5w"
    deadline = 40               # optional, defaults to the period
    priority = 1                # optional; smaller = higher. Every task or none.
    offset = 0                  # optional, ms
    jitter = 0                  # optional, ms: release up to J after the arrival
    (docs/model/beyond.md)
    bcet = 3                    # optional, for random execution-time models
    overload = "finish-late"    # optional: "finish-late", "abort" or "skip"

plus, for the paper's processing-window sets, a ``[window]`` table (the chain T_w: see
[`rtsim.model.window.WindowSpec`][rtsim.model.window.WindowSpec]; ``k = "geometric"`` with
``rho_min`` in cm takes the
sound count of 0.5° beams that can hit a follower at distance ≥ rho_min, docs/model/lower-bound.md)
and an
``[assumptions]`` table mapping each value the paper does not give to the reason for the value
chosen. With no priorities, tasks are ordered deadline-monotonically (equal deadlines in file
order) and numbered 1..N. With a ``[window]``, every task and the window must give a priority:
T_hp and T_lp follow from them.

Every problem raises `TaskSetError`, one line per problem and all of
them at once, ``<file>: task '<name>': <field>: <problem>`` (``[[tasks]] #3`` when the name
is missing). The file is read and checked by `rtsim.config` (the model of the file in
`rtsim.config.taskset`, with every key's type, range and unit).
Deadlines above the period are accepted: `rtsim.analysis.rta` analyses them with the
level-i busy period (Lehoczky 1990).
"""

from __future__ import annotations

import os
from typing import Any

from rtsim.config.load import PACKAGED_TASKSET, load_taskset, parse_taskset
from rtsim.errors import TaskSetError
from rtsim.model.taskset import TaskSet

__all__ = ["load_taskset", "parse_taskset", "taskset_to_dict", "as_taskset", "PACKAGED_TASKSET"]


def as_taskset(ts: object, function: str) -> TaskSet:
    """``ts`` as a [`TaskSet`][rtsim.io.taskset.TaskSet]: itself, or the task-set file a path names
    (str or
    ``os.PathLike``, read with [`load_taskset`][rtsim.io.taskset.load_taskset]). Anything else
    raises
    `TaskSetError` naming ``function`` (never an AttributeError)."""
    if isinstance(ts, TaskSet):
        return ts
    if isinstance(ts, str | os.PathLike):
        return load_taskset(ts)
    raise TaskSetError(
        f"{function}: expected a TaskSet or the path of a task-set file, got {type(ts).__name__}"
    )


def _multiple(x: float) -> str:
    return f"{int(x)}w" if float(x).is_integer() else f"{x!r}w"


def taskset_to_dict(ts: TaskSet) -> dict[str, Any]:
    """A JSON-able dict in the file's shape; [`parse_taskset`][rtsim.io.taskset.parse_taskset] turns
    it back into ``ts``.

    Priorities are always written out. A task's own ``segments`` are not part of the file
    format (the window chain is, as ``window``), so a task set made by
    `TaskSet.at_window` comes back with the chain as a plain task of cost g.
    """
    tasks: list[dict[str, Any]] = []
    for t in ts.tasks:
        entry: dict[str, Any] = {"name": t.name, "wcet": t.wcet}
        assert t.deadline is not None
        if t.per_window:
            entry["period"], entry["deadline"] = _multiple(t.period), _multiple(t.deadline)
        else:
            entry["period"], entry["deadline"] = t.period, t.deadline
        entry["priority"] = t.priority
        entry["offset"] = t.offset
        if t.jitter:
            entry["jitter"] = t.jitter
        if t.bcet is not None:
            entry["bcet"] = t.bcet
        entry["overload"] = t.overload
        if t.critical_sections:
            entry["critical_sections"] = [
                {"resource": c.resource, "start": c.start, "length": c.length}
                for c in t.critical_sections
            ]
        tasks.append(entry)
    out: dict[str, Any] = {"name": ts.name, "tasks": tasks}
    if ts.overhead:
        out["overhead"] = ts.overhead
    if ts.scheduler != "fp" or ts.resources is not None:
        out["scheduler"] = {"policy": ts.scheduler}
        if ts.resources is not None:
            out["scheduler"]["resources"] = ts.resources
        if ts.quantum is not None:
            out["scheduler"]["quantum"] = ts.quantum
    if ts.window is not None:
        out["window"] = ts.window.as_dict()
    if ts.assumptions:
        out["assumptions"] = dict(ts.assumptions)
    return out
