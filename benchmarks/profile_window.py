"""Where a window's CPU time goes: a warm sweep point of Test 2, by stage (not a test).

    python benchmarks/profile_window.py [--scenario test2] [--followers 2,6] [--repeat 3]

Runs ``run_scenario(SCENARIO, record_jobs=False)`` once to warm up (imports, kernels), then
``--repeat`` laps with the world's, the localization's and the coupling's stage methods
wrapped in CPU timers (``time.process_time``). Each stage's time is exclusive: what a
wrapped call spends inside another wrapped call counts to the inner one. The rest of the
lap (the scheduler's dispatcher, SimPy, the run's set-up and tables) is the lap's CPU time
less the stages'. Prints µs per window for each stage (the best lap), and the lap's CPU
time unwrapped beside it: each wrapper costs ≈ 0.3 µs, about 10 per window.
"""

from __future__ import annotations

import argparse
import functools
import time
from collections import Counter
from collections.abc import Callable
from typing import Any

from _machine import print_machine

#: (module, class or None, attribute, stage): the methods timed, and the stage they count to
TIMED = [
    ("rtsim.world.hough", "Accumulator", "locate", "Hough accumulator (compiled)"),
    ("rtsim.world.hough", "Accumulator", "search", "Hough accumulator (compiled)"),
    ("rtsim.world.rangefinder", "Rangefinder", "scan", "laser scan (compiled)"),
    # (the compiled world's scan: laser, centres, Hough windows and changes in one call)
    ("rtsim.world.scanstep", "FusedScan", "run", "scan kernel: laser + Hough (compiled)"),
    ("rtsim.world.world", "World", "scan", "scan + localization (Python)"),
    # (the run's scan and estimate in one call: the compiled world's EKF inside its kernel)
    ("rtsim.world.world", "World", "scan_estimate", "scan + localization (Python)"),
    ("rtsim.world.world", "World", "estimate", "EKF"),
    ("rtsim.world.world", "World", "_estimated", "EKF"),
    ("rtsim.world.world", "World", "command", "commands"),
    ("rtsim.coupling.scenario_run", "_Coupling", "_decide", "decision set-up (Python)"),
    ("rtsim.coupling.physical", "PhysicalLog", "add", "truth log"),
    ("rtsim.coupling.scenario_run", "_Coupling", "_on_scan", "hooks and records"),
    ("rtsim.coupling.scenario_run", "_Coupling", "_on_release", "hooks and records"),
    ("rtsim.coupling.scenario_run", "_Coupling", "_on_send", "hooks and records"),
    ("rtsim.coupling.scenario_run", "_Coupling", "_on_done", "hooks and records"),
    ("rtsim.coupling.scenario_run", "_Coupling", "_close", "hooks and records"),
]

#: methods that return the function a run calls per window (bound once per run): that function
#: is timed, (module, class, attribute, stage)
MADE = [("rtsim.coupling.physical", "PhysicalLog", "adder", "truth log")]

#: the compiled rollout's entries (`rtsim.control.kernels.rollout_kernels`), timed the same way
ROLLOUT = ("roll_or_decide",)  # (the decision and a whole rollout: one entry)
ROLLOUT_STAGE = "rollout kernels (compiled)"
REST = "dispatcher, SimPy, set-up, tables"


class Timers:
    """Exclusive CPU time per stage: a stack of the wrapped calls open now."""

    def __init__(self) -> None:
        self.spent: Counter[str] = Counter()
        self._stack: list[list[float]] = []  # [start, time in nested wrapped calls]

    def wrap(self, fn: Callable[..., Any], stage: str) -> Callable[..., Any]:
        clock, stack, spent = time.process_time, self._stack, self.spent

        def timed(*args: Any, **kw: Any) -> Any:
            frame = [clock(), 0.0]
            stack.append(frame)
            try:
                return fn(*args, **kw)
            finally:
                stack.pop()
                total = clock() - frame[0]
                spent[stage] += total - frame[1]
                if stack:
                    stack[-1][1] += total

        return timed


def install(timers: Timers) -> None:
    """Wrap every method of `TIMED` and the rollout's kernels."""
    import importlib

    from rtsim.control.compiled_rollout import call
    from rtsim.control.kernels import rollout_kernels

    for mod, cls, attr, stage in TIMED:
        owner = getattr(importlib.import_module(mod), cls)
        if hasattr(owner, attr):  # (an older checkout may lack one: its stage is then 0)
            setattr(owner, attr, timers.wrap(getattr(owner, attr), stage))
    for mod, cls, attr, stage in MADE:
        owner = getattr(importlib.import_module(mod), cls)
        if hasattr(owner, attr):
            setattr(owner, attr, _timed_maker(timers, getattr(owner, attr), stage))
    ns = rollout_kernels()
    for name in ROLLOUT:  # (each through its compiled function, as the run calls it)
        fn = functools.partial(call, getattr(ns, name))
        setattr(ns, name, timers.wrap(fn, ROLLOUT_STAGE))


def _timed_maker(timers: Timers, make: Callable[..., Any], stage: str) -> Callable[..., Any]:
    """``make`` whose returned function is wrapped in ``stage``'s timer (`MADE`)."""

    @functools.wraps(make)
    def made(*args: Any, **kw: Any) -> Any:
        return timers.wrap(make(*args, **kw), stage)

    return made


def laps(scenario: str, followers: int, repeat: int, timers: Timers | None = None) -> Any:
    """The best of ``repeat`` warm laps: unwrapped (``timers`` None), (CPU ms, windows);
    wrapped, µs per window per stage of the fastest lap."""
    from rtsim.coupling import run_scenario

    ov = {"formation.followers": followers}
    run_scenario(scenario, record_jobs=False, overrides=ov)  # warm-up
    best: Any = None
    for _ in range(repeat):
        if timers is not None:
            timers.spent.clear()
        t = time.process_time()
        res = run_scenario(scenario, record_jobs=False, overrides=ov)
        lap = time.process_time() - t
        windows = int(res.summary["windows"])
        if timers is None:
            best = min(best or (lap, windows), (lap, windows))
            continue
        stages = dict(timers.spent)
        stages[REST] = lap - sum(stages.values())
        if best is None or lap < sum(best.values()):
            best = stages
    if timers is None:
        return 1e3 * best[0], best[1]
    return {k: 1e6 * v / windows for k, v in best.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="test2")
    ap.add_argument("--followers", default="2,6", help="comma-separated follower counts")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args(argv)
    print_machine()
    counts = [int(x) for x in args.followers.split(",")]
    plain = {n: laps(args.scenario, n, args.repeat) for n in counts}
    timers = Timers()
    install(timers)
    for n in counts:
        us = laps(args.scenario, n, args.repeat, timers)
        lap_ms, windows = plain[n]
        total = sum(us.values())
        print(
            f"\n{args.scenario}, {n} followers: {windows} windows; lap {lap_ms:.1f} ms CPU "
            f"unwrapped ({1e3 * lap_ms / windows:.0f} us/window), {total:.0f} us/window wrapped"
        )
        for stage, v in sorted(us.items(), key=lambda kv: -kv[1]):
            print(f"  {stage:36s} {v:7.1f} us/window  {100 * v / total:5.1f} %")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
