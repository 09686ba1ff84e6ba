"""Scenario files prepared once per process (`prepared`): a run of a file, or of a packaged
scenario by name, that this process has already prepared skips the parse, the validation, the
task set's read and the resolved values, and reuses the
[`ScenarioInputs`][rtsim.coupling.inputs.ScenarioInputs] (a sweep's points, a notebook's
repeated runs: docs/performance.md).

`window_bound`: the window's lower bound (w_sch, or the ``[adjust] lower_bound`` named:
w_rta and w_susp run the response-time analysis, ≈ 6 ms for Test 2) and `settled_speed`:
the leader's settled start speed, each computed once per process for the values it depends
on (a sweep's points that share n and r_H — other seeds, policies, speeds — share them).

The cache is keyed by the path as given, the working directory, the overrides, ``allow_code``
and the caller's ``text``, and an entry is used only while the scenario file's bytes and its
task-set file's bytes are those it was prepared from (both read again at each call, a few µs):
an edited file is prepared again. The inputs are shared, treat them as read-only (as
`run_scenario` does), except the adjustment policy: each call gets a fresh instance made
with the file's keys, as a first read does (a policy of the user's may keep state).
"""

from __future__ import annotations

import os
import threading
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import fields, replace
from typing import Any, NamedTuple

from rtsim.analysis.bounds import lower_bound
from rtsim.config.scenario import load_scenario, scenario_bytes, taskset_file
from rtsim.config.taskset import taskset_bytes
from rtsim.control.oracle import start_speed
from rtsim.errors import InputError
from rtsim.model.taskset import TaskSet
from rtsim.world.config import WorldConfig
from rtsim.world.world import forget_starts

__all__ = ["prepared", "clear", "run_constant", "settled_speed", "settled_world", "window_bound"]

#: files prepared and kept per process, most recent last
PREPARED_MAX = 8


class _Entry(NamedTuple):
    raw: bytes  # the scenario file's bytes
    taskset: str  # its task set, as the scenario names it after resolution
    taskset_raw: bytes  # ... and that file's bytes
    inputs: Any  # ScenarioInputs


_CACHE: OrderedDict[tuple[Any, ...], _Entry] = OrderedDict()


def _taskset_raw(name: str) -> bytes:
    return taskset_bytes(taskset_file(name))[0]


def _fresh_policy(inp: Any) -> Any:
    """``inp`` with a new instance of its adjustment policy, made with the same own keys
    (`rtsim.control.policy.make_policy`'s ``cls(**params)``; a hand-made ``adjust`` mapping
    holds no instance)."""
    adj = inp.adjust
    policy, own = getattr(adj, "policy", None), getattr(adj, "own", None)
    if policy is None or own is None:
        return inp
    return replace(inp, adjust=replace(adj, policy=type(policy)(**own)))


def clear() -> None:
    """Forget every prepared scenario (and the bounds, settled speeds, runs' constants
    and the followers' starting states on the leader's trace)."""
    _CACHE.clear()
    _SETTLED.clear()
    _BOUNDS.clear()
    _CONSTANTS.clear()
    _WORLDS.clear()
    forget_starts()


#: Settled start speeds kept per process (`settled_speed`)
SETTLED_MAX = 64


def settled_speed(cfg: WorldConfig, w_sch: float) -> float:
    """`rtsim.control.oracle.start_speed` of ``cfg`` and ``w_sch`` (cm/s), computed once per
    process for the values it reads — the path's segments and start, the formation, the
    leader's start, T_ε and T_β, V_Ld, the followers' top speed, w_sch — never by the
    identity of the (memoising, hence mutable) path object."""
    thr = cfg.thresholds
    key = (
        tuple(cfg.path.segments),
        tuple(cfg.path.start),
        cfg.formation,
        float(cfg.start_s),
        float(thr.T_eps),
        float(thr.T_beta),
        float(cfg.leader_speed),
        float(cfg.follower.max_speed),
        float(w_sch),
    )
    return _kept(_SETTLED, SETTLED_MAX, key, lambda: start_speed(cfg, w_sch))


_SETTLED: OrderedDict[tuple[Any, ...], float] = OrderedDict()


def settled_world(cfg: WorldConfig, w_sch: float) -> WorldConfig:
    """``cfg`` with its leader's start speed `settled_speed` (a settled start), made once
    per process for that configuration object and w_sch: a sweep's next point of a prepared
    scenario shares its (frozen) world and skips its validation again (≈ 50 µs). Kept by
    the object (alive while kept, so its id is its own) and w_sch."""
    key = (id(cfg), float(w_sch))  # (``cfg`` kept beside its value: alive, its id its own)
    kept = _kept(
        _WORLDS,
        SETTLED_MAX,
        key,
        lambda: (cfg, replace(cfg, start_speed=settled_speed(cfg, w_sch))),
    )
    return kept[1]  # type: ignore[no-any-return]


_WORLDS: OrderedDict[tuple[Any, ...], tuple[WorldConfig, WorldConfig]] = OrderedDict()
_LOCK = threading.Lock()  # (points may run in threads: a Dask worker's)


def _kept(
    cache: OrderedDict[tuple[Any, ...], Any],
    limit: int,
    key: tuple[Any, ...],
    compute: Callable[[], Any],
) -> Any:
    """``cache[key]``, else ``compute()`` kept there, the least recently used entry dropped
    beyond ``limit`` (an exception is raised and nothing kept)."""
    with _LOCK:
        hit = cache.get(key)
        if hit is not None:
            cache.move_to_end(key)
            return hit
    value = compute()
    with _LOCK:
        cache[key] = value
        while len(cache) > limit:
            cache.popitem(last=False)
    return value


def prepared(
    path: str | os.PathLike[str],
    text: str | None,
    overrides: Mapping[str, Any] | None,
    allow_code: bool | None,
    prepare: Callable[[Any, str], Any],
) -> Any:
    """``prepare(scenario, text)`` (`rtsim.coupling.inputs.scenario_inputs`, which calls this)
    of the scenario file (or packaged name) ``path`` loaded with ``overrides``, from the cache
    while both its files are unchanged (module docstring)."""
    key = (
        os.fspath(path),
        os.getcwd(),
        repr(sorted((overrides or {}).items())),
        allow_code,
        text,
    )
    raw = scenario_bytes(path)[0]
    hit = _CACHE.get(key)
    if hit is not None and hit.raw == raw:
        try:
            same = _taskset_raw(hit.taskset) == hit.taskset_raw
        except InputError:  # gone or unreadable: prepared again, which says so
            same = False
        if same:
            _CACHE.move_to_end(key)
            return _fresh_policy(hit.inputs)
    scenario = load_scenario(path, overrides=overrides, allow_code=allow_code)
    inp = prepare(scenario, raw.decode("utf-8") if text is None else text)
    if scenario_bytes(path)[0] == raw:  # (not edited while it was read)
        _CACHE[key] = _Entry(raw, scenario.taskset, _taskset_raw(scenario.taskset), inp)
        _CACHE.move_to_end(key)
        while len(_CACHE) > PREPARED_MAX:
            _CACHE.popitem(last=False)
    return inp


#: A run's constants kept per process (`run_constant`)
CONSTANTS_MAX = 32
_CONSTANTS: OrderedDict[tuple[Any, ...], Any] = OrderedDict()


def run_constant(key: tuple[Any, ...], make: Callable[[], Any]) -> Any:
    """One of a run's constants that a sweep's next point would make again, ``make()``
    once per process for ``key``: what it is (a name first) and every value it is made of
    (`rtsim.coupling.scenario_run`: the thresholds per follower, the sends' nominal
    offsets). Immutable (tuples of numbers): a caller that changes it copies it."""
    return _kept(_CONSTANTS, CONSTANTS_MAX, key, make)


#: Window bounds kept per process (`window_bound`)
BOUNDS_MAX = 64


def window_bound(
    ts: TaskSet, name: str, *, scheduler: str, suspension: str, where: str, force: bool = False
) -> float:
    """`rtsim.analysis.bounds.lower_bound` of ``ts`` (ms), computed once per process for the
    bound, the scheduler, the suspension and the task set's values — every field but its
    ``assumptions`` (text; a TaskSet is immutable) — whatever file or object they came from.
    ``where`` only words an error (errors are not kept); ``force`` runs past a work limit
    (a value once computed is kept either way)."""
    key = (
        name,
        scheduler,
        suspension,
        *(getattr(ts, f.name) for f in fields(ts) if f.name != "assumptions"),
    )

    def compute() -> float:
        return lower_bound(
            ts, name, scheduler=scheduler, suspension=suspension, where=where, force=force
        )

    try:
        hash(key)
    except TypeError:  # (a field that cannot be a key: computed every time)
        return compute()
    return _kept(_BOUNDS, BOUNDS_MAX, key, compute)


_BOUNDS: OrderedDict[tuple[Any, ...], float] = OrderedDict()
