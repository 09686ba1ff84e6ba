"""Compile once, visibly (issue 36): the first run with an empty kernel cache says so in one
line on stderr, a run loading from the cache says nothing; the parents of process pools
compile the kernels before their workers start, and only when the work runs compiled."""

from __future__ import annotations

import importlib
import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from rtsim.control import kernels as control_kernels
from rtsim.world import jit, kernels, motion
from rtsim.world.compiled import available

needs_numba = pytest.mark.skipif(not available(), reason="numba is not importable")

LINE = re.compile(r"^rtsim: compiling the world's kernels \(once per install, about \d+ s\)\.\.\.$")
ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def empty_cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh numba cache directory for this process, and no announcement made yet."""
    from numba.core import config

    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "numba-cache"))
    monkeypatch.setattr(kernels, "_ANNOUNCED", False)
    return tmp_path / "numba-cache"


@needs_numba
def test_announce_says_it_once_and_only_for_an_uncached_kernel(
    empty_cache: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("RTSIM_PROGRESS", "1")
    assert not jit.cached(motion.arc)
    assert kernels.announce([motion.arc], 7.4)
    err = capsys.readouterr().err
    assert LINE.match(err.strip()) and "about 7 s" in err and err.count("\n") == 1
    assert not kernels.announce([motion.arc], 7.4)  # once per process
    assert capsys.readouterr().err == ""
    # a build in the cache (numba's index in the source key's directory): nothing to say
    monkeypatch.setattr(kernels, "_ANNOUNCED", False)
    root = jit.cache_root()
    assert root is not None
    key_dir = Path(root, jit.source_key(motion.arc))
    key_dir.mkdir(parents=True)
    (key_dir / "motion.arc-1.py311.nbi").write_bytes(b"")
    assert jit.cached(motion.arc) and not kernels.announce([motion.arc], 7.4)
    # not where progress is hidden (no terminal, RTSIM_PROGRESS=0)
    monkeypatch.setenv("RTSIM_PROGRESS", "0")
    assert not kernels.announce([motion.ramp], 7.4)
    assert capsys.readouterr().err == ""


ROLES = """
from rtsim.world.jit import kernel

@kernel
def half(x):
    return 0.5 * x

@kernel
def twice(x):
    return half(x) * 4.0
"""


@needs_numba
def test_a_kernel_only_kernels_call_compiles_without_wrappers_and_is_not_cached(
    empty_cache: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The kernel Python calls is cached with numba's wrappers; its callee is compiled without
    them and not cached (its code is linked into the caller's); built as an entry, the callee
    is a dispatcher of its own, cached, and it serves the callers built after it."""
    pkg = tmp_path / "kpkg_roles"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "k.py").write_text(ROLES)
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    mod = importlib.import_module("kpkg_roles.k")
    monkeypatch.setattr(jit, "_COMPILED", {})
    twice = jit.build(mod.twice)
    assert twice(3.0) == 6.0
    inner = twice.py_func.__globals__["half"]
    linked_only = jit._linked_only_compiler()
    assert inner._compiler.pipeline_class is linked_only
    assert twice._compiler.pipeline_class is not linked_only
    assert jit.cached(mod.twice) and not jit.cached(mod.half)
    half = jit.build(mod.half)
    assert half is not inner and half(3.0) == 1.5 and jit.cached(mod.half)
    assert jit.build(mod.twice) is twice  # once per process
    # an entry built after its caller was built, before the caller compiles, serves it
    monkeypatch.setattr(jit, "_COMPILED", {})
    twice = jit.build(mod.twice)
    half = jit.build(mod.half)
    assert twice.py_func.__globals__["half"] is half
    assert twice(3.0) == 6.0 and half._compiler.pipeline_class is not linked_only
    monkeypatch.setattr(jit, "_COMPILED", {})
    half = jit.build(mod.half)
    assert jit.build(mod.twice).py_func.__globals__["half"] is half  # the entry serves


@needs_numba
@pytest.mark.slow
def test_first_run_says_it_compiles_and_the_next_loads_silently(tmp_path: Path) -> None:
    """Two processes on one fresh NUMBA_CACHE_DIR: the first compiles every kernel a run
    uses (the scan's, with the laser and the Hough windows, included, which each worker of a
    pool compiled again before) and says so in one line; the second loads them all, silently."""
    env = {
        **os.environ,
        "NUMBA_CACHE_DIR": str(tmp_path / "cache"),
        "RTSIM_PROGRESS": "1",
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    code = (
        "from rtsim.control import kernels as C; from rtsim.world import kernels as K; "
        "from rtsim.world import scanstep as S; "
        "C.warm_all(); "
        "print(all(K.cached(fn) for fn in "
        "[*K.ENTRIES.values(), *C.ENTRIES.values(), S.scan_step]))"
    )
    runs = [
        subprocess.run(
            [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600
        )
        for _ in range(2)
    ]
    for r in runs:
        assert r.returncode == 0, r.stderr
        assert r.stdout.strip() == "True"  # every entry cached after the run
    lines = runs[0].stderr.splitlines()
    assert len(lines) == 1 and LINE.match(lines[0]), runs[0].stderr
    assert runs[1].stderr == ""


@needs_numba
def test_warm_world_only_when_the_world_runs_compiled(monkeypatch: pytest.MonkeyPatch) -> None:
    from rtsim.config.scenario import load_scenario
    from rtsim.coupling.warm import warm_world

    calls: list[int] = []
    monkeypatch.setattr(control_kernels, "warm_all", lambda: calls.append(1))
    python = load_scenario("test2", {"world.backend": "python"})
    compiled = load_scenario("test2", {"world.backend": "compiled"})
    assert not warm_world([python]) and calls == []
    assert warm_world([python, compiled]) and calls == [1]


def test_sweep_warms_its_kind_in_the_parent_once_before_the_pool(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import rtsim.sweep.engine as engine
    from rtsim.sweep import KindSpec, register_kind, run_sweep
    from rtsim.sweep.kinds import KINDS

    # the probe kind is registered in this process only: fork, so the workers have it (the
    # engine spawns instead when another test left a thread running in this process)
    monkeypatch.setattr(engine, "_start_method", lambda: "fork")
    seen: list[Any] = []
    pid = os.getpid()

    def probe(p: Any) -> dict[str, Any]:
        return {"i2": 2 * p.params["i"], "forked": os.getppid() == pid}

    register_kind(
        KindSpec("warm_probe", probe, options=("i",), warm=lambda p: seen.append(p.params["i"]))
    )
    try:
        spec = tmp_path / "probe.toml"
        spec.write_text('[sweep]\nkind = "warm_probe"\n[grid]\ni = "0..3"\n', encoding="utf-8")
        table = run_sweep(spec, tmp_path / "out", workers=2)
    finally:
        KINDS._items.pop("warm_probe", None)
    assert seen == [0]  # once, in this process, with the first point
    assert list(table["i2"]) == [0, 2, 4, 6] and table["forked"].all()  # the workers ran them
