"""Dotted-path overrides of a scenario or task-set file, for the library and for sweeps.

``load_scenario("test2", overrides={"leader.speed": 20, "formation.followers": 4})`` changes
the parsed TOML document before it goes through the normal loader, exactly as a sweep's
``[sweep.set]`` and ``[grid]`` entries do: the same path resolution (:func:`resolve_path`:
tables by key, lists of tables by ``name`` or 0-based index, shortcuts for ``[window]`` and
top-level keys), the same typo check, the same :func:`apply_overrides`, and the loader's own
validation of the changed values — so a notebook and a sweep accept and refuse the same
paths with the same messages (:mod:`rtsim.sweep.spec` uses this module).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rtsim.errors import InputError, SweepError
from rtsim.registry import did_you_mean

__all__ = ["RUN_OPTIONS", "apply_dotted_overrides", "apply_overrides", "resolve_path",
           "walk_path"]

#: The run options (not keys of the file) of the sweep kinds that have a base file.
RUN_OPTIONS: dict[str, tuple[str, ...]] = {
    "simulate": ("horizon", "exec", "suspension", "window", "scheduler"),
    "scenario": ("mode", "duration", "exec", "scheduler"),
}


def apply_overrides(data: dict[str, Any], overrides: tuple[tuple[tuple[str, ...], Any], ...]
                    ) -> dict[str, Any]:
    """Set each dotted path (tables by key, lists of tables by ``name`` or index) in ``data``."""
    for path, value in overrides:
        node: Any = data
        for key in path[:-1]:
            if isinstance(node, list):
                named = [e for e in node if isinstance(e, dict) and e.get("name") == key]
                node = named[0] if named else node[int(key)]
            else:
                node = node[key]
        node[path[-1]] = value
    return data


def walk_path(data: Any, keys: list[str], src: str, name: str, base: str, table: str) -> None:
    """Check that dotted ``keys`` address a value (or a new leaf) in ``data``."""
    node = data
    for i, key in enumerate(keys):
        last = i == len(keys) - 1
        where = f"{src}: {table}.{name}: unknown parameter path"
        if isinstance(node, dict):
            if key in node:
                node = node[key]
                continue
            # a new leaf key is allowed (the loader validates it) unless it looks like a typo
            hint = did_you_mean(key, [str(k) for k in node], 0.8 if last else 0.6)
            if last and not hint:
                return
            raise SweepError(f"{where} (no key '{key}' in {base}{hint})")
        if isinstance(node, list):
            names = [e.get("name") for e in node if isinstance(e, dict)]
            if key in names:
                node = node[names.index(key)]
                continue
            if key.isdigit() and int(key) < len(node):
                node = node[int(key)]
                continue
            hint = did_you_mean(key, [str(n) for n in names if n is not None])
            raise SweepError(f"{where} (no entry named '{key}' in {base}{hint})")
        raise SweepError(f"{where} ('{'.'.join(keys[:i])}' in {base} is a value, not a table)")


def resolve_path(src: str, name: str, data: dict[str, Any], bname: str, table: str,
                 kind: str, options: tuple[str, ...]) -> tuple[str, ...]:
    """``("path", key, ...)`` for the dotted ``name`` in the file ``data`` (named ``bname``),
    or a :class:`SweepError` with a did-you-mean among ``options`` and the file's keys."""
    if "." in name:
        keys = name.split(".")
        walk_path(data, keys, src, name, bname, table)
        return ("path", *keys)
    window = data.get("window")
    if isinstance(window, dict) and name in window and name != "name":
        return ("path", "window", name)
    if name in data and not isinstance(data[name], dict | list):
        return ("path", name)
    choices = list(options) + ["seed"]
    if isinstance(window, dict):
        choices += [k for k in window if k != "name"]
    choices += [k for k, v in data.items() if not isinstance(v, dict | list)]
    raise SweepError(
        f"{src}: {table}.{name}: unknown parameter (not an option of kind '{kind}', nor a key of "
        f"{bname}){did_you_mean(name, choices)}"
    )


def apply_dotted_overrides(data: dict[str, Any], overrides: Mapping[str, Any], source: str,
                           kind: str = "scenario") -> dict[str, Any]:
    """Apply ``overrides`` (dotted path -> value) to the TOML dict ``data`` in place.

    ``kind``: ``scenario`` or ``simulate`` (a task-set file); decides which names are run
    options of a sweep, which are refused here (pass them as arguments instead).
    Raises :class:`~rtsim.errors.SweepError` (an InputError) naming ``source`` and the path.
    """
    if not isinstance(overrides, Mapping):
        raise InputError(f"{source}: overrides: expected a mapping of dotted paths to values, "
                         f"got {type(overrides).__name__}")
    options = RUN_OPTIONS[kind]
    paths = []
    for name, value in overrides.items():
        if not isinstance(name, str) or not name:
            raise InputError(f"{source}: overrides: keys must be dotted paths, got {name!r}")
        if name == "seed":
            raise SweepError(f"{source}: overrides.seed: give the sweep's seed as sweep.seed")
        if name in options:
            raise InputError(f"{source}: overrides.{name}: a run option "
                             f"({', '.join(options)}), not a key of the file: pass it as an "
                             f"argument")
        bname = Path(source).name or source
        paths.append((resolve_path(source, name, data, bname, "overrides", kind, options)[1:],
                      value))
    return apply_overrides(data, tuple(paths))
