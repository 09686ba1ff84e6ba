"""Benchmark: where the first run's compile time goes, kernel by kernel.

    python benchmarks/compile_profile.py [--json OUT] [--passes] [--min 0.03]
    python benchmarks/compile_profile.py --diff BEFORE.json AFTER.json

Runs the first run after an install (`bench_cold.py`'s command, ``rtsim scenario test2
--duration 10 --no-figures``, through the CLI in a child process with a fresh, empty
``NUMBA_CACHE_DIR``) and lists, for each function numba compiled:

- its own compile CPU (s): numba's ``numba:compile`` event of its dispatcher, less the
  compiles nested in it (a kernel's callees compile while it is typed);
- of that, LLVM's part (parsing the IR and the function passes, ``add_ir_module``; linking,
  the module passes and machine code, ``finalize``), timed by wrapping numba's code library;
- how many times it was compiled (a second signature, or an inlined copy and a compiled one,
  are both counted), and what kind: ``entry`` (Python calls it: numba's wrappers, cached),
  ``linked`` (only kernels call it: `rtsim.world.jit`'s linked-only build), ``inline``
  (compiled on its own as well as inlined), or ``numba`` (one of numba's own overloads). A
  kernel numba inlines (``kernel(inline=True)``) has no row of its own: it is typed and
  lowered again inside each caller, whose row holds it.

``--passes`` adds numba's compiler passes summed over every function (each pass's own time,
nested compiles subtracted). The CPU totals of a run on a loaded machine are noisy; the
compile sums are steadier. ``--json`` keeps a profile, ``--diff`` sets two side by side
(before/after a change; run each from its own checkout with ``PYTHONPATH``).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

COMMAND = ["scenario", "test2", "--duration", "10", "--no-figures", "--force"]


def _kind(dispatcher: Any) -> str:
    opts = getattr(dispatcher, "targetoptions", {})
    module = getattr(dispatcher.py_func, "__module__", "") or ""
    if not module.startswith("rtsim"):
        return "numba"
    if opts.get("inline") == "always":
        return "inline"
    from rtsim.world import jit

    linked_only = jit._linked_only_compiler()
    if getattr(getattr(dispatcher, "_compiler", None), "pipeline_class", None) is linked_only:
        return "linked"
    return "entry"


def _child(out_dir: str) -> None:
    """In a fresh NUMBA_CACHE_DIR: the CLI run, the compiles timed; one JSON line."""
    from numba.core import codegen, event

    from rtsim.cli import main as cli_main

    stack: list[list[Any]] = []  # [key, t0, nested] per compile
    passes: list[list[Any]] = []  # [name, t0, nested] per pass
    own: dict[str, dict[str, Any]] = {}
    pass_own: dict[str, float] = {}

    def row(key: str, kind: str) -> dict[str, Any]:
        return own.setdefault(key, {"s": 0.0, "llvm_s": 0.0, "n": 0, "kind": kind, "sigs": []})

    class Compiles(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            d = ev.data["dispatcher"]
            key = f"{d.py_func.__module__}.{d.py_func.__qualname__} [{_kind(d)}]"
            r = row(key, _kind(d))
            r["n"] += 1
            r["sigs"].append(str(ev.data["args"]))
            stack.append([key, time.process_time(), 0.0])

        def on_end(self, ev: Any) -> None:
            key, t0, nested = stack.pop()
            d = time.process_time() - t0
            own[key]["s"] += d - nested
            if stack:
                stack[-1][2] += d

    class Passes(event.Listener):  # type: ignore[misc]
        def on_start(self, ev: Any) -> None:
            passes.append([ev.data["name"].split(" [")[0], time.process_time(), 0.0])

        def on_end(self, ev: Any) -> None:
            name, t0, nested = passes.pop()
            d = time.process_time() - t0
            pass_own[name] = pass_own.get(name, 0.0) + d - nested
            if passes:
                passes[-1][2] += d

    def timed(fn: Any) -> Any:
        def wrapper(self: Any, *a: Any, **k: Any) -> Any:
            t0 = time.process_time()
            try:
                return fn(self, *a, **k)
            finally:
                if stack:
                    own[stack[-1][0]]["llvm_s"] += time.process_time() - t0

        return wrapper

    codegen.CPUCodeLibrary.add_ir_module = timed(codegen.CPUCodeLibrary.add_ir_module)
    codegen.CPUCodeLibrary.finalize = timed(codegen.CPUCodeLibrary.finalize)
    from rtsim.world import jit

    compiler = jit._linked_only_compiler()  # (its library's own finalize: the linking)
    for cell in compiler.compile_extra.__closure__ or ():
        lib = cell.cell_contents
        if isinstance(lib, type) and issubclass(lib, codegen.CPUCodeLibrary):
            lib.finalize = timed(lib.finalize)
    event.register("numba:compile", Compiles())
    event.register("numba:run_pass", Passes())
    t0 = time.process_time()
    cli_main([*COMMAND, "--out", out_dir])
    total = time.process_time() - t0
    print(json.dumps({"run_cpu_s": total, "kernels": own, "passes": pass_own}))


def profile() -> dict[str, Any]:
    """One first run in a child process with a fresh NUMBA_CACHE_DIR; its profile."""
    tmp = Path(tempfile.mkdtemp(prefix="compile_profile_"))
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp / "cache"), "RTSIM_PROGRESS": "0"}
    t0 = time.time()
    out = subprocess.run(
        [sys.executable, __file__, "--child", str(tmp / "out")],
        check=True,
        env=env,
        capture_output=True,
        text=True,
    ).stdout
    prof: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    prof["wall_s"] = time.time() - t0
    prof["load"] = os.getloadavg()[0]
    return prof


def show(prof: dict[str, Any], least: float, passes: bool) -> None:
    ks = prof["kernels"]
    tot = sum(r["s"] for r in ks.values())
    llvm = sum(r["llvm_s"] for r in ks.values())
    print(f"{'own s':>7} {'llvm s':>7} {'n':>3}  kernel [kind]")
    for key, r in sorted(ks.items(), key=lambda kv: -kv[1]["s"]):
        if r["s"] >= least:
            print(f"{r['s']:7.2f} {r['llvm_s']:7.2f} {r['n']:3d}  {key}")
    by_kind: dict[str, float] = {}
    for r in ks.values():
        by_kind[r["kind"]] = by_kind.get(r["kind"], 0.0) + r["s"]
    kinds = ", ".join(f"{k} {v:.2f}" for k, v in sorted(by_kind.items()))
    n = sum(r["n"] for r in ks.values())
    print(f"{tot:7.2f} {llvm:7.2f} {n:3d}  all compiles ({len(ks)} functions; {kinds})")
    print(f"run CPU {prof['run_cpu_s']:.2f} s in-process (load {prof.get('load', 0):.1f})")
    twice = {k: r["sigs"] for k, r in ks.items() if r["n"] > 1}
    for key, sigs in twice.items():
        print(f"  compiled {len(sigs)}x: {key}: " + " | ".join(sigs))
    if passes:
        for name, s in sorted(prof["passes"].items(), key=lambda kv: -kv[1]):
            if s >= least:
                print(f"  pass {s:6.2f} s  {name}")


def diff(a: dict[str, Any], b: dict[str, Any], least: float) -> None:
    ka, kb = a["kernels"], b["kernels"]

    def most(k: str) -> float:
        return -max(ka.get(k, {}).get("s", 0.0), kb.get(k, {}).get("s", 0.0))

    keys = sorted(set(ka) | set(kb), key=most)
    print(f"{'before':>7} {'after':>7} {'n':>5}  kernel [kind]")
    for k in keys:
        sa, sb = ka.get(k, {}).get("s", 0.0), kb.get(k, {}).get("s", 0.0)
        if max(sa, sb) >= least:
            n = f"{ka.get(k, {}).get('n', 0)}/{kb.get(k, {}).get('n', 0)}"
            print(f"{sa:7.2f} {sb:7.2f} {n:>5}  {k}")
    ta = sum(r["s"] for r in ka.values())
    tb = sum(r["s"] for r in kb.values())
    print(f"{ta:7.2f} {tb:7.2f}        all compiles")
    print(f"{a['run_cpu_s']:7.2f} {b['run_cpu_s']:7.2f}        run CPU in-process")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", help="write the profile to this file")
    ap.add_argument("--passes", action="store_true", help="numba's passes summed too")
    ap.add_argument("--min", type=float, default=0.03, help="hide rows below (s)")
    ap.add_argument("--diff", nargs=2, metavar=("BEFORE", "AFTER"))
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child:
        _child(args.child)
        return 0
    if args.diff:
        a, b = (json.loads(Path(p).read_text()) for p in args.diff)
        diff(a, b, args.min)
        return 0
    prof = profile()
    show(prof, args.min, args.passes)
    if args.json:
        Path(args.json).write_text(json.dumps(prof))
    return 0


if __name__ == "__main__":
    sys.exit(main())
