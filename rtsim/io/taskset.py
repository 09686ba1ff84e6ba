"""Task-set files (TOML, read with :mod:`tomllib`): loading, validation and the reverse.

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
:class:`rtsim.model.window.WindowSpec`; ``k = "geometric"`` with ``rho_min`` in cm takes the
sound count of 0.5° beams that can hit a follower at distance ≥ rho_min, docs/model/lower-bound.md)
and an
``[assumptions]`` table mapping each value the paper does not give to the reason for the value
chosen. With no priorities, tasks are ordered deadline-monotonically (equal deadlines in file
order) and numbered 1..N. With a ``[window]``, every task and the window must give a priority:
T_hp and T_lp follow from them.

Every problem raises :class:`~rtsim.errors.TaskSetError` with one line,
``<file>: task '<name>': <field>: <problem>`` (``[[tasks]] #3`` when the name is missing).
Deadlines above the period are accepted: :mod:`rtsim.analysis.rta` analyses them with the
level-i busy period (Lehoczky 1990).
"""

from __future__ import annotations

import difflib
import math
import os
import re
import tomllib
from collections.abc import Mapping
from importlib import resources
from typing import Any

from rtsim._numbers import is_int, is_real
from rtsim.analysis.window import k_geometric
from rtsim.errors import InputError, TaskSetError
from rtsim.model.task import OVERLOAD_POLICIES, Task
from rtsim.model.taskset import TaskSet
from rtsim.model.window import WindowSpec

__all__ = ["load_taskset", "parse_taskset", "taskset_to_dict", "as_taskset", "PACKAGED_TASKSET"]

#: The paper's Table 1, shipped inside the package (also ``tasksets/barrel_robots.toml``).
PACKAGED_TASKSET = "barrel_robots.toml"

TOP_KEYS = ("name", "tasks", "window", "assumptions", "overhead", "scheduler")
SCHEDULER_KEYS = ("policy",)
TASK_KEYS = ("name", "wcet", "period", "deadline", "priority", "offset", "bcet", "overload",
             "jitter")
TASK_REQUIRED = ("name", "wcet", "period")
WINDOW_KEYS = ("name", "priority", "n", "r_H", "e_cal", "e_trans", "k", "e_scan",
               "e_estimate", "e_send", "e_recv", "delta_t", "e_sched", "rho_min", "k_value",
               "jitter", "offset")
_WINDOW_OPTIONAL = ("name", "rho_min", "k_value", "jitter", "offset")
_WINDOW_TIMES = ("e_cal", "e_trans", "e_scan", "e_estimate", "e_send", "e_recv", "delta_t",
                 "e_sched")

_W_MULTIPLE = re.compile(r"^\s*(\d+(?:\.\d*)?|\.\d+)?\s*w\s*$")


def _unknown(where: str, key: str, allowed: tuple[str, ...]) -> TaskSetError:
    close = difflib.get_close_matches(key, allowed, n=1, cutoff=0.6)
    hint = f" (did you mean '{close[0]}'?)" if close else f" (known keys: {', '.join(allowed)})"
    return TaskSetError(f"{where}: unknown key '{key}'{hint}")


def _check_keys(where: str, table: Mapping[str, Any], allowed: tuple[str, ...],
                required: tuple[str, ...]) -> None:
    """Unknown keys first (with the closest known key), then missing required keys."""
    for key in table:
        if key not in allowed:
            raise _unknown(where, key, allowed)
    for key in required:
        if key not in table:
            raise TaskSetError(f"{where}: {key}: missing (required)")


def _number(where: str, field: str, value: object, *, positive: bool = True) -> float:
    """A finite number: positive, or non-negative when ``positive`` is false."""
    if not is_real(value):
        raise TaskSetError(f"{where}: {field}: must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise TaskSetError(f"{where}: {field}: must be finite, got {value!r}")
    if v < 0 or (positive and v == 0):
        raise TaskSetError(
            f"{where}: {field}: must be {'positive' if positive else 'non-negative'}, "
            f"got {value!r}"
        )
    return v


def _integer(where: str, field: str, value: object) -> int:
    if not is_int(value):
        raise TaskSetError(f"{where}: {field}: must be an integer, got {value!r}")
    return int(value)


def _time_or_multiple(where: str, field: str, value: object) -> tuple[float, bool]:
    """A time in ms, or a multiple of w written ``"2w"``: (value, per_window)."""
    if isinstance(value, str):
        m = _W_MULTIPLE.match(value)
        if not m:
            raise TaskSetError(
                f"{where}: {field}: must be a number (ms) or a multiple of the window "
                f"such as \"2w\", got {value!r}"
            )
        mult = float(m.group(1)) if m.group(1) else 1.0
        return _number(where, field, mult), True
    return _number(where, field, value), False


def _parse_window(source: str, table: object) -> WindowSpec:
    where = f"{source}: [window]"
    if not isinstance(table, dict):
        raise TaskSetError(f"{where}: must be a table, got {table!r}")
    _check_keys(where, table, WINDOW_KEYS, tuple(k for k in WINDOW_KEYS
                                                 if k not in _WINDOW_OPTIONAL))
    name = table.get("name", "window")
    if not isinstance(name, str) or not name:
        raise TaskSetError(f"{where}: name: must be a non-empty string, got {name!r}")
    n = _integer(where, "n", table["n"])
    if n < 1:
        raise TaskSetError(f"{where}: n: must be at least 1, got {n!r}")
    values: dict[str, Any] = {
        "name": name,
        "n": n,
        "priority": _integer(where, "priority", table["priority"]),
        "r_H": _number(where, "r_H", table["r_H"]),
    }
    if table["k"] == "geometric":
        if "rho_min" not in table:
            raise TaskSetError(f"{where}: rho_min: missing (required with k = \"geometric\": "
                               "the least follower distance in cm)")
        rho_min = _number(where, "rho_min", table["rho_min"])
        values["k"] = float(k_geometric(rho_min))
        values["rho_min"] = rho_min
        if "k_value" in table and table["k_value"] != values["k"]:
            raise TaskSetError(f"{where}: k_value: {table['k_value']!r} is not the geometric "
                               f"count {values['k']:g} for rho_min = {rho_min:g} cm")
    elif isinstance(table["k"], str):
        raise TaskSetError(f"{where}: k: must be a number or \"geometric\", got {table['k']!r}")
    else:
        values["k"] = _number(where, "k", table["k"])
        for key in ("rho_min", "k_value"):
            if key in table:
                raise TaskSetError(f"{where}: {key}: applies only with k = \"geometric\"")
    for key in _WINDOW_TIMES:
        values[key] = _number(where, key, table[key], positive=False)
    for key in ("jitter", "offset"):  # the window's release jitter and first arrival (ms)
        if key in table:
            values[key] = _number(where, key, table[key], positive=False)
    try:
        return WindowSpec(**values)
    except TaskSetError as exc:  # pragma: no cover - everything is checked above
        raise TaskSetError(f"{source}: {exc}") from None


def _parse_task(source: str, index: int, table: object,
                has_window: bool) -> tuple[dict[str, Any], str]:
    """Validate one ``[[tasks]]`` entry: (keyword arguments for Task, its label)."""
    label = f"[[tasks]] #{index}"
    if not isinstance(table, dict):
        raise TaskSetError(f"{source}: {label}: must be a table, got {table!r}")
    name = table.get("name")
    if isinstance(name, str) and name.strip():
        label = f"task '{name}'"
    where = f"{source}: {label}"
    _check_keys(where, table, TASK_KEYS, TASK_REQUIRED)
    if not isinstance(name, str) or not name.strip():
        raise TaskSetError(f"{where}: name: must be a non-empty string, got {name!r}")
    kw: dict[str, Any] = {"name": name}
    kw["wcet"] = _number(where, "wcet", table["wcet"])
    period, per_window = _time_or_multiple(where, "period", table["period"])
    kw["period"], kw["per_window"] = period, per_window
    if "deadline" in table:
        deadline, d_window = _time_or_multiple(where, "deadline", table["deadline"])
        if d_window != per_window:
            raise TaskSetError(
                f"{where}: deadline: {table['deadline']!r} and period {table['period']!r} must "
                "both be in ms or both be multiples of w"
            )
        kw["deadline"] = deadline
    if per_window and not has_window:
        raise TaskSetError(
            f"{where}: period: {table['period']!r} is a multiple of the window w, but the "
            "file has no [window] table"
        )
    if "priority" in table:
        kw["priority"] = _integer(where, "priority", table["priority"])
    if "offset" in table:
        kw["offset"] = _number(where, "offset", table["offset"], positive=False)
    if "jitter" in table:
        kw["jitter"] = _number(where, "jitter", table["jitter"], positive=False)
    if "bcet" in table:
        bcet = _number(where, "bcet", table["bcet"], positive=False)
        if bcet > kw["wcet"]:
            raise TaskSetError(f"{where}: bcet: {bcet:g} is above wcet {kw['wcet']:g}")
        kw["bcet"] = bcet
    if "overload" in table:
        policy = table["overload"]
        if policy not in OVERLOAD_POLICIES:
            raise TaskSetError(
                f"{where}: overload: must be one of {', '.join(OVERLOAD_POLICIES)}, "
                f"got {policy!r}"
            )
        kw["overload"] = policy
    return kw, label


def _assign_priorities(source: str, entries: list[tuple[dict[str, Any], str]],
                       window: WindowSpec | None) -> None:
    """Every task gives a priority or none does; none → deadline-monotonic, ties in file order."""
    given = [label for kw, label in entries if "priority" in kw]
    if given and len(given) != len(entries):
        missing = next(label for kw, label in entries if "priority" not in kw)
        raise TaskSetError(
            f"{source}: {missing}: priority: missing, but {given[0]} gives one "
            "(give every task a priority, or none for deadline-monotonic order)"
        )
    if not given:
        if window is not None and entries:
            raise TaskSetError(
                f"{source}: {entries[0][1]}: priority: missing (required when the file has "
                "a [window]: it places each task above or below the window)"
            )
        order = sorted(range(len(entries)), key=lambda i: (
            entries[i][0].get("deadline", entries[i][0]["period"]), i))
        for rank, i in enumerate(order, start=1):
            entries[i][0]["priority"] = rank
        return
    seen: dict[int, str] = {}
    if window is not None:
        seen[window.priority] = f"[window] '{window.name}'"
    for kw, label in entries:
        prio = kw["priority"]
        if prio in seen:
            raise TaskSetError(
                f"{source}: {label}: priority: {prio} is already used by {seen[prio]}"
            )
        seen[prio] = label


def _parse_scheduler(source: str, table: object) -> str:
    """``[scheduler] policy``: a registered policy name or ``package.module:Name``."""
    from rtsim.sim.policy import resolve_policy

    where = f"{source}: [scheduler]"
    if not isinstance(table, dict):
        raise TaskSetError(f"{where}: must be a table (policy = \"fp\" or \"edf\")")
    _check_keys(where, table, SCHEDULER_KEYS, ())
    policy = table.get("policy", "fp")
    if not isinstance(policy, str) or not policy:
        raise TaskSetError(f"{where}: policy: must be a policy name, got {policy!r}")
    try:
        resolve_policy(policy, where=f"{where}: policy")
    except InputError as exc:
        raise TaskSetError(str(exc)) from None
    return policy


def parse_taskset(data: dict[str, Any], source: str, *,
                  allow_code: bool | None = None) -> TaskSet:
    """Validate a task-set table (as :func:`tomllib.loads` returns it) and build the TaskSet.

    ``source`` names the file in error messages and is kept as ``TaskSet.source``. Every
    number is then checked against its range (:mod:`rtsim.io.limits`). A ``[scheduler]
    policy`` of the form ``module:Name`` is code: it loads only with ``allow_code=True``
    (:func:`rtsim.registry.reading_input`).
    """
    from rtsim.io import limits
    from rtsim.registry import reading_input

    with reading_input(allow_code):
        return limits.parse_checked("taskset", lambda: _parse_taskset(data, source), data,
                                    source)


def _parse_taskset(data: dict[str, Any], source: str) -> TaskSet:
    if not isinstance(data, dict):
        raise TaskSetError(f"{source}: must be a table of keys, got {type(data).__name__}")
    for key in data:
        if key not in TOP_KEYS:
            raise _unknown(source, key, TOP_KEYS)
    name = data.get("name", "")
    if not isinstance(name, str):
        raise TaskSetError(f"{source}: name: must be a string, got {name!r}")
    window = _parse_window(source, data["window"]) if "window" in data else None
    overhead = _number(source, "overhead", data.get("overhead", 0.0), positive=False)
    scheduler = _parse_scheduler(source, data.get("scheduler", {}))
    raw_tasks = data.get("tasks", [])
    if not isinstance(raw_tasks, list):
        raise TaskSetError(f"{source}: tasks: must be an array of tables ([[tasks]])")
    if not raw_tasks:
        raise TaskSetError(f"{source}: tasks: no [[tasks]] in the file")
    entries = [_parse_task(source, i, t, window is not None)
               for i, t in enumerate(raw_tasks, start=1)]
    names: dict[str, int] = {} if window is None else {window.name: 0}
    for i, (kw, label) in enumerate(entries, start=1):
        if kw["name"] in names:
            other = names[kw["name"]]
            first = "the [window]" if other == 0 else f"[[tasks]] #{other}"
            raise TaskSetError(f"{source}: {label}: name: duplicate of {first}")
        names[kw["name"]] = i
    _assign_priorities(source, entries, window)
    assumptions = data.get("assumptions", {})
    if not isinstance(assumptions, dict):
        raise TaskSetError(f"{source}: [assumptions]: must be a table, got {assumptions!r}")
    for key, value in assumptions.items():
        if not isinstance(value, str):
            raise TaskSetError(f"{source}: [assumptions]: {key}: must be a string, got {value!r}")
    try:
        tasks = tuple(Task(**kw) for kw, _ in entries)
        return TaskSet(tasks, name=name, window=window, assumptions=dict(assumptions),
                       source=source, overhead=overhead, scheduler=scheduler)
    except TaskSetError as exc:  # pragma: no cover - the checks above come first
        raise TaskSetError(f"{source}: {exc}") from None


def _read(path: str | os.PathLike[str] | None) -> tuple[bytes, str]:
    if path is None:
        res = resources.files("rtsim") / "data" / PACKAGED_TASKSET
        return res.read_bytes(), str(res)
    from rtsim.examples import packaged_text

    shipped = packaged_text(path, "taskset")  # a shipped example by name ("example")
    if shipped is not None:
        return shipped.encode("utf-8"), f"{os.fspath(path)}.toml (packaged)"
    source = os.fspath(path)
    from rtsim.io.limits import read_input

    try:
        return read_input(source, "task-set"), source
    except FileNotFoundError:
        raise TaskSetError(f"{source}: no such file") from None
    except IsADirectoryError:
        raise TaskSetError(f"{source}: is a directory, not a task-set file") from None
    except OSError as exc:
        raise TaskSetError(f"{source}: cannot read: {exc.strerror or exc}") from None


def load_taskset(path: str | os.PathLike[str] | None = None, *,
                 allow_code: bool | None = None) -> TaskSet:
    """Read a TOML task-set file (``None``: the packaged paper set, Table 1); ``allow_code``:
    as :func:`parse_taskset`."""
    raw, source = _read(path)
    if b"\x00" in raw:
        raise TaskSetError(f"{source}: not a text file (contains NUL bytes)")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise TaskSetError(f"{source}: not a text file (not UTF-8 at byte {exc.start})") from None
    try:
        data = tomllib.loads(text)
        return parse_taskset(data, source, allow_code=allow_code)
    except tomllib.TOMLDecodeError as exc:
        raise TaskSetError(f"{source}: malformed TOML: {exc}") from None
    except RecursionError:
        raise TaskSetError(f"{source}: nested too deeply to read (tables or arrays within "
                           f"each other hundreds of levels deep)") from None


def as_taskset(ts: object, function: str) -> TaskSet:
    """``ts`` as a :class:`TaskSet`: itself, or the task-set file a path names (str or
    ``os.PathLike``, read with :func:`load_taskset`). Anything else raises
    :class:`~rtsim.errors.TaskSetError` naming ``function`` (never an AttributeError)."""
    if isinstance(ts, TaskSet):
        return ts
    if isinstance(ts, str | os.PathLike):
        return load_taskset(ts)
    raise TaskSetError(f"{function}: expected a TaskSet or the path of a task-set file, "
                       f"got {type(ts).__name__}")


def _multiple(x: float) -> str:
    return f"{int(x)}w" if float(x).is_integer() else f"{x!r}w"


def taskset_to_dict(ts: TaskSet) -> dict[str, Any]:
    """A JSON-able dict in the file's shape; :func:`parse_taskset` turns it back into ``ts``.

    Priorities are always written out. A task's own ``segments`` are not part of the file
    format (the window chain is, as ``window``), so a task set made by
    :meth:`TaskSet.at_window` comes back with the chain as a plain task of cost g.
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
        tasks.append(entry)
    out: dict[str, Any] = {"name": ts.name, "tasks": tasks}
    if ts.overhead:
        out["overhead"] = ts.overhead
    if ts.scheduler != "fp":
        out["scheduler"] = {"policy": ts.scheduler}
    if ts.window is not None:
        out["window"] = ts.window.as_dict()
    if ts.assumptions:
        out["assumptions"] = dict(ts.assumptions)
    return out
