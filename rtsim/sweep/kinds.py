"""What runs at a sweep point: the registry of kinds (``bounds``, ``analyze``, ``simulate``,
``scenario``, ``call``). A kind is a function ``fn(point: PointInput) -> dict[str, scalar]``
of flat, deterministic metrics that declares its options and metric names. Each kind's
metrics and options: docs/sweeps.md.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import math
from collections import OrderedDict
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path
from types import ModuleType
from typing import Any

from rtsim.analysis.sufficient import window_or_w_sch
from rtsim.config.taskset import parse_taskset
from rtsim.errors import InputError
from rtsim.io.work import check_simulate
from rtsim.model.taskset import TaskSet
from rtsim.overrides import RUN_OPTIONS, apply_overrides
from rtsim.registry import Registry, load_code
from rtsim.sweep.base import BaseFile, _parsed

__all__ = ["PointInput", "KindSpec", "KINDS", "register_kind", "apply_overrides"]


def canonical_json(obj: Any) -> str:
    """Compact, key-sorted JSON: the text that seeds and fingerprints are hashed from."""
    return json.dumps(obj, sort_keys=True, separators=(",", ":"), allow_nan=True)


@dataclass(frozen=True)
class PointInput:
    """Everything one point needs, picklable so that it can travel to any worker."""

    index: int
    kind: str
    params: Mapping[str, Any]
    options: Mapping[str, Any]
    seed: int
    base: BaseFile | None = None
    overrides: tuple[tuple[tuple[str, ...], Any], ...] = ()
    function: str | None = None
    #: the sweep's reader allowed code named in its files (`rtsim.registry`)
    allow_code: bool = False

    def base_data(self) -> dict[str, Any]:
        """The base file's TOML dict with this point's overrides applied."""
        if self.base is None:
            raise RuntimeError("this sweep has no base file")
        return apply_overrides(self.base.data(), self.overrides)

    def taskset(self) -> TaskSet:
        """The base task set with this point's overrides, through the normal loader."""
        assert self.base is not None
        return parse_taskset(self.base_data(), self.base.source, allow_code=self.allow_code)

    def simulate_options(self) -> dict[str, Any]:
        """The keyword options of `rtsim.sim.simulate` a ``simulate`` point runs with: its
        seed and its ``exec``, ``suspension``, ``window`` and ``scheduler`` options."""
        o = self.options
        kwargs: dict[str, Any] = {
            "seed": self.seed,
            "exec_model": o.get("exec", "wcet"),
            "suspension": o.get("suspension", "cpu"),
        }
        if o.get("window") is not None:
            kwargs["window"] = float(o["window"])
        if "scheduler" in o:
            kwargs["scheduler"] = o["scheduler"]
        return kwargs


@dataclass(frozen=True)
class KindSpec:
    """A kind: its function, the options it takes (and requires), the metrics it gives."""

    name: str
    fn: Callable[[PointInput], dict[str, Any]]
    options: tuple[str, ...] = ()
    required: tuple[str, ...] = ()
    metrics: tuple[str, ...] | None = None  # None: not known in advance
    modules: tuple[str, ...] = ()  # imported before forking workers, so they inherit them
    #: called with the first point before a process pool starts (the scenario kind compiles
    #: the world's kernels there once, not once per worker: rtsim.coupling.warm)
    warm: Callable[[PointInput], Any] | None = field(default=None, compare=False)
    doc: str = field(default="", compare=False)

    def preload(self) -> None:
        """Import `modules` now (best effort: a missing one fails at its points)."""
        for name in self.modules:
            try:
                importlib.import_module(name)
            except ImportError:
                pass

    def knows_metric(self, name: str) -> bool:
        """Whether ``name`` (a name or a glob pattern) can be produced by this kind."""
        if self.metrics is None:
            return True
        return any(name == p or fnmatchcase(name, p) for p in self.metrics)


def _need(module: str, kind: str) -> ModuleType:
    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        raise RuntimeError(
            f"kind '{kind}' needs {module}, which is not available ({exc})"
        ) from None


def _num(v: Any) -> float:
    return math.nan if v is None else float(v)


def _bounds(p: PointInput) -> dict[str, Any]:
    mod = _need("rtsim.analysis.bounds", "bounds")
    wb = mod.window_bounds(p.taskset())
    return {
        k: float(getattr(wb, k))
        for k in ("e_hough", "g", "w_eq7", "w_eq11", "w_sch", "w_rta", "w_susp", "w_edf")
    }


def _analyze(p: PointInput) -> dict[str, Any]:
    ts = p.taskset()
    policies = _need("rtsim.sim.policy", "analyze")
    name = p.options.get("scheduler", ts.scheduler)
    fn = policies.SCHEDULERS.resolve(name, "scheduler", allow_code=p.allow_code).analysis
    if fn is None:
        raise InputError(f"scheduler: the scheduling policy {name!r} has no analysis")
    w = p.options.get("window")
    a = fn(ts) if w is None else fn(ts, w=float(w))
    out: dict[str, Any] = {"schedulable": bool(a.schedulable), "utilization": float(a.utilization)}
    for t in a.tasks:
        out[f"wcrt.{t.name}"] = _num(t.wcrt)
    for t in a.tasks:
        out[f"schedulable.{t.name}"] = bool(t.schedulable)
    return out


def _simulate(p: PointInput) -> dict[str, Any]:
    mod = _need("rtsim.sim", "simulate")
    ts = p.taskset()
    o = p.options
    kwargs = p.simulate_options()
    w_est = kwargs.get("window")
    if ts.window is not None:
        w_est = window_or_w_sch(ts, w_est)  # (simulate decides its window the same way)
    check_simulate(ts, float(o["horizon"]), w_est, f"sweep.options.horizon {o['horizon']}")
    res = mod.simulate(ts, float(o["horizon"]), **kwargs)
    out: dict[str, Any] = {}
    if res.window is not None and "w" in res.window:
        out["w"] = float(res.window["w"])
    for name, s in res.tasks.items():
        out[f"max_response.{name}"] = _num(s.max_response)
        out[f"mean_response.{name}"] = _num(s.mean_response)
        out[f"misses.{name}"] = int(s.misses)
        out[f"jobs.{name}"] = int(s.completed)
    out["misses"] = sum(int(s.misses) for s in res.tasks.values())
    out["jobs"] = sum(int(s.completed) for s in res.tasks.values())
    return out


def _flatten(obj: Any, prefix: str = "") -> dict[str, Any]:
    out: dict[str, Any] = {}
    if isinstance(obj, Mapping):
        for k, v in obj.items():
            out.update(_flatten(v, f"{prefix}{k}."))
    elif isinstance(obj, bool | int | float | str):
        out[prefix[:-1]] = obj
    return out


#: Prepared scenarios a worker keeps (`_prepared`), most recent last.
_PREPARED: OrderedDict[str, tuple[Any, Any]] = OrderedDict()
_PREPARED_MAX = 16


def forget_prepared() -> None:
    """Forget what this process prepared for its points — the scenarios, the base file's
    parse, the task sets built, the bounds and settled speeds (a benchmark's or a test's
    fresh start)."""
    from rtsim.config.scenario import _built_taskset  # lazy: as _need, only scenarios use it
    from rtsim.coupling.prepared import clear  # lazy: only this needs pandas (as _need)

    _PREPARED.clear()
    _parsed.cache_clear()
    _built_taskset.cache_clear()
    clear()


def _prepared(p: PointInput, data: dict[str, Any], where: Path | None) -> tuple[Any, Any]:
    """(Scenario, ScenarioInputs) of ``data``, parsed and prepared once per worker process
    for each distinct content (points that differ only in seed or run options — mode,
    duration — share them): the key is the base file's name, its folder and the canonical
    JSON of the data with the point's overrides applied."""
    assert p.base is not None
    key = hashlib.sha256(
        "\0".join((p.base.source, str(where), canonical_json(data))).encode()
    ).hexdigest()
    hit = _PREPARED.get(key)
    if hit is not None:
        _PREPARED.move_to_end(key)
        return hit
    io = _need("rtsim.config.scenario", "scenario")
    coupling = _need("rtsim.coupling", "scenario")
    scenario = io.parse_scenario(data, p.base.source, base=where, allow_code=p.allow_code)
    hit = (scenario, coupling.scenario_inputs(scenario))
    _PREPARED[key] = hit
    if len(_PREPARED) > _PREPARED_MAX:
        _PREPARED.popitem(last=False)
    return hit


def _point_scenario(p: PointInput) -> tuple[Any, Any]:
    """(Scenario, ScenarioInputs) of a scenario point (`_prepared`)."""
    assert p.base is not None
    where = Path(p.base.path).parent if p.base.path else None
    data = p.base_data()
    if "scheduler" in p.options:
        data.setdefault("scheduler", {})["policy"] = p.options["scheduler"]
    return _prepared(p, data, where)


def _warm_scenario(p: PointInput) -> None:
    """The compiled world's kernels made ready when point ``p`` runs compiled (best effort:
    a point that cannot be read fails in its worker, recorded)."""
    try:
        scenario, _ = _point_scenario(p)
    except Exception:
        return
    from rtsim.coupling.warm import warm_world  # lazy: only this needs pandas (as _need)

    warm_world([scenario])


def _scenario(p: PointInput) -> dict[str, Any]:
    coupling = _need("rtsim.coupling", "scenario")
    assert p.base is not None
    o = p.options
    scenario, inputs = _point_scenario(p)
    kwargs: dict[str, Any] = {"seed": p.seed, "record_jobs": False, "windows": False}
    if "mode" in o:
        kwargs["policy"] = o["mode"]
    if "duration" in o:
        kwargs["duration_s"] = float(o["duration"])
    if "exec" in o:
        kwargs["exec_model"] = o["exec"]
    from rtsim.coupling.duration import check_scenario  # lazy: only this needs pandas

    check_scenario(scenario, kwargs.get("duration_s"), f"{p.base.source}: duration")
    summary = dict(coupling.run_scenario(inputs, **kwargs).summary)
    summary.pop("seed", None)  # the point's seed is its own column
    return _flatten(summary)


def _call(p: PointInput) -> dict[str, Any]:
    assert p.function is not None
    fn = load_code(p.function, "sweep.function", allow_code=p.allow_code)
    return fn(dict(p.params), dict(p.options), p.seed)


def _kind_spec(obj: Any, spec: str, where: str) -> KindSpec:
    if isinstance(obj, KindSpec):
        return obj
    raise InputError(f"{where} is not a KindSpec")


#: The sweep kinds by name (entry-point group ``rtsim.sweep_kinds``, each a
#: [`KindSpec`][rtsim.sweep.kinds.KindSpec]).
KINDS: Registry[KindSpec] = Registry("sweep kind", "rtsim.sweep_kinds", _kind_spec)


def register_kind(spec: KindSpec) -> None:
    """Add (or replace) a kind in this process's registry."""
    KINDS.register(spec.name, spec)


_LOADER = ("rtsim.config.taskset",)
register_kind(
    KindSpec(
        "bounds",
        _bounds,
        metrics=("e_hough", "g", "w_eq7", "w_eq11", "w_sch", "w_rta", "w_susp", "w_edf"),
        modules=(*_LOADER, "rtsim.analysis.bounds"),
    )
)
register_kind(
    KindSpec(
        "analyze",
        _analyze,
        options=("window", "scheduler"),
        metrics=("schedulable", "utilization", "wcrt.*", "schedulable.*"),
        modules=(*_LOADER, "rtsim.sim.policy"),
    )
)
register_kind(
    KindSpec(
        "simulate",
        _simulate,
        options=RUN_OPTIONS["simulate"],
        required=("horizon",),
        modules=(*_LOADER, "rtsim.sim"),
        metrics=("w", "max_response.*", "mean_response.*", "misses.*", "jobs.*", "misses", "jobs"),
    )
)
register_kind(
    KindSpec(
        "scenario",
        _scenario,
        options=RUN_OPTIONS["scenario"],
        modules=("rtsim.config.scenario", "rtsim.coupling"),
        warm=_warm_scenario,
    )
)
register_kind(KindSpec("call", _call))
