"""``rtsim scenario FILE --out DIR``: run a robot scenario, schedule and world in one SimPy run.

Writes to DIR: ``windows.csv`` (one row per processing window; schema in
docs/outputs.md) and ``windows.parquet`` with ``--parquet``, ``jobs.csv`` (the job
records of the schedule), ``summary.json``, the paper's figures as PNG (paths, window and
slack, effective bounds, leader speed, and the operating space) unless ``--no-figures``, and
``manifest.json`` (rtsim version, seed, argv, the scenario file's text and resolved values,
``timing.simulation_s`` — the simulation loop alone — and ``timing.total_s``).

``--duration`` is simulated seconds; by default the scenario's ``duration``, else one lap of
the leader's path plus the followers' separation (see :mod:`rtsim.coupling.scenario_run`).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path
from typing import Any

from rtsim.errors import InputError

__all__ = ["register", "run"]

MODES = ("adjust", "fixed-wsch", "min-msb")


def register(sub: Any) -> None:
    """Add the ``scenario`` sub-command."""
    p = sub.add_parser("scenario", help="run a robot-group scenario (schedule + world)",
                       description=__doc__.splitlines()[0])
    p.add_argument("file", help="scenario TOML file")
    p.add_argument("--mode", choices=MODES, default="adjust",
                   help="adjust (the paper's algorithm, default), fixed-wsch (w = w_sch, speed "
                        "never lowered) or min-msb (w = min MSB, speed never lowered)")
    p.add_argument("--duration", type=float, default=None, metavar="SECONDS",
                   help="simulated seconds (default: the scenario's, else one lap)")
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument("--exec", dest="exec_model", choices=("wcet", "uniform"), default="wcet",
                   help="execution times of the fixed segments (default wcet)")
    p.add_argument("--no-figures", action="store_true", help="do not draw the PNG figures")
    p.add_argument("--parquet", action="store_true", help="also write windows.parquet")
    p.add_argument("--perfetto", metavar="FILE",
                   help="also write the schedule as a Chrome/Perfetto trace (JSON; open in "
                        "ui.perfetto.dev)")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--force", action="store_true",
                   help="run even above the work limits (2e6 windows, 2e8 world steps x "
                        "followers)")
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """Run the scenario and write DIR (see the module docstring)."""
    t0 = time.perf_counter()
    from rtsim.coupling import run_scenario
    from rtsim.io.atomic import write_json, write_table
    from rtsim.io.manifest import write_manifest

    if args.duration is not None and not (0 < args.duration < float("inf")):
        raise InputError(f"--duration must be a positive number of seconds, got "
                         f"{args.duration!r}")
    if args.seed < 0:
        raise InputError(f"--seed must be a non-negative integer, got {args.seed!r}")
    from rtsim.io.scenario import load_scenario
    from rtsim.io.work import check_scenario

    where = (f"--duration {args.duration:g}" if args.duration is not None
             else f"{args.file}: duration")
    scenario = load_scenario(args.file)
    check_scenario(scenario, args.duration, where, force=args.force)
    try:
        res = run_scenario(Path(args.file), mode=args.mode, duration_s=args.duration,
                           seed=args.seed, record_jobs=True, exec_model=args.exec_model,
                           record_trace=bool(args.perfetto))
    except InputError as exc:  # raised inside the run (an estimate, a state): name the file
        src = scenario.source or str(args.file)
        if str(exc).startswith(src):
            raise
        raise type(exc)(f"{src}: during the run (seed {args.seed}): {exc}") from None
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    outputs = ["windows.csv", "jobs.csv", "summary.json"]
    write_table(out / "windows.csv", res.windows)
    if args.parquet:
        write_table(out / "windows.parquet", res.windows)
        outputs.append("windows.parquet")
    if res.jobs is not None:
        write_table(out / "jobs.csv", res.jobs)
    from rtsim.io.summary import summary_json

    write_json(out / "summary.json", summary_json(res.summary))
    if args.perfetto:
        from rtsim.export.perfetto import write_perfetto

        assert res.jobs is not None and res.trace is not None
        write_perfetto(args.perfetto, res.jobs, res.trace, windows=res.windows,
                       tasks=[t.name for t in sorted(res.inputs.taskset.tasks,
                                                     key=lambda t: t.priority)],
                       metadata={"command": "scenario", "scenario": res.summary["scenario"],
                                 "mode": args.mode, "seed": args.seed})
        p = Path(args.perfetto).resolve()
        if p.parent == out.resolve():
            outputs.append(p.name)
    if not args.no_figures:
        from rtsim.plots.scenario import write_scenario_figures

        label = f"{res.inputs.name or Path(args.file).stem}, {args.mode}"
        paths = write_scenario_figures(res.windows, out, label=label)
        outputs += [p.name for p in paths]
    inp = res.inputs
    timing = dict(res.timing)
    timing["total_s"] = time.perf_counter() - t0
    write_manifest(
        out, command="scenario", seed=args.seed,
        inputs={"scenario_file": str(args.file), "scenario_text": inp.text,
                "scenario": inp.resolved, "mode": args.mode, "duration_s": args.duration,
                "exec_model": args.exec_model},
        argv=["rtsim", *sys.argv[1:]],
        extra={"timing": timing, "outputs": [*outputs, "report.html"]},
    )
    from rtsim.report import write_run_report

    label = res.inputs.name or Path(args.file).stem
    write_run_report(out, title=f"rtsim scenario: {label}, {args.mode}")
    s = res.summary
    print(f"{s['scenario'] or args.file} [{s['mode']}] {s['duration_s']:.1f} s, "
          f"{s['windows']} windows: missed {s['missed']}, tracks lost {s['tracks_lost']}, "
          f"violations {sum(s['violations'].values())}, critical {s['critical_share']:.1%}, "
          f"min MSB/w_sch {s['min_msb_over_wsch']:.3f}, min V_L/V_Ld "
          f"{s['min_speed_ratio']:.3f}  -> {out}")
    return 0
