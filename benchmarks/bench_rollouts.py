"""Benchmark: what a cheaper rollout would change — its CPU per lap and the decisions.

    python benchmarks/bench_rollouts.py [--runs test2:2,test2:8,test1:2,test1:9]
        [--seeds 0,13,17,21] [--variants step=20,step=50,step=240,arc] [--json]

Each run (scenario:followers, seed; one lap, ``run_scenario(..., record_jobs=False)``) is
played with the shipped rollout and with each variant, in this process, the rollouts'
kernel calls timed (`bench_sweep_point.time_rollouts`) and counted
(`rtsim.control.rollout.rollouts_run`). Variants (benchmark-only patches, no input key):

* ``step=S``: the rollout integrates a ramping wheel speed in steps of S ms instead of the
  world's ``step_ms`` (the world itself unchanged);
* ``arc``: every held command's ramp folded into one arc at its mean speed, whatever its
  length (the step made infinite: the analytic arc over a held command);
* ``search=G:T``: the plan's speed search on G speeds and to T·V_Ld (the shipped 8 and
  0.005; `rtsim.control.adjust.ROLLOUT_GRID`, ``ROLLOUT_TOL``) — the coarser search, a
  modelling choice, for comparison.

Per run and variant: the rollouts per lap and their CPU, the windows whose decision (window
length ``w``, leader target ``v_leader_target``, ``method``) differs from the shipped one at
all and by more than 1e-6 relative, the first such window, and the outcomes beside the
shipped ones: windows, lap time, critical share, missed deadlines, collisions, contact and
path-diversion violations. Prints one line per (run, variant) and, with ``--json``, all
rows as one JSON line at the end. Run by hand (docs/planning.md, "what a cheaper rollout
would change").
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

from _machine import print_machine
from bench_sweep_point import time_rollouts

#: the outcomes compared (summary.json keys; ``violations.*`` from its violations dict)
OUTCOMES = (
    "windows",
    "lap_time_s",
    "critical_share",
    "missed",
    "collisions",
    "violations.contact",
    "violations.path_diversion",
)


@contextmanager
def variant(spec: str) -> Iterator[None]:
    """The rollout changed as ``spec`` says (module docstring) while the block runs."""
    import rtsim.control.rollout as ro_mod
    import rtsim.coupling.scenario_run as run_mod

    if spec == "shipped":
        yield
        return
    if spec.startswith("search="):
        grid, tol = spec.split("=", 1)[1].split(":")
        old = ro_mod.ROLLOUT_GRID, ro_mod.ROLLOUT_TOL
        ro_mod.ROLLOUT_GRID, ro_mod.ROLLOUT_TOL = int(grid), float(tol)
        try:
            yield
        finally:
            ro_mod.ROLLOUT_GRID, ro_mod.ROLLOUT_TOL = old
        return
    step = 1e12 if spec == "arc" else float(spec.split("=", 1)[1])
    real = run_mod.RolloutState

    def coarse(*a: Any, **kw: Any) -> Any:
        return dataclasses.replace(real(*a, **kw), step_ms=step)

    run_mod.RolloutState = coarse  # type: ignore[assignment,misc]
    try:
        yield
    finally:
        run_mod.RolloutState = real  # type: ignore[misc]


def outcome(summary: dict[str, Any], key: str) -> Any:
    """``summary[key]``, ``violations.K`` read from its violations dict."""
    if key.startswith("violations."):
        return summary["violations"][key.split(".", 1)[1]]
    return summary[key]


def one(scenario: str, n: int, seed: int, spec: str, spent: list[float]) -> dict[str, Any]:
    """One lap of ``scenario`` with ``n`` followers and ``seed`` under variant ``spec``: its
    decisions (w, target, method per window), outcomes, rollouts and their CPU (ms)."""
    from rtsim.control.rollout import rollouts_run
    from rtsim.coupling import run_scenario

    with variant(spec):
        r0, s0, t0 = rollouts_run(), spent[0], time.process_time()
        res = run_scenario(
            scenario, seed=seed, record_jobs=False, overrides={"formation.followers": n}
        )
        cpu = time.process_time() - t0
    win = res.windows
    cols = (win["w"].tolist(), win["v_leader_target"].tolist(), win["method"].tolist())
    return {
        "decisions": list(zip(*cols, strict=True)),
        "outcomes": {k: outcome(res.summary, k) for k in OUTCOMES},
        "rollouts": rollouts_run() - r0,
        "rollouts_ms": 1e3 * (spent[0] - s0),
        "lap_cpu_ms": 1e3 * cpu,
    }


def compare(base: list[Any], other: list[Any]) -> dict[str, Any]:
    """Windows whose decision differs at all and beyond 1e-6 relative, and the first."""
    at_all = beyond = 0
    first = None
    for i, (a, b) in enumerate(zip(base, other, strict=False)):
        if a == b:
            continue
        at_all += 1
        first = i if first is None else first
        rel = max(abs(x - y) / max(abs(x), 1e-300) for x, y in zip(a[:2], b[:2], strict=True))
        beyond += rel > 1e-6 or a[2] != b[2]
    extra = abs(len(base) - len(other))
    return {"differ": at_all + extra, "differ_1e6": beyond + extra, "first": first}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", default="test2:2,test2:8,test1:2,test1:9")
    ap.add_argument("--seeds", default="0,13,17,21")
    ap.add_argument("--variants", default="step=20,step=50,step=240,arc")
    ap.add_argument("--json", action="store_true", help="print all rows as one JSON line")
    args = ap.parse_args(argv)
    m = print_machine()
    from rtsim.coupling import run_scenario

    run_scenario("test2", record_jobs=False)  # warm: imports, compiled kernels
    spent = time_rollouts()
    rows = []
    for run in args.runs.split(","):
        scenario, n = run.split(":")
        for seed in (int(s) for s in args.seeds.split(",")):
            base = one(scenario, int(n), seed, "shipped", spent)
            print(
                f"{scenario} n={n} seed={seed} shipped: {len(base['decisions'])} windows, "
                f"{base['rollouts']:,} rollouts, {base['rollouts_ms']:.1f} ms in them, "
                f"lap {base['lap_cpu_ms']:.0f} ms CPU; {base['outcomes']}",
                flush=True,
            )
            for spec in args.variants.split(","):
                got = one(scenario, int(n), seed, spec, spent)
                diff = compare(base["decisions"], got["decisions"])
                changed = {
                    k: (base["outcomes"][k], v)
                    for k, v in got["outcomes"].items()
                    if v != base["outcomes"][k]
                }
                row = {
                    "scenario": scenario,
                    "followers": int(n),
                    "seed": seed,
                    "variant": spec,
                    "rollouts": (base["rollouts"], got["rollouts"]),
                    "rollouts_ms": (base["rollouts_ms"], got["rollouts_ms"]),
                    **diff,
                    "outcomes_changed": changed,
                }
                rows.append(row)
                print(
                    f"  {spec}: rollouts {got['rollouts']:,}, {got['rollouts_ms']:.1f} ms; "
                    f"decisions differ in {diff['differ']} windows ({diff['differ_1e6']} "
                    f"beyond 1e-6, first {diff['first']}); outcomes changed: {changed}",
                    flush=True,
                )
    if args.json:
        print(json.dumps({"machine": m, "rows": rows}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
