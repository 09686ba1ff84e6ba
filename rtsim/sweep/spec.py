"""Sweep files (TOML): parsing and validation into a frozen
[`SweepSpec`][rtsim.sweep.spec.SweepSpec] (the format and how grid names resolve:
docs/sweeps.md). Each point's changed base file goes through the normal loader, so a bad
value fails that point, not the sweep; any problem with the sweep file itself is a
`SweepError` naming the file and the key."""

from __future__ import annotations

import hashlib
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path
from typing import Any

from rtsim._suggest import did_you_mean
from rtsim.config.dotted import parse_assignment, resolve, shortcuts
from rtsim.config.load import validate
from rtsim.config.sweep import Scalar, SweepFile, read_sweep, sweep_special
from rtsim.errors import InputError, SweepError
from rtsim.io.limits import check as check_range
from rtsim.io.limits import read_input
from rtsim.registry import file_allows_code, load_code, reading_input
from rtsim.sweep.base import BaseFile
from rtsim.sweep.kinds import KINDS, canonical_json

__all__ = ["BaseFile", "SweepSpec", "load_sweep", "parse_sweep", "canonical_json", "Scalar"]


@dataclass(frozen=True)
class SweepSpec:
    """A validated sweep: what runs at each point, the grid, the seed and the metrics kept.

    ``targets`` maps each grid name to ``("seed",)``, ``("option", name)``,
    ``("path", key, key, ...)`` or ``("param", name)`` (kind ``call``), for the names of
    ``grid`` and of ``fixed`` (the ``[sweep.set]`` table, applied before the grid).
    """

    source: str
    text: str
    kind: str
    base: BaseFile | None
    seed: int
    combine: str
    grid: tuple[tuple[str, tuple[Scalar, ...]], ...]
    targets: Mapping[str, tuple[str, ...]]
    options: Mapping[str, Any] = field(default_factory=dict)
    metrics: tuple[str, ...] | None = None
    function: str | None = None
    name: str = ""
    fixed: tuple[tuple[str, Any], ...] = ()
    set_args: tuple[str, ...] = ()  # the command line's --set KEY=VALUE, as given
    #: the sweep's reader allowed code named in its files (not part of the fingerprint)
    allow_code: bool = field(default=False, compare=False)

    def resolved(self) -> dict[str, Any]:
        """Everything that determines the points and their results (the fingerprint's input)."""
        return {
            "kind": self.kind,
            "function": self.function,
            "base": None
            if self.base is None
            else {
                "path": self.base.path,
                "sha256": self.base.sha256,
                "data_sha256": self.base.data_sha256,
            },
            "seed": self.seed,
            "combine": self.combine,
            "grid": {k: list(v) for k, v in self.grid},
            "targets": {k: list(v) for k, v in self.targets.items()},
            "options": dict(self.options),
            "set": {k: v for k, v in self.fixed},
            **({"set_args": list(self.set_args)} if self.set_args else {}),
            "metrics": None if self.metrics is None else list(self.metrics),
        }

    def fingerprint(self) -> str:
        """sha256 of the resolved spec (base path excluded; the base file's parsed content
        included, so a change to its comments or layout alone keeps the fingerprint)."""
        return spec_fingerprint(self.resolved())

    def fingerprint_but_grid(self) -> str:
        """`fingerprint` without the grid's values: equal for two sweeps whose points
        with equal values give equal results (a grown grid keeps its finished points)."""
        return spec_fingerprint(self.resolved(), grid=False)


def spec_fingerprint(resolved: Mapping[str, Any], grid: bool = True) -> str:
    """sha256 of a resolved spec ([`SweepSpec.resolved`][rtsim.sweep.spec.SweepSpec.resolved], also
    as a manifest keeps it):
    the base file by its parsed content; ``grid=False`` leaves the grid's values out."""
    r = dict(resolved)
    if r.get("base") is not None:
        r["base"] = {"data_sha256": r["base"]["data_sha256"]}
    if not grid:
        r.pop("grid", None)
    return hashlib.sha256(canonical_json(r).encode("utf-8")).hexdigest()


# -- parameter resolution --------------------------------------------------------------
def _resolve(
    src: str,
    name: str,
    kind: str,
    base: BaseFile | None,
    data: dict[str, Any] | None,
    table: str = "grid",
) -> tuple[str, ...]:
    if name == "seed":
        if table != "grid":
            raise SweepError(f"{src}: {table}.seed: give the sweep's seed as sweep.seed")
        return ("seed",)
    if kind == "call":
        return ("param", name)
    spec = KINDS.resolve(kind, f"{src}: sweep.kind")
    if name in spec.options:
        return ("option", name)
    assert base is not None and data is not None
    bname = Path(base.path).name if base.path else base.source
    path = resolve(data, name, f"{src}: {table}.{name}", bname, SweepError)
    if path is not None:
        return ("path", *path)
    choices = list(spec.options) + ["seed"] + shortcuts(data)
    raise SweepError(
        f"{src}: {table}.{name}: unknown parameter (not an option of kind '{kind}', nor a key of "
        f"{bname}){did_you_mean(name, choices)}"
    )


# -- the file --------------------------------------------------------------------------
def _check_keys(src: str, table: str, got: Mapping[str, Any], allowed: tuple[str, ...]) -> None:
    """A kind's own option names (the keys of ``[sweep.options]``)."""
    for key in got:
        if key not in allowed:
            where = f"{table}.{key}" if table else key
            raise SweepError(f"{src}: unknown key '{where}'{did_you_mean(key, allowed)}")


def _load_base(src: str, kind: str, raw: Any, base_dir: Path) -> BaseFile | None:
    if kind == "call" and raw is None:
        return None
    if raw is None:
        if kind == "scenario":
            raise SweepError(f"{src}: sweep.base: required for kind 'scenario'")
        text = (resources.files("rtsim") / "data" / "barrel_robots.toml").read_text("utf-8")
        return BaseFile(None, text)
    if not isinstance(raw, str) or not raw:
        raise SweepError(f"{src}: sweep.base: expected a file path, got {raw!r}")
    path = (base_dir / raw).resolve()
    from rtsim.config.scenario import (  # lazy: only this needs numpy
        PACKAGED_SCENARIOS,
        PACKAGED_TASKSETS,
    )

    packaged = PACKAGED_SCENARIOS if kind == "scenario" else PACKAGED_TASKSETS
    if not path.exists() and raw in packaged:  # a file shipped with rtsim, by name
        sub = "scenarios/" if kind == "scenario" else ""
        text = (resources.files("rtsim") / "data" / f"{sub}{raw}.toml").read_text("utf-8")
        return BaseFile(None, text, raw)

    try:
        text = read_input(path, "task-set or scenario").decode("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SweepError(f"{src}: sweep.base: cannot read {path}: {exc}") from None
    try:
        tomllib.loads(text)
    except RecursionError:
        raise SweepError(f"{src}: sweep.base: {path} is nested too deeply to read") from None
    except tomllib.TOMLDecodeError as exc:
        raise SweepError(f"{src}: sweep.base: {path} is not valid TOML: {exc}") from None
    return BaseFile(str(path), text)


def _positive(v: Any) -> bool:
    return not isinstance(v, bool) and isinstance(v, int | float) and math.isfinite(v) and v > 0


#: What each run option accepts (checked once when the sweep file is read, so a bad value
#: is a bad sweep file — exit 2 — rather than a failure at every point).
_OPTION_CHECKS: dict[str, tuple[Any, str]] = {
    "horizon": (_positive, "a positive number of ms"),
    "window": (lambda v: v is None or _positive(v), "a positive number of ms"),
    "duration": (lambda v: v is None or _positive(v), "a positive number of seconds"),
    "exec": (lambda v: v in ("wcet", "uniform"), "'wcet' or 'uniform'"),
    "suspension": (lambda v: v in ("cpu", "idle"), "'cpu' or 'idle'"),
}


def _registered(name: str) -> Any:
    """The registry a plug-in option resolves in (``mode``: adjustment policies,
    ``scheduler``: scheduling policies), or None."""
    if name == "mode":
        from rtsim.control.policy import (  # lazy: only this needs numpy
            ADJUSTMENT_POLICIES,
        )

        return ADJUSTMENT_POLICIES
    if name == "scheduler":
        from rtsim.sim.policy import (  # lazy: only this needs numpy
            SCHEDULERS,
        )

        return SCHEDULERS
    return None


def _check_option(src: str, where: str, name: str, value: Any) -> None:
    registry = _registered(name)
    if registry is not None:  # a name, or code only when the sweep's reader allows it
        try:
            registry.resolve(value, f"{src}: {where}")
        except InputError as exc:
            raise SweepError(str(exc)) from None
        return
    check = _OPTION_CHECKS.get(name)
    if check is not None and not check[0](value):
        raise SweepError(f"{src}: {where}: must be {check[1]}, got {value!r}")
    if name in ("horizon", "window", "duration") and value is not None:
        check_range(f"option: --{name}", value, f"{src}: {where}", SweepError)


def parse_sweep(
    data: Mapping[str, Any],
    source: str,
    base_dir: str | Path = ".",
    text: str = "",
    set_: tuple[str, ...] = (),
    *,
    allow_code: bool | None = None,
) -> SweepSpec:
    """Validate a parsed sweep file; ``base_dir`` is where a relative ``base`` is found;
    ``set_``: ``KEY=VALUE`` changes of the base file at every point (the command line's
    ``--set``, applied over ``[sweep.set]``).

    ``allow_code``: the file (its ``function``, a ``mode`` or ``scheduler``, its base file) may
    name Python code as ``package.module:Name`` (`rtsim.registry`); default: only when
    the user opted in."""
    allow = file_allows_code(allow_code)
    with reading_input(allow):
        spec = _parse_sweep(data, source, Path(base_dir), text, tuple(set_))
    return replace(spec, allow_code=allow) if allow else spec


def _parse_sweep(
    data: Mapping[str, Any], source: str, base_dir: Path, text: str, set_: tuple[str, ...]
) -> SweepSpec:
    src = source

    model = validate(SweepFile, data, src, SweepError, special=sweep_special)
    sw = model.sweep
    kind = sw.kind
    if not KINDS.contains(kind):
        raise SweepError(
            f"{src}: sweep.kind: unknown kind {kind!r} (one of "
            f"{', '.join(KINDS)}){did_you_mean(kind, tuple(KINDS))}"
        )
    seed, combine, function = sw.seed, sw.combine, sw.function
    if kind == "call":
        if function is None or function.count(":") != 1:
            raise SweepError(
                f"{src}: sweep.function: kind 'call' needs "
                f"'package.module:function', got {function!r}"
            )

        try:
            fn = load_code(function, f"{src}: sweep.function")
        except InputError as exc:
            raise SweepError(str(exc)) from None
        if not callable(fn):
            raise SweepError(f"{src}: sweep.function: {function!r} is not callable")
    elif function is not None:
        raise SweepError(f"{src}: sweep.function: only for kind 'call', not {kind!r}")
    kspec = KINDS.resolve(kind, f"{src}: sweep.kind")
    options = sw.options
    if kind != "call":
        _check_keys(src, "sweep.options", options, kspec.options)
    metrics = None if sw.metrics is None else tuple(sw.metrics)
    if metrics is not None and kspec.metrics is not None:
        for m in metrics:
            if not kspec.knows_metric(m):
                raise SweepError(
                    f"{src}: sweep.metrics: unknown metric {m!r} for kind '{kind}' "
                    f"(known: {', '.join(kspec.metrics)})"
                    f"{did_you_mean(m, kspec.metrics)}"
                )
    name = sw.name

    base = _load_base(src, kind, sw.base, Path(base_dir))
    bdata = base.data() if base is not None else None
    grid = tuple(model.grid.items())
    if kind != "call" and base is None:  # pragma: no cover - _load_base always gives one
        raise SweepError(f"{src}: sweep.base: missing")
    for v in dict(grid).get("seed", ()):
        if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v < 2**63:
            raise SweepError(f"{src}: grid.seed: expected non-negative integers, got {v!r}")
    fixed_raw = sw.set
    targets = {str(k): _resolve(src, str(k), kind, base, bdata, "sweep.set") for k in fixed_raw}
    fixed_raw = dict(fixed_raw)
    if set_:  # --set KEY=VALUE: as [sweep.set], over it
        for key, value in (parse_assignment(t, SweepError) for t in set_):
            targets[key] = _resolve(src, key, kind, base, bdata, "--set")
            fixed_raw[key] = value
    fixed = tuple((str(k), v) for k, v in fixed_raw.items())
    both = [k for k, _ in grid if k in targets]
    if both:
        raise SweepError(f"{src}: grid.{both[0]}: also given in sweep.set")
    targets.update({k: _resolve(src, k, kind, base, bdata) for k, _ in grid})
    if combine == "zip":
        lengths = {k: len(v) for k, v in grid}
        if len(set(lengths.values())) > 1:
            desc = ", ".join(f"{k}={n}" for k, n in lengths.items())
            raise SweepError(f"{src}: grid: combine = 'zip' needs lists of equal length ({desc})")
    swept_options = {k for k, t in targets.items() if t[0] == "option"}  # grid or set
    if kind != "call":  # a call's options are its function's own business
        for k, v in options.items():
            _check_option(src, f"sweep.options.{k}", k, v)
        for k, values in grid:
            if k in swept_options:
                for v in values:
                    _check_option(src, f"grid.{k}", k, v)
        for k, v in fixed:
            if k in swept_options:
                _check_option(src, f"sweep.set.{k}", k, v)
    for req in kspec.required:
        if req not in options and req not in swept_options:
            raise SweepError(f"{src}: sweep.options.{req}: required for kind '{kind}'")
    return SweepSpec(
        source=src,
        text=text,
        kind=kind,
        base=base,
        seed=seed,
        combine=combine,
        grid=grid,
        targets=targets,
        options=dict(options),
        metrics=metrics,
        function=function,
        name=name,
        fixed=fixed,
        set_args=tuple(set_),
    )


def load_sweep(
    path: str | os.PathLike[str],
    set_: list[str] | tuple[str, ...] = (),
    *,
    allow_code: bool | None = None,
) -> SweepSpec:
    """Read (`rtsim.config.sweep.read_sweep`) and validate a sweep file, or a shipped
    example by name; ``set_``: ``KEY=VALUE`` changes of the base file at every point (the
    command line's ``--set``, applied over ``[sweep.set]``); ``allow_code``: as
    [`parse_sweep`][rtsim.sweep.spec.parse_sweep]."""
    data, source, base, text = read_sweep(path)
    try:
        return parse_sweep(data, source, base, text, tuple(set_), allow_code=allow_code)
    except RecursionError:
        raise SweepError(
            f"{source}: nested too deeply to read (tables or arrays within each other "
            f"hundreds of levels deep)"
        ) from None
