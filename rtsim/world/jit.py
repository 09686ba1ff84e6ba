"""Kernel sources: plain Python functions that numba compiles for the ``compiled`` backend.

A function marked with :func:`kernel` stays the plain function it is (the ``python`` backend
and every Python caller run it as Python; numba is not imported). :func:`build` turns one
into a numba dispatcher on demand, together with the kernel sources it calls (found in its
code, by name in its module's globals): each callee is compiled first and the caller is
compiled against a copy of its globals in which the callees' names are their dispatchers, so
a kernel may call kernel sources of any module and the module's own names stay Python. The
compile order is derived from the calls; nothing lists it by hand.

**Cache.** numba's own on-disk cache (``cache=True``) checks only the file that defines a
kernel, so a kernel calling an edited function of another module would load a stale build.
Here each compiled kernel is cached in a directory named by :func:`source_key`, a hash of
the source text of the kernel and of every kernel source it reaches, and of the values of
the other globals they read (numba freezes those at compile time): an edit anywhere in that
closure is a new directory, hence a fresh compile. The directories live under
``NUMBA_CACHE_DIR`` when the user sets it (numba's own setting), else in ``__pycache__`` next
to this file, else in numba's user-wide cache directory.
"""

from __future__ import annotations

import functools
import hashlib
import inspect
import os
import types
from collections.abc import Callable, Iterator
from typing import Any, TypeVar

__all__ = ["build", "cache_root", "dependencies", "is_kernel", "kernel", "source_key"]

F = TypeVar("F", bound=Callable[..., Any])

_MARK = "__rtsim_kernel__"
_COMPILED: dict[Callable[..., Any], Any] = {}


def kernel(fn: F | None = None, *, inline: bool = False) -> Any:
    """Mark ``fn`` as a kernel source (returned unchanged). ``inline``: numba inlines it into
    its callers instead of compiling it on its own (a large helper called once)."""

    def mark(f: F) -> F:
        setattr(f, _MARK, {"inline": inline})
        return f

    return mark if fn is None else mark(fn)


def is_kernel(obj: Any) -> bool:
    """Whether ``obj`` is a function marked by :func:`kernel`."""
    return isinstance(obj, types.FunctionType) and hasattr(obj, _MARK)


def _names(code: types.CodeType) -> Iterator[str]:
    yield from code.co_names
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            yield from _names(const)


def dependencies(fn: Callable[..., Any]) -> tuple[dict[str, Callable[..., Any]], dict[str, Any]]:
    """The kernel sources ``fn`` calls by name, and the other plain values (numbers, strings,
    tuples of them) it reads from its globals: two name → object dicts."""
    glob = fn.__globals__  # type: ignore[attr-defined]
    calls: dict[str, Callable[..., Any]] = {}
    values: dict[str, Any] = {}
    for name in dict.fromkeys(_names(fn.__code__)):  # type: ignore[attr-defined]
        if name not in glob:
            continue
        obj = glob[name]
        if is_kernel(obj):
            calls[name] = obj
        elif isinstance(obj, int | float | str | bool | tuple | type(None)):
            values[name] = obj
    return calls, values


def _closure(fn: Callable[..., Any], seen: dict[Callable[..., Any], None]) -> None:
    if fn in seen:
        return
    seen[fn] = None
    for dep in dependencies(fn)[0].values():
        _closure(dep, seen)


@functools.cache
def _digest(fn: Callable[..., Any]) -> bytes:
    """The hash of one function's part of a source key: its name, source text, options and
    the plain values it reads."""
    h = hashlib.sha256(f"{fn.__module__}.{fn.__qualname__}\n".encode())
    h.update(inspect.getsource(fn).encode())
    h.update(repr(sorted(dependencies(fn)[1].items())).encode())
    h.update(repr(getattr(fn, _MARK, None)).encode())
    return h.digest()


def source_key(fn: Callable[..., Any]) -> str:
    """A hash of the source text of ``fn`` and of every kernel source it reaches (its module
    and name too), and of the values of the other globals they read: the name of the
    directory ``fn``'s compiled code is cached in (module docstring)."""
    seen: dict[Callable[..., Any], None] = {}
    _closure(fn, seen)
    h = hashlib.sha256()
    for d in sorted(_digest(f) for f in seen):
        h.update(d)
    return h.hexdigest()[:24]


def build(fn: Callable[..., Any]) -> Any:
    """The numba dispatcher of kernel source ``fn`` (made once per process; its callees
    first), cached on disk by :func:`source_key`. Imports numba."""
    done = _COMPILED.get(fn)
    if done is not None:
        return done
    import numba

    calls, _ = dependencies(fn)
    glob = dict(fn.__globals__)  # type: ignore[attr-defined]
    for name, dep in calls.items():
        if dep is fn:
            raise TypeError(f"kernel {fn.__qualname__} calls itself (numba cannot)")
        glob[name] = build(dep)
    clone = types.FunctionType(
        fn.__code__,  # type: ignore[attr-defined]
        glob,
        fn.__name__,
        fn.__defaults__,  # type: ignore[attr-defined]
        fn.__closure__,  # type: ignore[attr-defined]
    )
    clone.__qualname__ = fn.__qualname__
    clone.__module__ = fn.__module__
    clone.__doc__ = fn.__doc__
    opts = getattr(fn, _MARK, {})
    out: Any
    if opts.get("inline"):
        out = numba.njit(nogil=True, inline="always")(clone)
    else:
        out = numba.njit(nogil=True)(clone)
        root = cache_root()
        if root is not None:  # else uncached, as numba leaves a kernel it cannot cache
            out._cache = _keyed_cache_class()(clone, os.path.join(root, source_key(fn)))
    _COMPILED[fn] = out
    return out


def cache_root() -> str | None:
    """Where the compiled kernels are cached: ``NUMBA_CACHE_DIR``/rtsim-kernels when set,
    else ``__pycache__/rtsim-kernels`` next to this file when writable, else numba's
    user-wide cache directory's rtsim-kernels; None when none is writable."""
    from numba.core import config

    candidates = []
    user_dir = getattr(config, "CACHE_DIR", "")  # NUMBA_CACHE_DIR, read by numba
    if user_dir:
        candidates.append(os.path.join(user_dir, "rtsim-kernels"))
    else:
        candidates.append(os.path.join(os.path.dirname(__file__), "__pycache__", "rtsim-kernels"))
        from numba.misc.appdirs import AppDirs

        user = AppDirs(appname="numba", appauthor=False).user_cache_dir
        candidates.append(os.path.join(user, "rtsim-kernels"))
    for path in candidates:
        try:
            os.makedirs(path, exist_ok=True)
            if os.access(path, os.W_OK):
                return path
        except OSError:
            continue
    return None


_CACHE_CLASS: Any = None


def _keyed_cache_class() -> Any:
    """numba's FunctionCache with one locator: the directory it is given, named by the
    source key, which is also its source stamp (built on first use: numba is imported
    then)."""
    global _CACHE_CLASS
    if _CACHE_CLASS is not None:
        return _CACHE_CLASS
    from numba.core import caching

    class _KeyedLocator(caching._CacheLocator):
        def __init__(self, path: str, lineno: int) -> None:
            self._path, self._lineno = path, lineno

        def get_cache_path(self) -> str:
            return self._path

        def get_source_stamp(self) -> str:
            return os.path.basename(self._path)  # the source key

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            self = cls(_PATH_OF[py_func], py_func.__code__.co_firstlineno)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    class _KeyedImpl(caching.CompileResultCacheImpl):  # type: ignore[misc]
        _locator_classes = [_KeyedLocator]

    class _KeyedCache(caching.FunctionCache):  # type: ignore[misc]
        _impl_class = _KeyedImpl

        def __init__(self, py_func: Any, path: str) -> None:
            _PATH_OF[py_func] = path
            super().__init__(py_func)

    _CACHE_CLASS = _KeyedCache
    return _CACHE_CLASS


#: the cache directory of each function handed to numba (read by the locator numba builds)
_PATH_OF: dict[Any, str] = {}
