"""Kernel sources (rtsim.world.jit): the dependencies found in the code, the source key that
names a kernel's cache directory, and a kernel calling a kernel source of another module
compiled fresh after that module is edited (numba's own cache would load a stale build)."""

from __future__ import annotations

import importlib
import inspect
import math
import sys
import textwrap
from pathlib import Path
from types import ModuleType

import pytest

from rtsim.world import exactmath, ftl, jit, motion
from rtsim.world.compiled import available

CALLER = """
from rtsim.world.jit import kernel
from {pkg}.callee import double

SCALE = 10

@kernel
def f(x):
    return double(x) + SCALE
"""

CALLEE = """
from rtsim.world.jit import kernel

@kernel
def double(x):
    return {body}
"""


def _package(tmp_path: Path, name: str, body: str) -> tuple[ModuleType, Path]:
    # (the edits below change the file's size: import's and inspect's freshness checks)
    pkg = tmp_path / name
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "callee.py").write_text(textwrap.dedent(CALLEE.format(body=body)))
    (pkg / "caller.py").write_text(textwrap.dedent(CALLER.format(pkg=name)))
    sys.path.insert(0, str(tmp_path))
    importlib.invalidate_caches()
    return importlib.import_module(f"{name}.caller"), pkg


def _edit(pkg: Path, name: str, body: str) -> ModuleType:
    (pkg / "callee.py").write_text(textwrap.dedent(CALLEE.format(body=body)))
    importlib.invalidate_caches()
    importlib.reload(sys.modules[f"{name}.callee"])
    return importlib.reload(sys.modules[f"{name}.caller"])


def test_dependencies_found_in_the_code() -> None:
    calls, values = jit.dependencies(motion.follower_advance)
    assert calls == {"ramp_arc": motion.ramp_arc}
    calls, _ = jit.dependencies(motion.ramp_arc)
    assert calls == {"ramp": motion.ramp, "arc": motion.arc}
    assert jit.dependencies(motion.leader_travel)[0] == {"speed_ramp": motion.speed_ramp}
    calls, values = jit.dependencies(ftl.ftl_search)
    assert set(calls) == {"trace_frame", "_gap"}
    assert values["_NEWTON"] > 0 and "FTL_STEP" in values  # constants numba freezes
    assert not jit.is_kernel(math.sin) and jit.is_kernel(motion.arc)


@pytest.fixture
def isolated(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    """sys.path restored after the test, no .pyc written for the temporary packages."""
    monkeypatch.setattr(sys, "path", list(sys.path))
    monkeypatch.setattr(sys, "dont_write_bytecode", True)
    return monkeypatch


def test_editing_a_dependency_in_another_module_changes_the_key(
    tmp_path: Path, isolated: pytest.MonkeyPatch
) -> None:
    caller, pkg = _package(tmp_path, "kpkg_key", "2 * x")
    before = jit.source_key(caller.f)
    callee_before = jit.source_key(sys.modules["kpkg_key.callee"].double)
    other = jit.source_key(motion.arc)
    assert jit.source_key(caller.f) == before  # stable
    caller = _edit(pkg, "kpkg_key", "x + x + 0")
    assert jit.source_key(caller.f) != before
    # the callee's own key moves too, an unrelated kernel's does not
    assert jit.source_key(sys.modules["kpkg_key.callee"].double) != callee_before
    assert jit.source_key(motion.arc) == other


def test_a_constant_the_kernel_reads_is_in_the_key(
    tmp_path: Path, isolated: pytest.MonkeyPatch
) -> None:
    caller, _ = _package(tmp_path, "kpkg_const", "2 * x")
    before = jit.source_key(caller.f)
    jit._digest.cache_clear()
    isolated.setattr(caller, "SCALE", 11)
    assert jit.source_key(caller.f) != before
    jit._digest.cache_clear()


@pytest.mark.skipif(not available(), reason="numba is not importable")
def test_compiled_kernel_sees_an_edit_in_another_module(
    tmp_path: Path, isolated: pytest.MonkeyPatch
) -> None:
    """Compiled and cached, then the callee edited: the next build is compiled afresh (a new
    cache directory) and returns the edited result; the same sources load from the cache."""
    from numba.core import config

    isolated.setattr(config, "CACHE_DIR", str(tmp_path / "numba-cache"))
    root = jit.cache_root()
    assert root is not None and root.startswith(str(tmp_path / "numba-cache"))
    caller, pkg = _package(tmp_path, "kpkg_run", "2 * x")
    f = jit.build(caller.f)
    assert f(3) == 16 and f.py_func is not caller.f  # compiled against its callee's build
    assert caller.f(3) == 16  # the source itself stays Python
    key1 = jit.source_key(caller.f)
    assert any(Path(root, key1).iterdir())  # cached under its key
    caller = _edit(pkg, "kpkg_run", "3 * x + 0")
    g = jit.build(caller.f)
    assert g(3) == 19
    assert jit.source_key(caller.f) != key1


@pytest.mark.skipif(not available(), reason="numba is not importable")
def test_variants_compile_under_names_of_their_own(
    tmp_path: Path, isolated: pytest.MonkeyPatch
) -> None:
    """A kernel built with substitutions (a motion model's variant) compiles under a name of
    its own: numba links same-named machine code as one, and builds loaded from the cache
    come from different processes, whose counters in the names can coincide (a run after
    another model's, in one process, ran the first model's code)."""
    from numba.core import config

    isolated.setattr(config, "CACHE_DIR", str(tmp_path / "numba-cache"))
    caller, pkg = _package(tmp_path, "kpkg_var", "2 * x")
    (pkg / "other.py").write_text(textwrap.dedent(CALLEE.format(body="3 * x")))
    importlib.invalidate_caches()
    other = importlib.import_module("kpkg_var.other")
    subs = ((sys.modules["kpkg_var.callee"].double, other.double),)
    plain, variant = jit.build(caller.f), jit.build(caller.f, subs)
    assert plain(3) == 16 and variant(3) == 19
    names = [next(iter(d.overloads.values())).fndesc.qualname for d in (plain, variant)]
    assert names[0] == "f" and names[1].startswith("f__v") and names[1] != names[0]
    assert jit.build(caller.f, subs) is variant  # one build per variant per process


def test_the_build_scheme_is_in_the_key(isolated: pytest.MonkeyPatch) -> None:
    """A build cached by an earlier way of compiling (`jit.BUILD_SCHEME`) is never loaded."""
    before = jit.source_key(motion.follower_advance)
    isolated.setattr(jit, "BUILD_SCHEME", jit.BUILD_SCHEME + 1)
    assert jit.source_key(motion.follower_advance) != before


@pytest.mark.parametrize("name", ["_OPTIONS", "_INLINE"])
def test_numbas_options_are_in_the_key(isolated: pytest.MonkeyPatch, name: str) -> None:
    """A build cached under other numba options (numba's own index ignores them) is never
    loaded: each option set is part of the key."""
    before = jit.source_key(motion.follower_advance)
    isolated.setattr(jit, name, {**getattr(jit, name), "error_model": "python"})
    assert jit.source_key(motion.follower_advance) != before


def test_a_control_kernel_keys_the_world_sources_it_calls(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The controller's rollout (rtsim.control.kernels) calls the world's motion and law:
    its source key covers them, so an edit of a world function (its source text changed)
    is a new key for the control kernel, while a world kernel that does not reach that
    function keeps its key."""
    from rtsim.control import kernels as control_kernels

    reached, _ = jit._reach(control_kernels._rollout_changes)
    assert {motion.follower_advance, motion.ramp_arc, ftl.ftl_command_frame} <= reached
    rollout, hypot = (
        jit.source_key(control_kernels._rollout_changes),
        jit.source_key(exactmath.cpython_hypot),
    )
    real = inspect.getsource

    def edited(obj: object) -> str:
        text = real(obj)  # type: ignore[arg-type]
        return text + "    # edited\n" if obj is motion.ramp_arc else text

    jit._digest.cache_clear()
    monkeypatch.setattr(inspect, "getsource", edited)
    try:
        assert jit.source_key(control_kernels._rollout_changes) != rollout
        assert jit.source_key(exactmath.cpython_hypot) == hypot
    finally:
        monkeypatch.undo()
        jit._digest.cache_clear()
    assert jit.source_key(control_kernels._rollout_changes) == rollout


def test_rollout_pack_reads_back_as_its_named_scalars() -> None:
    """control.kernels.scalars reads the float pack in RolloutScalars' field order (distinct values,
    so a swapped field fails); the compiled rollout packs the five changing ones first."""
    import numpy as np

    from rtsim.control import kernels as control_kernels
    from rtsim.control.compiled_rollout import _CHANGING

    fields = control_kernels.RolloutScalars._fields
    named = control_kernels.RolloutScalars(*(float(i) + 0.5 for i in range(len(fields))))
    assert control_kernels.scalars(np.array(named)) == named
    assert fields[:_CHANGING] == ("leader_s", "leader_speed", "v_ld", "t_now", "next_scan")


@pytest.mark.skipif(not available(), reason="numba is not importable")
def test_llvm_options_are_tuned_only_while_a_kernels_library_optimises() -> None:
    """numba's pass builder is numba's own except while a kernel's code library optimises
    (`jit._tuned_library`: level 1 for the function passes, an entry's ``unroll``); the
    rollout's entry compiles without loop unrolling, the scan's with it."""
    from numba.core import codegen
    from numba.core.registry import cpu_target

    from rtsim.control.kernels import rollout_kernels
    from rtsim.world.scanstep import scan_step

    jit._custom()
    if not hasattr(codegen, "create_pass_builder"):  # (numba < 0.61: the legacy pass manager)
        assert jit._TUNED is None and jit._TUNING is None  # numba's own passes, untouched
        return
    assert jit._TUNED is not None and jit._TUNING is None
    assert issubclass(jit._TUNED.entry, codegen.JITCodeLibrary)
    machine = cpu_target.target_context.codegen()._tm
    own = codegen.create_pass_builder(machine, opt=3)
    assert own._pto.speed_level == 3 and own._pto.loop_unrolling
    with jit._tuned(jit._Tuning(1, False)):
        tuned = codegen.create_pass_builder(machine, opt=3)
        assert codegen.create_pass_builder(machine, opt=0)._pto.speed_level == 0
    assert tuned._pto.speed_level == 1 and not tuned._pto.loop_unrolling
    assert jit._TUNING is None
    assert rollout_kernels().roll_or_decide.py_func.__rtsim_unroll__ is False
    assert jit.build(scan_step).py_func.__rtsim_unroll__ is True


@pytest.mark.skipif(not available(), reason="numba is not importable")
def test_compiled_kernels_carry_one_set_of_flags_kept_until_an_option_changes() -> None:
    """Entries and linked-only kernels are typed under the same options (numba's own helpers
    compile once for both); the flags' memoised values follow every change and compare and
    hash as numba's own flags do."""
    from numba.core.compiler import Flags

    compiler = jit._entry_compiler()
    assert issubclass(jit._linked_only_compiler(), compiler)
    plain = Flags()
    plain.nrt = True
    mine = compiler.flags_class(plain)
    assert type(mine).__name__ == "Flags" and mine is not plain
    assert mine == plain and hash(mine) == hash(plain) and mine.values() == plain.values()
    mine.nrt = False
    assert mine.values()["nrt"] is False and mine != plain
    copy = mine.copy()
    copy.discard("nrt")
    assert copy.values()["nrt"] == Flags().nrt and mine.values()["nrt"] is False


def test_warm_world_compiles_the_truth_log_only_for_a_trace_follower(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A pool's parent compiles the truth log's kernel too where a world on the trace law
    logs through it (its scan does not make the samples: not the ``hough`` model's fused
    scan), so that its workers do not each compile it; not where no run calls it."""
    from rtsim.config.scenario import load_scenario
    from rtsim.control import kernels as control_kernels
    from rtsim.coupling import warm
    from rtsim.world.kernels import kernels

    calls: list[str] = []
    monkeypatch.setattr(control_kernels, "warm_all", lambda: calls.append("all"))
    monkeypatch.setattr(warm, "_warm_truth_log", lambda: calls.append("truth"))
    fused = load_scenario("test2", {"world.backend": "compiled"})  # (the hough model)
    fuses = kernels().exact_hypot  # (the scan fuses where the kernels' hypot is Python's)
    assert warm.warm_world([fused]) and calls == (["all"] if fuses else ["all", "truth"])
    calls.clear()
    trace = load_scenario("test2", {"world.backend": "compiled", "localization.model": "gaussian"})
    assert warm.warm_world([trace]) and calls == ["all", "truth"]
    calls.clear()
    assert warm.warm_world([trace, fused]) and calls == ["all", "truth"]
    calls.clear()
    l_psi = load_scenario("test2", {"world.backend": "compiled", "formation.model": "l-psi"})
    assert warm.warm_world([l_psi]) and calls == ["all"]


@pytest.mark.skipif(not available(), reason="numba is not importable")
def test_typing_memo_answers_as_numba_and_only_while_a_kernel_compiles() -> None:
    """The memoised typing gives numba's signature and implementation key, remembers only what
    a plain template typed (an `overload`'s compiles an implementation: asked again), and
    stands in for numba's only while a kernel compiles."""
    import operator

    import numpy as np
    from numba.core import types as nbt
    from numba.core.registry import cpu_target
    from numba.core.types.functions import Function

    jit.build(motion.ramp)(0.0, 1.0, 2.0, 3.0)
    memo = jit._custom().typing_memo
    assert memo is not None and Function.get_call_type is memo.original
    ctx = cpu_target.typing_context
    ctx.refresh()
    arr = nbt.Array(nbt.float64, 1, "C")
    for fn, args in ((operator.mul, (nbt.float64,) * 2), (operator.getitem, (arr, nbt.int64))):
        fnty = ctx.resolve_value_type(fn)
        want = memo.original(fnty, ctx, args, {})
        for _ in range(2):  # computed, then remembered
            got = memo.memoised(fnty, ctx, args, {})
            assert got == want and fnty.get_impl_key(got) is fnty.typing_key
    empty = ctx.resolve_value_type(np.empty)  # an overload: its key is its implementation
    sig = memo.memoised(empty, ctx, (nbt.int64,), {})
    assert sig is not None and empty.get_impl_key(sig) is not empty.typing_key
    assert not any(key[0] is empty for key in memo.answers)


def test_full_collections_freeze_their_survivors_only_while_a_kernel_compiles(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The collector's callback freezes after a full collection inside a compile, not else;
    a compile leaves nothing frozen, nor unfreezes what its caller froze."""
    import gc

    frozen: list[int] = []
    monkeypatch.setattr(gc, "freeze", lambda: frozen.append(1))
    for on, gen in ((False, 2), (True, 0), (True, 1), (True, 2)):
        monkeypatch.setattr(jit, "_FROZEN", on)
        jit._freeze_survivors("start", {"generation": gen})
        jit._freeze_survivors("stop", {"generation": gen})
    assert frozen == [1]
    monkeypatch.undo()
    if available():
        assert gc.get_freeze_count() == 0
        jit.build(motion.arc)(0.0, 0.0, 0.1, 1.0, 0.0, 2.0)  # (compiled, or loaded: either)
        assert gc.get_freeze_count() == 0 and not jit._FROZEN
        gc.freeze()
        try:
            mine = gc.get_freeze_count()
            with jit._compiling():
                assert not jit._FROZEN
            assert gc.get_freeze_count() == mine
        finally:
            gc.unfreeze()
