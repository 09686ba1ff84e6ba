"""Kernel sources: plain Python functions that numba compiles for the ``compiled`` backend.

A function marked with `kernel` stays the plain function it is (the ``python`` backend
and every Python caller run it as Python; numba is not imported). `build` turns one
into a numba dispatcher on demand, together with the kernel sources it calls (found in its
code, by name in its module's globals): each callee is compiled first and the caller is
compiled against a copy of its globals in which the callees' names are their dispatchers, so
a kernel may call kernel sources of any module and the module's own names stay Python. The
compile order is derived from the calls; nothing lists it by hand. ``subs`` (callee source →
replacement source) builds a variant in which every kernel of the closure calls the
replacement instead: a motion model's parts in the controller's rollout
(`rtsim.world.motionmodels`).

**Cache.** numba's own on-disk cache (``cache=True``) checks only the file that defines a
kernel, so a kernel calling an edited function of another module would load a stale build.
Here each compiled kernel is cached in a directory named by `source_key`, a hash of
the source text of the kernel and of every kernel source it reaches, and of the values of
the other globals they read (numba freezes those at compile time): an edit anywhere in that
closure is a new directory, hence a fresh compile. Only the kernels Python calls (`build`)
are cached, with numba's CPython wrapper; a kernel only other kernels call is compiled
without the wrappers and not cached on its own (its code is linked into each caller's, which
is what a later process loads): about 2 s less CPU on the first run. Nor is it optimised
as a module or emitted as machine code (`_linked_only_compiler`): its code never runs on its
own, each caller links its IR in and optimises and emits the whole, as before (the same
arithmetic; LLVM may inline a little differently); about 2 s less again. The directories live
under ``NUMBA_CACHE_DIR`` when set, else ``__pycache__`` here, else numba's user-wide cache.

**Stock numba.** These compilers and this cache subclass numba internals; a piece a numba
cannot build falls back to numba's own (`_custom`: same results, slower), said once on stderr.
"""

from __future__ import annotations

import contextlib
import functools
import gc
import hashlib
import inspect
import os
import sys
import types
from collections.abc import Callable, Iterator
from typing import Any, NamedTuple, TypeVar

__all__ = [
    "build",
    "cache_root",
    "cached",
    "dependencies",
    "is_kernel",
    "kernel",
    "source_key",
    "specialise",
]

# numba formats a typing error for each overload it tries and rejects (thousands while the
# kernels compile), each in a colour shell (colorama's init and deinit, ≈ 0.2 s CPU of a first
# run) unless this is set; its default colour scheme prints no colour anyway. Set before
# numba is imported (rtsim imports it only through this module).
os.environ.setdefault("NUMBA_DISABLE_ERROR_MESSAGE_HIGHLIGHTING", "1")

F = TypeVar("F", bound=Callable[..., Any])
#: substitutions (callee source, replacement source), hashable
Subs = tuple[tuple[Callable[..., Any], Callable[..., Any]], ...]

_MARK = "__rtsim_kernel__"
#: a build's `kernel` ``unroll``, on the function numba compiles (`_entry_compiler`)
_UNROLL = "__rtsim_unroll__"
#: How `_build` compiles (what a kernel source's text does not say: the variants' names, which
#: kernels are linked-only, literal arguments): part of every `source_key`, so a build cached
#: under an earlier scheme is never loaded. Bump it when `_build` changes what it emits.
BUILD_SCHEME = 4
_COMPILED: dict[tuple[Callable[..., Any], Subs, bool], Any] = {}
_PYTHON: dict[tuple[Callable[..., Any], Subs], Callable[..., Any]] = {}
#: id of a callee's dispatcher -> the (globals, name) of the kernels built to call it
_CALLERS: dict[int, list[tuple[dict[str, Any], str]]] = {}


def kernel(fn: F | None = None, *, inline: bool = False, unroll: bool = True) -> Any:
    """Mark ``fn`` as a kernel source (returned unchanged). ``inline``: numba inlines it into
    its callers instead of compiling it on its own: typed and lowered again in each caller,
    which the first run pays for (LLVM inlines a small kernel called from a kernel anyway),
    worth it only where numba's reference-count pruning then drops the increfs of arrays
    the kernel reads (the law's geometry: `rtsim.world.ftl.path_segment`). ``unroll``
    (an entry's): whether LLVM unrolls loops when it optimises the entry with the kernels
    it calls (`_Tuning`; off where that costs compile time and gains no run time)."""

    def mark(f: F) -> F:
        setattr(f, _MARK, {"inline": inline, "unroll": unroll})
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


def _reach(fn: Callable[..., Any], subs: Subs = ()) -> tuple[set[Callable[..., Any]], Subs]:
    """The kernel sources ``fn`` reaches with ``subs`` applied, and the substitutions met."""
    swap = dict(subs)
    seen: set[Callable[..., Any]] = set()
    used: set[Callable[..., Any]] = set()
    todo = [fn]
    while todo:
        f = todo.pop()
        if f not in seen:
            seen.add(f)
            for dep in dependencies(f)[0].values():
                if dep in swap:
                    used.add(dep)
                todo.append(swap.get(dep, dep))
    return seen, tuple(pair for pair in subs if pair[0] in used)


def source_key(fn: Callable[..., Any], subs: Subs = ()) -> str:
    """A hash of the source text of ``fn`` and of every kernel source it reaches (with their
    names; ``subs`` applied), of the values of the other globals they read (module
    docstring) and of numba's options (`_OPTIONS`, `_INLINE`: numba's own cache index
    ignores them, so a build made under other options would be loaded)."""
    seen, _ = _reach(fn, subs)
    h = hashlib.sha256(b"".join(sorted(map(_digest, seen))))
    options = f"{sorted(_OPTIONS.items())} {sorted(_INLINE.items())}"
    h.update(f"scheme {BUILD_SCHEME} {options}".encode())
    return h.hexdigest()[:24]


def build(fn: Callable[..., Any], subs: Subs = ()) -> Any:
    """The numba dispatcher of kernel source ``fn`` (made once per process; its callees
    first), cached on disk by `source_key`; with ``subs``, the variant whose kernels call
    each pair's replacement instead of its callee (module docstring). Imports numba."""
    return _build(fn, subs, entry=True)


def _build(fn: Callable[..., Any], subs: Subs, entry: bool) -> Any:
    """`build` for Python callers (``entry``) or for the kernels that call ``fn`` (module
    docstring: compiled without numba's wrappers, not cached; an entry's dispatcher serves
    when there is one already, or when it is built before any caller compiles)."""
    if subs:  # (only those it meets: a kernel they miss is shared)
        subs = _reach(fn, subs)[1]
    inline = getattr(fn, _MARK)["inline"]
    done = _COMPILED.get((fn, subs, entry or inline))
    if done is None and not entry:
        done = _COMPILED.get((fn, subs, True))
    if done is not None:
        return done
    import numba

    custom = _custom()
    swap = dict(subs)
    glob = dict(fn.__globals__)  # type: ignore[attr-defined]
    for name, dep in dependencies(fn)[0].items():
        if dep is fn:
            raise TypeError(f"kernel {fn.__qualname__} calls itself (numba cannot)")
        callee = _build(swap.get(dep, dep), subs, entry=False)
        glob[name] = callee
        _CALLERS.setdefault(id(callee), []).append((glob, name))
    f: Any = fn
    clone = types.FunctionType(f.__code__, glob, f.__name__, f.__defaults__, f.__closure__)
    clone.__qualname__, clone.__module__ = _variant_name(fn, subs), fn.__module__
    out: Any
    if inline:
        out = numba.njit(**_INLINE)(clone)
    else:
        njit: Any = numba.njit  # (numba's stubs omit no_cfunc_wrapper)
        pipeline = custom.entry if entry else custom.linked_only or custom.entry
        out = njit(**({"pipeline_class": pipeline} if pipeline else {}), **_OPTIONS)(clone)
        setattr(clone, _UNROLL, getattr(fn, _MARK)["unroll"])
        root = cache_root() if entry and custom.cache else None
        if root is not None:  # else uncached, as numba leaves a kernel it cannot cache
            key = source_key(fn, subs)
            clone.__rtsim_cache__ = os.path.join(root, key)  # type: ignore[attr-defined]
            out._cache = custom.cache(clone)
    if custom.unliteral:
        out.get_call_template = functools.partial(_unliteral_call, out.get_call_template)
    _COMPILED[fn, subs, entry or inline] = out
    bare = None if inline or not entry else _COMPILED.get((fn, subs, False))
    if bare is not None and not bare.overloads:  # no caller compiled against it yet:
        for caller_glob, name in _CALLERS.pop(id(bare), []):  # the entry serves them
            caller_glob[name] = out
        del _COMPILED[fn, subs, False]
    return out


#: numba's options of every kernel it compiles on its own, an entry or linked-only (the
#: latter without numba's CPython wrapper: `_linked_only_compiler`): one set of flags, so
#: that numba types its own helpers (``np.empty``, ``min``: compiled per signature *and*
#: flags) once for both; no C-callable wrapper, which nothing here calls; numpy's error
#: model: a division by zero gives IEEE's inf or nan where the Python reference (the same
#: source uncompiled) raises ZeroDivisionError, so the two agree on every run that completes,
#: and the divisions lose their test and raise path (-0.6 % of a Test 2 lap's instructions)
_OPTIONS: dict[str, Any] = {"nogil": True, "no_cfunc_wrapper": True, "error_model": "numpy"}
#: numba's options of an ``inline`` kernel (typed and lowered again in each caller)
_INLINE: dict[str, Any] = {"nogil": True, "inline": "always", "error_model": "numpy"}


def _variant_name(fn: Callable[..., Any], subs: Subs) -> str:
    """The qualified name a build of ``fn`` with ``subs`` compiles under: ``fn``'s own, and
    for a variant a suffix naming its substitutions. numba names a function's machine code
    by its module, qualified name, types and a counter of the process that compiled it, and
    links same-named code as one (the first loaded serves every caller): builds loaded from
    the cache were compiled by different processes, so two variants of one kernel (a
    motion model's and the unicycle's) could share a name and one run the other's code."""
    if not subs:
        return fn.__qualname__
    tag = hashlib.sha256(
        repr(
            [
                (f"{a.__module__}.{a.__qualname__}", f"{b.__module__}.{b.__qualname__}")
                for a, b in subs
            ]
        ).encode()
    ).hexdigest()[:12]
    return f"{fn.__qualname__}__v{tag}"


def _unliteral_call(template: Any, args: Any, kws: Any) -> Any:
    """numba's call template of a kernel called from a kernel, for the arguments' types
    without their literal values: a constant argument (``True``, ``0``) would otherwise
    compile one more build per value, not one per signature."""
    from numba.core import types as nbtypes

    return template(tuple(nbtypes.unliteral(a) for a in args), kws)


def specialise(fn: Callable[..., Any], subs: Subs = ()) -> Callable[..., Any]:
    """The plain-Python twin of `build` ``(fn, subs)``: ``fn`` itself when ``subs`` meets
    nothing it reaches, else a copy of it whose globals (and its callees', copied the same
    way) name the replacements (made once per process). The ``python`` backend runs it."""
    if subs:
        subs = _reach(fn, subs)[1]
    if not subs:
        return fn
    done = _PYTHON.get((fn, subs))
    if done is not None:
        return done  # type: ignore[no-any-return]
    swap = dict(subs)
    glob = dict(fn.__globals__)  # type: ignore[attr-defined]
    for name, dep in dependencies(fn)[0].items():
        glob[name] = specialise(swap.get(dep, dep), subs)
    f: Any = fn
    clone = types.FunctionType(f.__code__, glob, f.__name__, f.__defaults__, f.__closure__)
    clone.__qualname__, clone.__module__ = fn.__qualname__, fn.__module__
    clone.__doc__ = fn.__doc__
    _PYTHON[fn, subs] = clone
    return clone


def cached(fn: Callable[..., Any], subs: Subs = ()) -> bool:
    """Whether kernel source ``fn`` (with ``subs``) has a build in the cache (numba's index
    file in its source key's directory), so that `build` loads it rather than compiles it;
    False when nothing can be cached."""
    root = cache_root()
    if root is None or _custom().cache is None:
        return False
    try:
        names = os.listdir(os.path.join(root, source_key(fn, subs)))
    except OSError:
        return False
    return any(name.endswith(".nbi") for name in names)


def cache_root() -> str | None:
    """Where the compiled kernels are cached: ``NUMBA_CACHE_DIR``/rtsim-kernels when set,
    else ``__pycache__/rtsim-kernels`` next to this file when writable, else numba's
    user-wide cache directory's rtsim-kernels; None when none is writable."""
    from numba.core import config

    user_dir = getattr(config, "CACHE_DIR", "")  # NUMBA_CACHE_DIR, read by numba
    dirs = [user_dir] if user_dir else [os.path.join(os.path.dirname(__file__), "__pycache__")]
    if not user_dir:
        try:
            from numba.misc.appdirs import AppDirs
        except ImportError:  # (an internal of numba's: without it, no user-wide directory)
            pass
        else:
            dirs.append(AppDirs(appname="numba", appauthor=False).user_cache_dir)
    for path in (os.path.join(d, "rtsim-kernels") for d in dirs):
        try:
            os.makedirs(path, exist_ok=True)
        except OSError:
            continue
        if os.access(path, os.W_OK):
            return path
    return None


class _Custom(NamedTuple):
    """What `_build` compiles with beyond numba's public API (None/False: numba's own)."""

    entry: Any  #: `_entry_compiler`
    linked_only: Any  #: `_linked_only_compiler`
    cache: Any  #: `_keyed_cache_class`
    unliteral: bool  #: `_unliteral_call` (numba.core.types.unliteral, get_call_template)
    typing_memo: Any = None  #: `_typing_memo` (numba's Function.get_call_type, memoised)


_CUSTOM: _Custom | None = None
#: the errors that mean "this numba has no such internal" when a piece is set up
_MISSING = (ImportError, AttributeError, TypeError)


def _custom() -> _Custom:
    """The pieces of `_build` that use numba internals, each set up once per process; one
    that this numba cannot build (a name gone or changed: `_MISSING`) is None and numba's
    own stands in (the same results: a slower first run, no cache), said on stderr in one
    line for all of them (module docstring)."""
    global _CUSTOM
    if _CUSTOM is not None:
        return _CUSTOM
    missing: list[str] = []

    def attempt(make: Callable[[], Any]) -> Any:
        try:
            return make()
        except _MISSING as exc:
            missing.append(f"{make.__name__}: {type(exc).__name__}: {exc}")
            return None

    global _TUNED
    from numba.core import codegen

    # (the tuning is of numba's new pass manager's pipelines, numba >= 0.61: an older
    # numba's legacy passes run as they are, which is no missing internal to report)
    new_passes = hasattr(codegen, "create_pass_builder")
    _TUNED = attempt(_tuned_library) if new_passes else None
    entry = attempt(_entry_compiler)
    linked = attempt(_linked_only_compiler) if entry is not None else None  # (its subclass)
    cache = attempt(_keyed_cache_class)
    unliteral = attempt(_unliteral_ready) is not None
    memo = attempt(_typing_memo) if entry is not None else None
    _CUSTOM = _Custom(entry, linked, cache, unliteral, memo)
    if missing:
        import numba

        cost = (
            "every run compiling its kernels (none cached)"
            if cache is None
            else "a slower first run"
        )
        print(
            f"rtsim: numba {numba.__version__} lacks internals rtsim's compile set-up uses "
            f"({'; '.join(missing)}); compiling with numba's own instead: the same results, "
            + cost,
            file=sys.stderr,
            flush=True,
        )
    return _CUSTOM


def _require(owner: Any, *names: str) -> None:
    """Raise AttributeError unless ``owner`` has every attribute ``names`` (the internals a
    subclass's methods call, checked when it is set up rather than when a kernel compiles)."""
    for name in names:
        if not hasattr(owner, name):
            raise AttributeError(f"{getattr(owner, '__name__', owner)} has no {name!r}")


def _unliteral_ready() -> bool:
    """Set-up check of `_unliteral_call`'s internals."""
    from numba.core import types as nbtypes
    from numba.core.dispatcher import Dispatcher

    _require(nbtypes, "unliteral")
    _require(Dispatcher, "get_call_template")
    return True


_CACHE_CLASS: Any = None


def _keyed_cache_class() -> Any:
    """numba's FunctionCache with one locator: the function's ``__rtsim_cache__`` directory,
    named by its source key, which is also the source stamp (built when numba is imported)."""
    global _CACHE_CLASS
    if _CACHE_CLASS is not None:
        return _CACHE_CLASS
    from numba.core import caching

    _require(caching._CacheLocator, "ensure_cache_path")
    _require(caching.FunctionCache, "_impl_class")

    class _KeyedLocator(caching._CacheLocator):
        def __init__(self, py_func: Any) -> None:
            self._path, self._lineno = py_func.__rtsim_cache__, py_func.__code__.co_firstlineno
            self._py_file = py_func.__code__.co_filename  # (numba's warnings name it)

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


class _Tuning(NamedTuple):
    """LLVM's options while one of the kernels' code libraries is optimised (`_tuned_library`)."""

    speed: int  #: the highest optimisation level of the pass pipelines
    unroll: bool  #: whether loops are unrolled


class _Tuned(NamedTuple):
    """`_tuned_library`'s code library class, and numba's pass builder it stands in for."""

    entry: Any
    numbas: Any


_TUNED: _Tuned | None = None
#: the options in force (None: numba's own), set only while a kernel's library optimises
_TUNING: _Tuning | None = None
#: the level of the function passes each function of a kernel's code runs when numba adds
#: it to the kernel's library, before the kernel is linked into an entry, where the module
#: passes at numba's level (3) optimise it again with the kernels it calls and its callers:
#: level 1 there, less CPU of a first run and the same speed of the kernels (measured:
#: docs/performance.md, "The first run within 15 s")
_FUNCTION_SPEED = 1


@contextlib.contextmanager
def _tuned(tuning: _Tuning) -> Iterator[None]:
    global _TUNING
    before, _TUNING = _TUNING, tuning
    try:
        yield
    finally:
        _TUNING = before


def _tuned_library() -> _Tuned:
    """numba's JIT code library with the kernels' LLVM options (`_Tuning`): the function
    passes at `_FUNCTION_SPEED`, and the module passes of an entry with loops unrolled or
    not (its ``unroll``: `kernel`). Pass pipelines are built by numba's
    ``create_pass_builder``, looked up in numba's codegen module at each build: the stand-in
    set there builds numba's own unless a kernel's library is optimising. The same
    arithmetic in a different order of passes: the same floats (no fast-math: LLVM
    reorders no floating-point operation), machine code that may differ."""
    global _TUNED
    if _TUNED is not None:
        return _TUNED
    from numba.core import codegen

    _require(codegen, "create_pass_builder", "ll")
    llvm = codegen.ll  # (llvmlite.binding)
    _require(codegen.CPUCodeLibrary, "_optimize_functions", "_optimize_final_module")
    _require(llvm, "create_pipeline_tuning_options", "create_pass_builder")
    # (numba's own: the stand-in's, when one was set up before)
    numbas = getattr(codegen.create_pass_builder, "numbas", codegen.create_pass_builder)
    _require(llvm.create_pipeline_tuning_options(), "loop_unrolling", "speed_level")

    def create_pass_builder(tm: Any, opt: int = 2, loop_vectorize: bool = False,
                            slp_vectorize: bool = False) -> Any:  # fmt: skip
        tuning = _TUNING
        if tuning is None:
            return numbas(tm, opt=opt, loop_vectorize=loop_vectorize, slp_vectorize=slp_vectorize)
        pto = llvm.create_pipeline_tuning_options()
        pto.speed_level = min(opt, tuning.speed)
        pto.slp_vectorization = slp_vectorize
        pto.loop_vectorization = loop_vectorize
        pto.loop_unrolling = tuning.unroll
        return llvm.create_pass_builder(tm, pto)

    class _Library(codegen.JITCodeLibrary):  # type: ignore[misc]
        """A kernel's code library: its LLVM passes tuned (`_tuned_library`)."""

        unroll = True  #: the entry's `kernel` ``unroll``

        def _optimize_functions(self, ll_module: Any) -> None:
            with _tuned(_Tuning(_FUNCTION_SPEED, True)):
                super()._optimize_functions(ll_module)

        def _optimize_final_module(self) -> None:
            with _tuned(_Tuning(3, self.unroll)):
                super()._optimize_final_module()

    create_pass_builder.numbas = numbas  # type: ignore[attr-defined]
    codegen.create_pass_builder = create_pass_builder
    _TUNED = _Tuned(_Library, numbas)
    return _TUNED


_ENTRY: Any = None


def _entry_compiler() -> Any:
    """numba's compiler with flags whose values are computed once per change: numba looks
    each overload up by the flags of the function it types (hashed and compared, each time
    every option read through its property: ≈ 25,000 look-ups, ≈ 0.4 s CPU of a first run).
    The same flags, the same code."""
    global _ENTRY
    if _ENTRY is not None:
        return _ENTRY
    from numba.core import compiler

    class _Watched(dict):  # type: ignore[type-arg]
        """The flags' set options, counting their changes."""

        version = 0

        def __setitem__(self, key: Any, value: Any) -> None:
            self.version += 1
            super().__setitem__(key, value)

        def __delitem__(self, key: Any) -> None:
            self.version += 1
            super().__delitem__(key)

        def pop(self, *args: Any) -> Any:
            self.version += 1
            return super().pop(*args)

        def update(self, *args: Any, **kwargs: Any) -> None:
            self.version += 1
            super().update(*args, **kwargs)

        def clear(self) -> None:
            self.version += 1
            super().clear()

        def setdefault(self, *args: Any) -> Any:
            self.version += 1
            return super().setdefault(*args)

        def popitem(self) -> Any:
            self.version += 1
            return super().popitem()

    class Flags(compiler.Flags):  # type: ignore[misc]
        """numba's Flags (the same name: it is part of the mangled symbols), their values
        kept until an option changes (a default is a constant)."""

        def __init__(self, copy_from: Any = None) -> None:
            super().__init__(copy_from)
            self._values = _Watched(self._values)
            self._memo: tuple[int, dict[str, Any]] = (-1, {})

        def values(self) -> dict[str, Any]:
            version, values = self._memo
            if version != self._values.version:
                values = super().values()
                self._memo = (self._values.version, values)
            return dict(values)

    class _Compiler(compiler.Compiler):  # type: ignore[misc]
        flags_class = Flags

        def __init__(self, typingctx: Any, targetctx: Any, library: Any, args: Any,
                     return_type: Any, flags: Any, locals: Any) -> None:  # fmt: skip
            flags = Flags(flags)
            super().__init__(typingctx, targetctx, library, args, return_type, flags, locals)

        def compile_extra(self, func: Any) -> Any:
            if self.state.library is None and _TUNED is not None:
                cg = self.state.targetctx.codegen()
                self.state.library = _TUNED.entry(cg, func.__qualname__)
                self.state.library.enable_object_caching()  # (as numba's lowering does)
                self.state.library.unroll = getattr(func, _UNROLL, True)
            with _compiling():
                return super().compile_extra(func)

    Flags(compiler.Flags()).values()  # (set up: numba's Flags as this subclass reads them)
    _ENTRY = _Compiler
    return _ENTRY


#: how many kernel compiles are under way (a kernel's callees compile inside it): `_compiling`
_DEPTH = 0
#: whether `_compiling` froze the collector's objects (`_freeze_survivors` freezes more)
_FROZEN = False
_GC_HOOKED = False


@contextlib.contextmanager
def _compiling() -> Iterator[None]:
    """While a kernel compiles (the outermost of nested compiles): numba's typing memoised
    (`_typing_memo`), and the cyclic collector's objects frozen (`_freeze_survivors`), then
    unfrozen, unless the caller had frozen objects of its own."""
    global _DEPTH, _FROZEN, _GC_HOOKED
    memo = _CUSTOM.typing_memo if _CUSTOM is not None else None
    outermost = _DEPTH == 0
    if outermost:
        if not _GC_HOOKED:
            gc.callbacks.append(_freeze_survivors)
            _GC_HOOKED = True
        if gc.get_freeze_count() == 0:
            gc.freeze()
            _FROZEN = True
        if memo is not None:
            memo.install()
    _DEPTH += 1
    try:
        yield
    finally:
        _DEPTH -= 1
        if outermost:
            if memo is not None:
                memo.remove()
            if _FROZEN:
                _FROZEN = False
                gc.unfreeze()


def _freeze_survivors(phase: str, info: dict[str, Any]) -> None:
    """gc callback: while a kernel compiles (`_compiling`), the objects alive before it are
    frozen and so is what each full collection leaves, so that a full collection traverses
    only what came after the last one. A first run's compiles collect fully about 12 times
    over a heap that grows to ≈ 340,000 objects (numba's typing tables, each kernel's compiled
    result): 1.4 s CPU, ≈ 0.4 s so. Once the compile ends they are unfrozen (the oldest
    generation, as a full collection leaves them): what was dropped meanwhile is collected at
    the next full collection after it."""
    if _FROZEN and phase == "stop" and info.get("generation") == 2:
        gc.freeze()


class _TypingMemo(NamedTuple):
    """numba's ``Function.get_call_type`` and its memoised stand-in (`_typing_memo`)."""

    owner: Any
    original: Any
    memoised: Any
    answers: dict[tuple[Any, ...], Any]  #: the memo: (function type, context, ...) -> signature

    def install(self) -> None:
        self.owner.get_call_type = self.memoised

    def remove(self) -> None:
        del self.owner.get_call_type  # (numba's, inherited, again)


def _typing_memo() -> _TypingMemo:
    """numba types each call of a builtin (``a * b``, ``x[i]``, ``bool(c)``) by trying every
    template registered for it in turn, each rejection formatted: ≈ 6,800 times in a first
    run for ≈ 330 distinct (function, argument types), ≈ 1.7 s CPU. The stand-in answers a
    repeat from a memo keyed by everything the answer depends on (the typing context, the
    arguments' types with their literal values, the flags of the compile, the target), and
    only where a plain template typed it (its implementation key is the function's own:
    ``get_impl_key``), which does nothing but compute the signature; an `overload`'s or an
    intrinsic's (each compiles or registers an implementation) is asked again as before. A
    hit also sets the implementation key as the template would. The same signatures, hence
    the same code."""
    from numba.core import targetconfig
    from numba.core.target_extension import get_local_target
    from numba.core.types.functions import Function

    _require(Function, "get_call_type")
    if "get_call_type" in vars(Function):  # (numba's own is inherited: `remove` deletes ours)
        raise TypeError("numba.core.types.functions.Function defines get_call_type itself")
    _require(targetconfig.ConfigStack, "top_or_none")
    original = Function.get_call_type
    memo: dict[tuple[Any, ...], Any] = {}
    top = targetconfig.ConfigStack.top_or_none

    def get_call_type(self: Any, context: Any, args: Any, kws: Any) -> Any:
        key = (self, context, tuple(args), tuple(kws.items()), top(), get_local_target(context))
        sig = memo.get(key)
        if sig is not None:
            self._impl_keys[sig.args] = self.typing_key
            return sig
        sig = original(self, context, args, kws)
        if sig is not None and self._impl_keys.get(sig.args) is self.typing_key:
            memo[key] = sig
        return sig

    return _TypingMemo(Function, original, get_call_type, memo)


_LINKED_ONLY: Any = None


def _linked_only_compiler() -> Any:
    """numba's compiler for a kernel only kernels call: its code library is finalized
    without the module-level optimisation and without machine code (module docstring)."""
    global _LINKED_ONLY
    if _LINKED_ONLY is not None:
        return _LINKED_ONLY
    from numba.core import codegen, compiler, typed_passes
    from numba.core.compiler_lock import require_global_compiler_lock
    from numba.core.compiler_machinery import LoweringPass, register_pass

    _require(codegen.JITCodeLibrary, "_raise_if_finalized", "_get_module_for_linking",
             "_ensure_finalized", "finalize", "get_pointer_to_function")  # fmt: skip
    _require(compiler.DefaultPassBuilder, "define_nopython_pipeline")
    _require(typed_passes, "IRLegalization")

    class _NoEnv:
        """The codegen, except that it sets no environment (the kernel has no machine code
        of its own: the callers' copies run, as they do when loaded from the cache)."""

        def __init__(self, cg: Any) -> None:
            self._cg = cg

        def set_env(self, name: str, env: Any) -> None:
            pass

        def __getattr__(self, name: str) -> Any:
            return getattr(self._cg, name)

    class _LinkedOnly(_TUNED.entry if _TUNED is not None else codegen.JITCodeLibrary):  # type: ignore[misc]
        """A library only linked into others: finalizing it links in its callees' IR,
        nothing more (each caller optimises and emits the whole with its own code)."""

        def finalize(self) -> None:
            require_global_compiler_lock()
            self._raise_if_finalized()
            reload = getattr(self, "_reload_init", None)  # (not in every numba: 0.59 has none)
            for library in dict.fromkeys(self._linking_libraries):
                if reload is not None:
                    reload.update(library._reload_init)
                self._final_module.link_in(library._get_module_for_linking(), preserve=True)
            self._finalized = True

        def get_pointer_to_function(self, name: str) -> int:
            self._ensure_finalized()
            return 0  # (no wrappers: nothing to call from Python)

        @property
        def codegen(self) -> Any:
            return _NoEnv(self._codegen)

    @register_pass(mutates_CFG=False, analysis_only=True)
    class _Unwrapped(LoweringPass):  # type: ignore[misc]
        """Before lowering: no CPython wrapper. (Set here, not in the kernel's options, so
        that it types its callees under the entries' flags: `_OPTIONS`.)"""

        _name = "rtsim_linked_only_unwrapped"

        def __init__(self) -> None:
            LoweringPass.__init__(self)

        def run_pass(self, state: Any) -> bool:
            state.flags.no_cpython_wrapper = True
            return False

    class _Compiler(_entry_compiler()):  # type: ignore[misc]
        def compile_extra(self, func: Any) -> Any:
            if self.state.library is None:
                cg = self.state.targetctx.codegen()
                self.state.library = _LinkedOnly(cg, func.__qualname__)
            return super().compile_extra(func)

        def define_pipelines(self) -> list[Any]:
            pm = compiler.DefaultPassBuilder.define_nopython_pipeline(self.state)
            pm.add_pass_after(_Unwrapped, typed_passes.IRLegalization)
            pm.finalize()
            return [pm]

    _LINKED_ONLY = _Compiler
    return _LINKED_ONLY
