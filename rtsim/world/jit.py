"""Kernel sources: plain Python functions that numba compiles for the ``compiled`` backend.

A function marked with `kernel` stays the plain function it is (the ``python`` backend
and every Python caller run it as Python; numba is not imported). `build` turns one
into a numba dispatcher on demand, together with the kernel sources it calls (found in its
code, by name in its module's globals): each callee is compiled first and the caller is
compiled against a copy of its globals in which the callees' names are their dispatchers, so
a kernel may call kernel sources of any module and the module's own names stay Python. The
compile order is derived from the calls; nothing lists it by hand.

**Cache.** numba's own on-disk cache (``cache=True``) checks only the file that defines a
kernel, so a kernel calling an edited function of another module would load a stale build.
Here each compiled kernel is cached in a directory named by `source_key`, a hash of
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

__all__ = [
    "build",
    "cache_root",
    "cached",
    "dependencies",
    "is_kernel",
    "kernel",
    "source_key",
]

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
    """Whether ``obj`` is a function marked by `kernel`."""
    return isinstance(obj, types.FunctionType) and hasattr(obj, _MARK)


def _names(code: types.CodeType) -> Iterator[str]:
    yield from code.co_names
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            yield from _names(const)


def dependencies(fn: Callable[..., Any]) -> tuple[dict[str, Callable[..., Any]], dict[str, Any]]:
    """The kernel sources ``fn`` calls by name, and the other plain values (numbers, strings,
    tuples of them; a named tuple class as its fields) it reads from its globals: two
    name → object dicts."""
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
        elif isinstance(obj, type) and issubclass(obj, tuple):  # a NamedTuple it builds
            values[name] = (obj.__qualname__, getattr(obj, "__annotations__", None))
    return calls, values


@functools.cache
def _digest(fn: Callable[..., Any]) -> bytes:
    """One function's part of a source key: its name, source text, options, plain values."""
    h = hashlib.sha256(f"{fn.__module__}.{fn.__qualname__}\n".encode())
    h.update(inspect.getsource(fn).encode())
    h.update(repr((sorted(dependencies(fn)[1].items()), getattr(fn, _MARK, None))).encode())
    return h.digest()


def source_key(fn: Callable[..., Any]) -> str:
    """A hash of the source text of ``fn`` and of every kernel source it reaches (with their
    names), and of the values of the other globals they read (module docstring)."""
    seen, todo = set(), [fn]
    while todo:
        f = todo.pop()
        if f not in seen:
            seen.add(f)
            todo += dependencies(f)[0].values()
    return hashlib.sha256(b"".join(sorted(map(_digest, seen)))).hexdigest()[:24]


def build(fn: Callable[..., Any]) -> Any:
    """The numba dispatcher of kernel source ``fn`` (made once per process; its callees
    first), cached on disk by `source_key`. Imports numba."""
    done = _COMPILED.get(fn)
    if done is not None:
        return done
    import numba

    glob = dict(fn.__globals__)  # type: ignore[attr-defined]
    for name, dep in dependencies(fn)[0].items():
        if dep is fn:
            raise TypeError(f"kernel {fn.__qualname__} calls itself (numba cannot)")
        glob[name] = build(dep)
    f: Any = fn
    clone = types.FunctionType(f.__code__, glob, f.__name__, f.__defaults__, f.__closure__)
    clone.__qualname__, clone.__module__ = fn.__qualname__, fn.__module__
    out: Any
    if getattr(fn, _MARK)["inline"]:
        out = numba.njit(nogil=True, inline="always")(clone)
    else:
        out = numba.njit(nogil=True)(clone)
        root = cache_root()
        if root is not None:  # else uncached, as numba leaves a kernel it cannot cache
            clone.__rtsim_cache__ = os.path.join(root, source_key(fn))  # type: ignore[attr-defined]
            out._cache = _keyed_cache_class()(clone)
    _COMPILED[fn] = out
    return out


def cached(fn: Callable[..., Any]) -> bool:
    """Whether kernel source ``fn`` has a build in the cache (numba's index file in its
    source key's directory), so that `build` loads it rather than compiles it; False
    when nothing can be cached."""
    root = cache_root()
    if root is None:
        return False
    try:
        names = os.listdir(os.path.join(root, source_key(fn)))
    except OSError:
        return False
    return any(name.endswith(".nbi") for name in names)


def cache_root() -> str | None:
    """Where the compiled kernels are cached: ``NUMBA_CACHE_DIR``/rtsim-kernels when set,
    else ``__pycache__/rtsim-kernels`` next to this file when writable, else numba's
    user-wide cache directory's rtsim-kernels; None when none is writable."""
    from numba.core import config
    from numba.misc.appdirs import AppDirs

    user_dir = getattr(config, "CACHE_DIR", "")  # NUMBA_CACHE_DIR, read by numba
    dirs = [user_dir] if user_dir else [os.path.join(os.path.dirname(__file__), "__pycache__")]
    if not user_dir:
        dirs.append(AppDirs(appname="numba", appauthor=False).user_cache_dir)
    for path in (os.path.join(d, "rtsim-kernels") for d in dirs):
        try:
            os.makedirs(path, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            return path
    return None


_CACHE_CLASS: Any = None


def _keyed_cache_class() -> Any:
    """numba's FunctionCache with one locator: the function's ``__rtsim_cache__`` directory,
    named by its source key, which is also the source stamp (built when numba is imported)."""
    global _CACHE_CLASS
    if _CACHE_CLASS is not None:
        return _CACHE_CLASS
    from numba.core import caching

    class _KeyedLocator(caching._CacheLocator):
        def __init__(self, py_func: Any) -> None:
            self._path, self._lineno = py_func.__rtsim_cache__, py_func.__code__.co_firstlineno

        def get_cache_path(self) -> str:
            return self._path  # type: ignore[no-any-return]

        def get_source_stamp(self) -> str:
            return os.path.basename(self._path)  # the source key

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Any:
            self = cls(py_func)
            try:
                self.ensure_cache_path()
            except OSError:
                return None
            return self

    class _KeyedImpl(caching.CompileResultCacheImpl):  # type: ignore[misc]
        _locator_classes: list[Any] = [_KeyedLocator]

    class _KeyedCache(caching.FunctionCache):  # type: ignore[misc]
        _impl_class = _KeyedImpl

    _CACHE_CLASS = _KeyedCache
    return _CACHE_CLASS
