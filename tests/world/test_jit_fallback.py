"""rtsim.world.jit on a numba without the internals its compilers and cache subclass: each
piece falls back to numba's own (the same results, no cache), said in one line on stderr
once per process, instead of every run failing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from rtsim.world import jit, motion
from rtsim.world.compiled import available

needs_numba = pytest.mark.skipif(not available(), reason="numba is not importable")
ROOT = Path(__file__).resolve().parents[2]

#: numba internals `jit` subclasses, by the piece that needs them (ones numba's own compile
#: does not read once imported: deleted for the test)
GONE = {
    "linked_only": ("numba.core.codegen", "JITCodeLibrary"),
    "cache": ("numba.core.caching", "_CacheLocator"),
}
#: the pieces whose internals numba's own compile reads too (``compiler.Compiler``,
#: ``compiler.Flags``, ``types.unliteral``): their set-up raising as it would without them
STAND_INS = {"entry": "Compiler", "unliteral": "unliteral"}
#: arguments of `motion.follower_advance`: a ramp over several steps, then one arc
ARGS = [
    (0.0, 0.0, 0.1, 0.0, 0.0, 30.0, 0.2, 40.0, 0.0, 0.0, 1000.0, 100.0),
    (5.0, -2.0, 3.0, 20.0, -0.1, 20.0, -0.1, 40.0, 12.5, 100.0, 137.5, 100.0),
]


def _gone(name: str) -> None:
    raise AttributeError(f"module 'numba.core' has no attribute {name!r}")


def _stand_in(monkeypatch: pytest.MonkeyPatch, piece: str) -> None:
    """`jit`'s set-up of ``piece`` raising as on a numba without its internal."""
    fn = {"entry": "_entry_compiler", "unliteral": "_unliteral_ready"}[piece]

    def raiser() -> None:
        _gone(STAND_INS[piece])

    raiser.__name__ = fn
    monkeypatch.setattr(jit, fn, raiser)


def _fresh(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """jit's per-process state empty (restored afterwards), a cache directory of the test's."""
    from numba.core import config

    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "numba-cache"))
    for name, empty in (("_CUSTOM", None), ("_ENTRY", None), ("_LINKED_ONLY", None),
                        ("_CACHE_CLASS", None), ("_COMPILED", {}), ("_CALLERS", {})):  # fmt: skip
        monkeypatch.setattr(jit, name, empty)


@needs_numba
@pytest.mark.parametrize(
    "pieces", [("entry",), ("linked_only",), ("cache",), ("unliteral",), (*GONE, *STAND_INS)]
)
def test_missing_internals_fall_back_to_stock_numba(
    pieces: tuple[str, ...],
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    import importlib

    _fresh(monkeypatch, tmp_path)
    for piece in pieces:
        if piece in STAND_INS:
            _stand_in(monkeypatch, piece)
        else:
            module, name = GONE[piece]
            monkeypatch.delattr(importlib.import_module(module), name)
    f = jit.build(motion.follower_advance)  # an entry; ramp_arc, ramp, arc linked-only
    for args in ARGS:
        assert f(*args) == motion.follower_advance(*args)  # bit for bit, the Python reference
    assert jit.build(motion.arc)(*ARGS[0][:6]) == motion.arc(*ARGS[0][:6])
    custom = jit._custom()
    assert (custom.entry is None) == ("entry" in pieces)
    assert (custom.linked_only is None) == bool({"entry", "linked_only"} & set(pieces))
    assert (custom.cache is None) == ("cache" in pieces)
    assert custom.unliteral == ("unliteral" not in pieces)
    cached = any(Path(tmp_path, "numba-cache").rglob("*.nbi"))
    assert cached == ("cache" not in pieces)
    assert jit.cached(motion.follower_advance) == ("cache" not in pieces)
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith("rtsim: numba "), err
    assert "compiling with numba's own instead: the same results" in err[0]
    assert ("none cached" in err[0]) == ("cache" in pieces)
    for piece in set(pieces) - ({"linked_only"} if "entry" in pieces else set()):
        assert {**STAND_INS, **{p: n for p, (_, n) in GONE.items()}}[piece] in err[0]  # (why)
    jit.build(motion.ramp)  # once per process: nothing more said
    assert capsys.readouterr().err == ""


@needs_numba
def test_the_current_numba_needs_no_fallback(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The numba installed (CI: the newest, and the floor) has every internal: silence."""
    _fresh(monkeypatch, tmp_path)
    custom = jit._custom()
    assert None not in custom[:3] and custom.unliteral
    assert capsys.readouterr().err == ""


#: a run of the world's compile path with the internals gone (a fresh interpreter: numba's
#: state and the world's compiled kernels are per process)
STOCK_RUN = """
import sys
import numba.core.caching, numba.core.codegen
from rtsim.world import jit
del numba.core.codegen.JITCodeLibrary, numba.core.caching._CacheLocator
def _entry_compiler():  # (numba's own compile reads compiler.Compiler: a stand-in)
    raise AttributeError("module 'numba.core.compiler' has no attribute 'Compiler'")
jit._entry_compiler = _entry_compiler
from rtsim.cli import main
sys.exit(main(sys.argv[1:]))
"""


@needs_numba
@pytest.mark.slow
def test_a_scenario_on_stock_numba_is_bit_identical(tmp_path: Path) -> None:
    """Test 2 for 10 s, every kernel compiled by numba's own compiler (uncached): the same
    windows.csv and jobs.csv as with rtsim's, one line on stderr saying why."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RTSIM_PROGRESS": "0"}
    args = ["scenario", "test2", "--duration", "10", "--no-figures", "--force", "--out"]
    runs = {}
    for name, pre in (("stock", ["-c", STOCK_RUN]), ("custom", ["-m", "rtsim"])):
        out = tmp_path / name
        proc = subprocess.run([sys.executable, *pre, *args, str(out)], env=env, cwd=ROOT,
                              capture_output=True, text=True, check=True)  # fmt: skip
        runs[name] = (out, [ln for ln in proc.stderr.splitlines() if ln.startswith("rtsim: ")])
    assert len(runs["stock"][1]) == 1 and "numba's own instead" in runs["stock"][1][0]
    assert not runs["custom"][1]
    for file in ("windows.csv", "jobs.csv"):
        assert (runs["stock"][0] / file).read_bytes() == (runs["custom"][0] / file).read_bytes()
