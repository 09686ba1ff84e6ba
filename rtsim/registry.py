"""One registry for every plug-in seam, and the one place that loads ``package.module:Name``.

A `Registry` maps names to plug-ins of one kind (scheduling policies, adjustment
policies, predictors, execution-time models, follower models, exporters, sweep kinds). A name
resolves, in this order, to

1. a plug-in registered in this process (the built-ins register themselves on import);
2. an installed entry point of the registry's group (``rtsim.schedulers``,
   ``rtsim.policies``, ...; the Python convention pytest and Sphinx use for their plug-ins);
3. ``"package.module:Name"``: an object imported from a module — **code**. It is loaded only
   when code is allowed (`code_allowed`).

Code is allowed by default in the library: a ``module:Name`` passed to a function is the
caller's own choice. Reading an input file switches it off (`reading_input`): a name
written in a task-set, scenario or sweep file resolves only to registered and entry-point
plug-ins unless the user opts in with ``--allow-code`` on the command line or
``allow_code=True`` in the API. A refused name is an `InputError` that
says how to opt in; its module is not imported. When code is loaded, the current directory is
importable (as ``python -m`` and pytest make it), so ``--policy mymod:MyPolicy`` works from
the directory that holds ``mymod.py``.

This module is at the bottom of the package: it imports only `rtsim.errors` and
`rtsim._suggest` (the did-you-mean, re-exported here).
"""

from __future__ import annotations

import contextlib
import importlib
import os
import re
import sys
from collections.abc import Callable, Iterator, Mapping, MutableMapping
from contextvars import ContextVar
from typing import Any, Generic, TypeVar

from rtsim._suggest import did_you_mean
from rtsim.errors import InputError

__all__ = [
    "Registry",
    "code_allowed",
    "did_you_mean",
    "file_allows_code",
    "is_code_spec",
    "load_code",
    "opted_in",
    "reading_input",
]

T = TypeVar("T")

#: ``package.module:Name`` (dotted identifiers on both sides of one colon).
_CODE_SPEC = re.compile(r"[A-Za-z_]\w*(\.[A-Za-z_]\w*)*:[A-Za-z_]\w*(\.[A-Za-z_]\w*)*")

#: While an input file is read: whether code named in it may load (None: no file is being
#: read, so a name comes from the caller and code may load).
_IN_FILE: ContextVar[bool | None] = ContextVar("rtsim_code_in_file", default=None)
#: The user opted in for the files read now (the command line's ``--allow-code``).
_OPTED_IN: ContextVar[bool] = ContextVar("rtsim_code_opted_in", default=False)

#: How a user opts in, named in every refusal.
OPT_IN = "pass --allow-code (allow_code=True in the API) to allow it"


def is_code_spec(spec: object) -> bool:
    """Whether ``spec`` is a string that names code (it contains a colon)."""
    return isinstance(spec, str) and ":" in spec


def code_allowed() -> bool:
    """Whether a ``module:Name`` may be imported now: always, unless an input file is being
    read without the user's opt-in (`reading_input`)."""
    state = _IN_FILE.get()
    return True if state is None else state


@contextlib.contextmanager
def reading_input(allow_code: bool | None = None) -> Iterator[None]:
    """While an input file is read: code named in it loads only if ``allow_code``. ``None``:
    as the file that names this one (a scenario's task set), else as the user opted in
    (`opted_in`), else not."""
    if allow_code is None:
        outer = _IN_FILE.get()
        allow_code = _OPTED_IN.get() if outer is None else outer
    token = _IN_FILE.set(bool(allow_code))
    try:
        yield
    finally:
        _IN_FILE.reset(token)


@contextlib.contextmanager
def opted_in(allow: bool = True) -> Iterator[None]:
    """Code named in the input files read within may load (``--allow-code``)."""
    token = _OPTED_IN.set(bool(allow))
    try:
        yield
    finally:
        _OPTED_IN.reset(token)


def file_allows_code(allow_code: bool | None = None) -> bool:
    """What `reading_input` ``(allow_code)`` would allow: for an API call that must pass
    the decision on (a sweep's points, run in other processes)."""
    if allow_code is not None:
        return bool(allow_code)
    outer = _IN_FILE.get()
    return _OPTED_IN.get() if outer is None else outer


def load_code(spec: str, where: str, *, allow_code: bool | None = None) -> Any:
    """The object ``"package.module:Name"`` names.

    Malformed strings, refused code (``allow_code`` False, or None and not
    `code_allowed`) and failed imports are one-line `InputError` s naming
    ``where``; a refused module is never imported."""
    if not isinstance(spec, str) or not _CODE_SPEC.fullmatch(spec):
        raise InputError(f"{where}: {spec!r} is not 'package.module:Name'")
    allowed = code_allowed() if allow_code is None else allow_code
    if not allowed:
        raise InputError(
            f"{where}: {spec!r} names Python code, which an input file loads "
            f"only when asked: {OPT_IN}"
        )
    mod, _, attr = spec.partition(":")
    cwd = os.getcwd()
    if cwd not in sys.path and "" not in sys.path:
        sys.path.append(cwd)
    try:
        obj: Any = importlib.import_module(mod)
        for part in attr.split("."):
            obj = getattr(obj, part)
    except (ImportError, AttributeError) as exc:
        raise InputError(f"{where}: cannot load {spec!r}: {exc}") from None
    return obj


def _entry_points(**select: str) -> Any:
    """``importlib.metadata.entry_points(**select)``, imported when a plug-in is first looked
    up (importing it costs every command ≈ 40 ms at start-up otherwise)."""
    from importlib import metadata

    return metadata.entry_points(**select)


class Registry(MutableMapping[str, T], Generic[T]):
    """Plug-ins of one kind by name (module doc): a mutable mapping of the registered ones,
    with `resolve` for names, entry points and ``module:Name``.

    ``kind``: what a plug-in is, for messages ("scheduling policy"); ``group``: the entry-point
    group; ``check(obj, spec, where)``: validates (and may convert) a plug-in loaded from an
    entry point or from code (``spec`` the name it was loaded by), raising
    `InputError`."""

    def __init__(
        self,
        kind: str,
        group: str,
        check: Callable[[Any, str, str], T] | None = None,
        renamed: Mapping[str, str] | None = None,
    ) -> None:
        self.kind = kind
        self.group = group
        self._check = check
        #: old names and their new ones: an old name is an error that names its replacement
        self.renamed: dict[str, str] = dict(renamed or {})
        self._items: dict[str, T] = {}

    # -- the mapping of registered plug-ins ----------------------------------------------
    def __getitem__(self, name: str) -> T:
        return self._items[name]

    def __setitem__(self, name: str, value: T) -> None:
        self._items[name] = value

    def __delitem__(self, name: str) -> None:
        del self._items[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, {self.group!r}, {sorted(self._items)})"

    def register(self, name: str, value: T) -> T:
        """Register ``value`` under ``name`` (replacing one of that name); returns it."""
        if not isinstance(name, str) or not name or ":" in name:
            raise TypeError(f"a {self.kind} needs a non-empty name without ':', got {name!r}")
        self._items[name] = value
        return value

    # -- resolution ---------------------------------------------------------------------
    def entry_point(self, name: str) -> Any | None:
        """The object of the installed entry point ``name`` of `group`, or None."""
        for ep in _entry_points(group=self.group, name=name):
            return ep.load()
        return None

    def known(self) -> list[str]:
        """Registered names, then installed entry points' names."""
        names = list(self._items)
        names += [ep.name for ep in _entry_points(group=self.group) if ep.name not in self._items]
        return names

    def contains(self, name: object) -> bool:
        """Whether ``name`` resolves without code (registered or an entry point)."""
        if not isinstance(name, str):
            return False
        return name in self._items or bool(_entry_points(group=self.group, name=name))

    def resolve(self, spec: str, where: str, *, allow_code: bool | None = None) -> T:
        """The plug-in ``spec`` names: registered, an entry point, or ``module:Name`` (code:
        see `load_code`). An unknown name is an `InputError` with a
        did-you-mean."""
        if isinstance(spec, str) and spec in self._items:
            return self._items[spec]
        if is_code_spec(spec):
            return self._checked(load_code(spec, where, allow_code=allow_code), spec, where)
        obj = self.entry_point(spec) if isinstance(spec, str) and spec else None
        if obj is not None:
            value = self._checked(obj, spec, where)
            self._items[spec] = value
            return value
        known = self.known()
        raise InputError(
            f"{where}: must be one of {', '.join(known)} or "
            f"'package.module:Name', got {spec!r}"
            f"{did_you_mean(spec, known, renamed=self.renamed)}"
        )

    def _checked(self, obj: Any, spec: str, where: str) -> T:
        if self._check is None:
            return obj  # type: ignore[no-any-return]
        return self._check(obj, spec, f"{where}: {spec!r}")
