"""Task-set files: the file format's typed model, the loader (`load_taskset`, `parse_taskset`)
that builds a [`TaskSet`][rtsim.model.taskset.TaskSet] from a valid file, and the reverse
(`taskset_to_dict`). The format, its rules and its errors: docs/tasksets.md.
"""

from __future__ import annotations

import functools
import os
import re
from collections.abc import Mapping
from importlib import resources
from typing import Annotated, Any

from pydantic import Field

from rtsim.analysis.window import k_geometric
from rtsim.config.errors import Loc, raise_errors
from rtsim.config.fields import (
    Leaf,
    Table,
    _check_number,
    choice,
    integer,
    number,
    problem,
    ranged,
    text,
)
from rtsim.config.load import parse_toml, validate, with_overrides
from rtsim.errors import TaskSetError
from rtsim.examples import packaged_text, shipped_hint
from rtsim.io.limits import WINDOW_N, WINDOW_R_H, Range, read_input
from rtsim.model.task import OVERLOAD_POLICIES, RESOURCE_PROTOCOLS, CriticalSection, Task
from rtsim.model.taskset import TaskSet
from rtsim.model.window import TIMES, WindowSpec
from rtsim.registry import reading_input
from rtsim.sim.policy import resolve_scheduler

__all__ = [
    "TaskSetFile",
    "TaskTable",
    "WindowTable",
    "SchedulerTable",
    "build_taskset",
    "taskset_where",
    "load_taskset",
    "parse_taskset",
    "taskset_bytes",
    "taskset_to_dict",
    "as_taskset",
    "PACKAGED_TASKSET",
]

#: The paper's Table 1, shipped inside the package (also ``tasksets/barrel_robots.toml``).
PACKAGED_TASKSET = "barrel_robots.toml"

_MS_MAX = 1e9  # ms: 11.6 days, beyond any run rtsim is made for
_W_MULTIPLE = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)?\s*w\s*$")


def _time_or_multiple(lo: float, why: str) -> Leaf:
    """A time in ms, or a multiple of the window written ``"2w"`` (``"w"``: one)."""
    r = Range("", lo, _MS_MAX, "ms", why)
    check_ms = _check_number(r, False)

    def check(value: Any) -> Any:
        if isinstance(value, str):
            m = _W_MULTIPLE.match(value)
            if not m:
                raise problem(
                    f'must be a number (ms) or a multiple of the window such as "2w", got {value!r}'
                )
            if m.group(1) and float(m.group(1)) <= 0:
                raise problem(f"must be positive, got {value!r}")
            return value
        return check_ms(value)

    schema = {
        "anyOf": [
            {"type": "number", "minimum": lo, "maximum": _MS_MAX},
            {"type": "string", "pattern": _W_MULTIPLE.pattern},
        ],
        "unit": "ms",
        "why": why,
    }
    return Leaf(check, schema, r)


def per_window(value: float | str) -> tuple[float, bool]:
    """(value, per_window) of a period or deadline: ``"2w"`` → (2.0, True)."""
    if isinstance(value, str):
        m = _W_MULTIPLE.match(value)
        assert m is not None
        return (float(m.group(1)) if m.group(1) else 1.0), True
    return float(value), False


class SectionTable(Table):
    """One critical section of a task: ``{ resource = "radio", start = 2.0, length = 3.0 }``
    (docs/resources.md)."""

    resource: Annotated[str, text(what="a resource name")]
    start: Annotated[
        float,
        number(
            0,
            1e7,
            "ms",
            "the execution a job has consumed when the section begins (within the wcet)",
        ),
    ]
    length: Annotated[
        float,
        number(
            0,
            1e7,
            "ms",
            "the execution that holds the resource (within what is left of the wcet)",
            lo_open=True,
        ),
    ]


class TaskTable(Table):
    """One ``[[tasks]]`` entry."""

    name: Annotated[str, text()]
    wcet: Annotated[float, number(0, 1e7, "ms", "at most 2.8 h of CPU per job", lo_open=True)]
    period: Annotated[float | str, _time_or_multiple(1e-3, "1 µs (a timer tick) to 11.6 days")]
    deadline: Annotated[float | str, _time_or_multiple(1e-3, "as the period")] | None = None
    priority: Annotated[int, integer(-1e9, 1e9, "", "an integer rank")] | None = None
    offset: Annotated[float, number(0, _MS_MAX, "ms", "within 11.6 days of the start")] | None = (
        None
    )
    jitter: Annotated[float, number(0, _MS_MAX, "ms", "as the offset")] | None = None
    bcet: Annotated[float, number(0, 1e7, "ms", "at most 2.8 h of CPU per job")] | None = None
    overload: Annotated[str, choice(OVERLOAD_POLICIES)] | None = None
    critical_sections: list[SectionTable] | None = None


_CHAIN = "a chain step of at most 2.8 h"
_K_RANGE = number(0, 361, "points", "a follower returns at most the 361 beams", lo_open=True)


def _k(value: Any) -> Any:
    if value == "geometric":
        return value
    if isinstance(value, str):
        raise problem(f'must be a number or "geometric", got {value!r}')
    return _K_RANGE.check(value)


_K = Leaf(
    _k,
    {
        "anyOf": [
            {k: v for k, v in _K_RANGE.schema.items() if k not in ("unit", "why")},
            {"type": "string", "enum": ["geometric"]},
        ],
        "unit": "points",
        "why": _K_RANGE.schema["why"],
    },
    _K_RANGE.range,
)


class WindowTable(Table):
    """The ``[window]`` table: the processing window's chain T_w."""

    name: Annotated[str, text()] = "window"
    priority: Annotated[int, integer(-1e9, 1e9, "", "an integer rank")]
    n: Annotated[int, ranged(WINDOW_N)]
    r_H: Annotated[float, ranged(WINDOW_R_H)]
    e_cal: Annotated[float, number(0, 1e3, "ms", "per accumulator cell")]
    e_trans: Annotated[float, number(0, 1e3, "ms", "per scan point")]
    k: Annotated[float | str, _K]
    e_scan: Annotated[float, number(0, 1e7, "ms", _CHAIN)]
    e_estimate: Annotated[float, number(0, 1e7, "ms", _CHAIN)]
    e_send: Annotated[float, number(0, 1e7, "ms", _CHAIN)]
    e_recv: Annotated[float, number(0, 1e7, "ms", _CHAIN)]
    delta_t: Annotated[float, number(0, 1e7, "ms", _CHAIN)]
    e_sched: Annotated[float, number(0, 1e7, "ms", _CHAIN)]
    rho_min: (
        Annotated[
            float,
            number(
                25, 1e5, "cm", "beyond the follower radius r_F = 25 cm, within 1 km", lo_open=True
            ),
        ]
        | None
    ) = None
    k_value: Annotated[float, number(0, 361, "points", "as k", lo_open=True)] | None = None
    offset: (
        Annotated[
            float,
            number(
                0,
                _MS_MAX,
                "ms",
                "as a task's offset: the first window "
                "arrives then; per-window tasks count their offsets from "
                "it",
            ),
        ]
        | None
    ) = None
    jitter: (
        Annotated[
            float,
            number(
                0,
                _MS_MAX,
                "ms",
                "as a task's jitter: each window job is released up to J after its arrival",
            ),
        ]
        | None
    ) = None


class SchedulerTable(Table):
    """``[scheduler]``: the CPU's scheduling policy."""

    policy: Annotated[str, text(what="a policy name")] = "fp"
    resources: Annotated[str, choice(RESOURCE_PROTOCOLS)] | None = None
    quantum: (
        Annotated[
            float,
            number(
                0,
                1e7,
                "ms",
                "the time slice of a time-sliced policy (rr)",
                lo_open=True,
            ),
        ]
        | None
    ) = None


class TaskSetFile(Table):
    """A task-set file."""

    name: Annotated[str, text(nonempty=False, what="a string")] = ""
    tasks: list[TaskTable] = Field(min_length=1)
    window: WindowTable | None = None
    assumptions: dict[str, str] = Field(default_factory=dict)
    overhead: Annotated[float, number(0, 1e4, "ms", "a context switch of at most 10 s")] = 0.0
    scheduler: SchedulerTable | None = None


# ------------------------------------------------------------------------- messages
def taskset_where(data: Any) -> Any:
    """Locations as task-set messages give them: ``task 'tau1': wcet``, ``[window]: n``."""

    def where(loc: Loc) -> str:
        head, rest = loc[0], loc[1:]
        if head == "tasks" and rest and isinstance(rest[0], int):
            i = rest[0]
            label = f"[[tasks]] #{i + 1}"
            tasks = data.get("tasks") if isinstance(data, Mapping) else None
            if isinstance(tasks, list) and i < len(tasks) and isinstance(tasks[i], Mapping):
                name = tasks[i].get("name")
                if isinstance(name, str) and name.strip():
                    label = f"task '{name}'"
            rest = rest[1:]
        elif head in ("window", "scheduler", "assumptions"):
            label = f"[{head}]"
        else:
            return ".".join(str(p) for p in loc)
        return f"{label}: {'.'.join(str(p) for p in rest)}" if rest else label

    return where


def taskset_special(loc: Loc, what: str) -> str | None:
    if loc == ("tasks",) and what in ("missing (required)", "must not be empty"):
        return "no [[tasks]] in the file"
    if loc == ("tasks",) and what.startswith("must be an array"):
        return "must be an array of tables ([[tasks]])"
    return None


# -------------------------------------------------------------------------- building
def _label(model: TaskTable, index: int) -> str:
    return f"task '{model.name}'" if model.name.strip() else f"[[tasks]] #{index}"


def build_taskset(model: TaskSetFile, source: str) -> tuple[TaskSet | None, list[str]]:
    """The TaskSet of a valid file, or the problems (``<key>: <problem>`` lines without the
    file) of the rules between keys."""
    errors: list[str] = []
    window = None
    if model.window is not None:
        window, errs = _window(model.window)
        errors += errs
    if model.scheduler is not None:
        try:
            sliced = resolve_scheduler(
                model.scheduler.policy, where=f"{source}: [scheduler]: policy"
            ).takes_quantum
        except Exception as exc:  # an InputError naming the file already
            errors.append(str(exc).removeprefix(f"{source}: "))
        else:
            if model.scheduler.quantum is not None and not sliced:
                errors.append(
                    f"[scheduler]: quantum: only for a time-sliced policy (rr), not "
                    f"{model.scheduler.policy!r}"
                )
            if model.scheduler.quantum is None and sliced:
                errors.append(
                    f"[scheduler]: quantum: missing (required by the time-sliced policy "
                    f"{model.scheduler.policy!r}: its time slice in ms)"
                )
    entries: list[tuple[dict[str, Any], str]] = []
    for i, t in enumerate(model.tasks, start=1):
        label = _label(t, i)
        kw: dict[str, Any] = {"name": t.name, "wcet": float(t.wcet)}
        kw["period"], kw["per_window"] = per_window(t.period)
        if t.deadline is not None:
            deadline, d_window = per_window(t.deadline)
            if d_window != kw["per_window"]:
                errors.append(
                    f"{label}: deadline: {t.deadline!r} and period {t.period!r} must "
                    "both be in ms or both be multiples of w"
                )
            kw["deadline"] = deadline
        if kw["per_window"] and model.window is None:
            errors.append(
                f"{label}: period: {t.period!r} is a multiple of the window w, but "
                "the file has no [window] table"
            )
        if t.priority is not None:
            kw["priority"] = int(t.priority)
        if t.offset is not None:
            kw["offset"] = float(t.offset)
        if t.jitter is not None:
            kw["jitter"] = float(t.jitter)
        if t.bcet is not None:
            if t.bcet > t.wcet:
                errors.append(f"{label}: bcet: {float(t.bcet):g} is above wcet {float(t.wcet):g}")
            kw["bcet"] = float(t.bcet)
        if t.overload is not None:
            kw["overload"] = t.overload
        if t.critical_sections:
            kw["critical_sections"] = tuple(
                CriticalSection(c.resource, float(c.start), float(c.length))
                for c in t.critical_sections
            )
        entries.append((kw, label))
    names: dict[str, int] = {} if model.window is None else {model.window.name: 0}
    for i, (kw, label) in enumerate(entries, start=1):
        if kw["name"] in names:
            other = names[kw["name"]]
            first = "the [window]" if other == 0 else f"[[tasks]] #{other}"
            errors.append(f"{label}: name: duplicate of {first}")
        else:
            names[kw["name"]] = i
    shared = model.scheduler is not None and model.scheduler.quantum is not None
    errors += _assign_priorities(entries, model.window, shared)
    if errors or (model.window is not None and window is None):
        return None, errors
    tasks_l = []
    for kw, label in entries:
        try:
            tasks_l.append(Task(**kw))
        except TaskSetError as exc:  # the critical sections against the wcet
            msg = str(exc)
            errors.append(msg if msg.startswith(label) else f"{label}: {msg}")
    if model.scheduler is not None and model.scheduler.resources == "pcp":
        try:
            levels = resolve_scheduler(model.scheduler.policy).resource_levels
        except Exception:  # an unknown policy: reported above
            levels = "priority"
        if levels == "deadline":
            errors.append(
                f"[scheduler]: resources: pcp needs fixed priorities; under "
                f"{model.scheduler.policy} use srp or npr"
            )
    if errors:
        return None, errors
    tasks = tuple(tasks_l)
    return TaskSet(
        tasks,
        name=model.name,
        window=window,
        assumptions=dict(model.assumptions),
        source=source,
        overhead=float(model.overhead),
        scheduler=model.scheduler.policy if model.scheduler else "fp",
        resources=model.scheduler.resources if model.scheduler else None,
        quantum=model.scheduler.quantum if model.scheduler else None,
    ), []


def _window(w: WindowTable) -> tuple[WindowSpec | None, list[str]]:
    where = "[window]"
    values: dict[str, Any] = {
        "name": w.name,
        "n": int(w.n),
        "priority": int(w.priority),
        "r_H": float(w.r_H),
    }
    if w.k == "geometric":
        if w.rho_min is None:
            return None, [
                f'{where}: rho_min: missing (required with k = "geometric": the '
                "least follower distance in cm)"
            ]
        values["k"] = float(k_geometric(float(w.rho_min)))
        values["rho_min"] = float(w.rho_min)
        if w.k_value is not None and w.k_value != values["k"]:
            return None, [
                f"{where}: k_value: {w.k_value!r} is not the geometric count "
                f"{values['k']:g} for rho_min = {float(w.rho_min):g} cm"
            ]
    else:
        values["k"] = float(w.k)
        for key in ("rho_min", "k_value"):
            if getattr(w, key) is not None:
                return None, [f'{where}: {key}: applies only with k = "geometric"']
    for key in TIMES:
        values[key] = float(getattr(w, key))
    for key in ("jitter", "offset"):  # the window's release jitter and first arrival (ms)
        if getattr(w, key) is not None:
            values[key] = float(getattr(w, key))
    return WindowSpec(**values), []


def _assign_priorities(
    entries: list[tuple[dict[str, Any], str]], window: WindowTable | None, shared: bool = False
) -> list[str]:
    """Every task gives a priority or none does; none → deadline-monotonic, ties in file order.
    ``shared``: tasks may share a priority (a time-sliced policy with its quantum)."""
    given = [label for kw, label in entries if "priority" in kw]
    if given and len(given) != len(entries):
        missing = next(label for kw, label in entries if "priority" not in kw)
        return [
            f"{missing}: priority: missing, but {given[0]} gives one (give every task a "
            "priority, or none for deadline-monotonic order)"
        ]
    if not given:
        if window is not None and entries:
            return [
                f"{entries[0][1]}: priority: missing (required when the file has a "
                "[window]: it places each task above or below the window)"
            ]
        order = sorted(
            range(len(entries)),
            key=lambda i: (entries[i][0].get("deadline", entries[i][0]["period"]), i),
        )
        for rank, i in enumerate(order, start=1):
            entries[i][0]["priority"] = rank
        return []
    seen: dict[int, str] = {}
    if window is not None:
        seen[int(window.priority)] = f"[window] '{window.name}'"
    errors = []
    for kw, label in entries:
        prio = kw["priority"]
        if prio in seen and not shared:
            errors.append(
                f"{label}: priority: {prio} is already used by {seen[prio]} (tasks share a "
                f'priority only under a time-sliced policy: [scheduler] policy = "rr" with '
                f"a quantum)"
            )
        else:
            seen[prio] = label
    return errors


# -------------------------------------------------------------------------- loading
@functools.cache
def packaged_data(*parts: str) -> Any:
    """The packaged data file ``rtsim/data/<parts>`` (an `importlib.resources` traversable),
    found once per process: read at every use (its bytes as they are then), not looked up
    again (≈ 30 µs a lookup, twice a sweep point)."""
    res = resources.files("rtsim") / "data"
    for part in parts:
        res = res / part
    return res


def taskset_bytes(path: str | os.PathLike[str] | None) -> tuple[bytes, str]:
    """The bytes of a task-set file and the name errors give it (``None``: the packaged
    paper set; a shipped example by name, ``example``)."""
    if path is None:
        res = packaged_data(PACKAGED_TASKSET)
        return res.read_bytes(), str(res)

    shipped = packaged_text(path, "taskset")
    if shipped is not None:
        return shipped.encode("utf-8"), f"{os.fspath(path)}.toml (packaged)"
    source = os.fspath(path)

    try:
        return read_input(source, "task-set"), source
    except FileNotFoundError:
        raise TaskSetError(f"{source}: no such file{shipped_hint(source, 'taskset')}") from None
    except IsADirectoryError:
        raise TaskSetError(f"{source}: is a directory, not a task-set file") from None
    except OSError as exc:
        raise TaskSetError(f"{source}: cannot read: {exc.strerror or exc}") from None


def parse_taskset(data: Mapping[str, Any], source: str, *, allow_code: bool | None = None) -> Any:
    """Validate a task-set table (as `tomllib.loads` returns it) and build the TaskSet;
    ``source`` names the file in error messages and is kept as ``TaskSet.source``. A
    ``[scheduler] policy`` of the form ``module:Name`` is code: it loads only with
    ``allow_code=True`` or the user's opt-in (`rtsim.registry.reading_input`)."""
    with reading_input(allow_code):
        model = validate(
            TaskSetFile, data, source, TaskSetError, taskset_where(data), taskset_special
        )
        ts, errors = build_taskset(model, source)
    raise_errors([f"{source}: {e}" for e in errors], TaskSetError)
    assert ts is not None
    return ts


def load_taskset(
    path: str | os.PathLike[str] | None = None,
    overrides: Mapping[str, Any] | None = None,
    *,
    allow_code: bool | None = None,
) -> Any:
    """Read a TOML task-set file (``None``: the packaged paper set, Table 1); ``overrides``:
    dotted paths and their values (`rtsim.config.dotted`); ``allow_code``: as
    `parse_taskset`."""
    raw, source = taskset_bytes(path)
    return taskset_from_bytes(raw, source, overrides, allow_code=allow_code)


def taskset_from_bytes(
    raw: bytes,
    source: str,
    overrides: Mapping[str, Any] | None = None,
    *,
    allow_code: bool | None = None,
) -> Any:
    """A task-set file's bytes ``raw`` (named ``source``) parsed and built, as
    `load_taskset` reads them."""
    data = parse_toml(raw, source, TaskSetError)
    return parse_taskset(with_overrides(data, overrides, source), source, allow_code=allow_code)


def as_taskset(ts: object, function: str) -> TaskSet:
    """``ts`` as a [`TaskSet`][rtsim.model.taskset.TaskSet]: itself, or the task-set file a
    path names (str or ``os.PathLike``, read with `load_taskset`). Anything else raises
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
    """A JSON-able dict in the file's shape; `parse_taskset` turns it back into ``ts``.

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
