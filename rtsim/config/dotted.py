"""Dotted paths into a parsed TOML document: ``leader.speed``, ``tasks.command.wcet``.

One syntax for every place a user changes a file without editing it: a sweep's ``[grid]`` and
``[sweep.set]``, ``--set KEY=VALUE`` on the command line, and the library's ``overrides=``.
Tables are entered by key, arrays of tables by an entry's ``name`` or a 0-based index;
intermediate keys must exist, a new last key may be added (unless it looks like a typo of an
existing one: the model then checks it like any other key). Two shortcuts: a key of the
file's ``[window]`` table (``n``, ``r_H``, ...) and a key at the top level of the file.
"""

from __future__ import annotations

import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

from rtsim._suggest import did_you_mean
from rtsim.errors import InputError

__all__ = ["resolve", "shortcuts", "apply_paths", "parse_assignment", "Path"]

Path = tuple[str, ...]


def _walk(data: Any, keys: list[str], where: str, base: str, error: type[InputError]) -> None:
    """Check that dotted ``keys`` address a value (or a new leaf) in ``data``."""
    node = data
    where = f"{where}: unknown parameter path"
    for i, key in enumerate(keys):
        last = i == len(keys) - 1
        if isinstance(node, dict):
            if key in node:
                node = node[key]
                continue
            # a new leaf key is allowed (the model validates it) unless it looks like a typo
            hint = did_you_mean(key, [str(k) for k in node], 0.8 if last else 0.6)
            if last and not hint:
                return
            raise error(f"{where} (no key '{key}' in {base}{hint})")
        if isinstance(node, list):
            names = [e.get("name") for e in node if isinstance(e, dict)]
            if key in names:
                node = node[names.index(key)]
                continue
            if key.isdigit() and int(key) < len(node):
                node = node[int(key)]
                continue
            hint = did_you_mean(key, [str(n) for n in names if n is not None], 0.6)
            raise error(f"{where} (no entry named '{key}' in {base}{hint})")
        raise error(f"{where} ('{'.'.join(keys[:i])}' in {base} is a value, not a table)")


def resolve(
    data: Mapping[str, Any], name: str, where: str, base: str, error: type[InputError] = InputError
) -> Path | None:
    """The path ``name`` addresses in ``data`` (None: a plain name that is no shortcut).

    ``where`` prefixes an error (``<file>: grid.<name>``); ``base`` names the file in it.
    """
    if "." in name:
        keys = name.split(".")
        if not all(keys):
            raise error(f"{where}: empty key in the dotted path {name!r}")
        _walk(data, keys, where, base, error)
        return tuple(keys)
    window = data.get("window")
    if isinstance(window, dict) and name in window and name != "name":
        return ("window", name)
    if name in data and not isinstance(data[name], dict | list):
        return (name,)
    return None


def shortcuts(data: Mapping[str, Any]) -> list[str]:
    """The plain names `resolve` accepts in ``data`` (for a did-you-mean)."""
    window = data.get("window")
    out = [k for k in window if k != "name"] if isinstance(window, dict) else []
    return out + [k for k, v in data.items() if not isinstance(v, dict | list)]


def apply_paths(data: dict[str, Any], paths: Iterable[tuple[Path, Any]]) -> dict[str, Any]:
    """Set each path (tables by key, arrays of tables by ``name`` or index) in ``data``."""
    for path, value in paths:
        node: Any = data
        for key in path[:-1]:
            if isinstance(node, list):
                named = [e for e in node if isinstance(e, dict) and e.get("name") == key]
                node = named[0] if named else node[int(key)]
            else:
                node = node[key]
        node[path[-1]] = value
    return data


def apply_overrides(
    data: dict[str, Any],
    overrides: Mapping[str, Any],
    source: str,
    error: type[InputError] = InputError,
    table: str = "overrides",
    options: Iterable[str] = (),
) -> dict[str, Any]:
    """Apply ``overrides`` (dotted name → value) to the TOML dict ``data`` in place.

    ``options``: names that are run options rather than keys of the file (an error that says
    to pass them as arguments). Errors are ``error`` naming ``source`` and
    ``<table>.<name>``.
    """
    if not isinstance(overrides, Mapping):
        raise error(
            f"{source}: {table}: expected a mapping of dotted paths to values, "
            f"got {type(overrides).__name__}"
        )
    options = tuple(options)
    paths = []
    for name, value in overrides.items():
        if not isinstance(name, str) or not name:
            raise error(f"{source}: {table}: keys must be dotted paths, got {name!r}")
        where = f"{source}: {table}.{name}"
        if name in options:
            raise error(
                f"{where}: a run option ({', '.join(options)}), not a key of the "
                "file: pass it as an argument"
            )
        path = resolve(data, name, where, source, error)
        if path is None:
            raise error(
                f"{where}: unknown parameter (not a key of {source})"
                f"{did_you_mean(name, shortcuts(data))}"
            )
        paths.append((path, value))
    return apply_paths(data, paths)


def parse_assignment(
    text: str, error: type[InputError] = InputError, flag: str = "--set"
) -> tuple[str, Any]:
    """``KEY=VALUE`` → (key, value): the value read as a TOML value (``4``, ``2.5``, ``true``,
    ``"text"``, ``[1, 2]``, ``inf``), a bare word as a string (``left``). A line break is
    refused: TOML would read the rest as further keys, which the value would silently drop."""
    if "\n" in text or "\r" in text:
        raise error(f"{flag} {text!r}: has a line break; give one KEY=VALUE per {flag}")
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise error(
            f"{flag} {text!r}: expected KEY=VALUE (a dotted key such as formation.followers=4)"
        )
    raw = raw.strip()
    try:
        value = tomllib.loads(f"v = {raw}")["v"]
    except tomllib.TOMLDecodeError:
        if not raw or any(c in raw for c in "\"'[]{}=\n"):
            raise error(f"{flag} {text!r}: cannot read {raw!r} as a TOML value") from None
        value = raw  # a bare word: a string
    return key, value
