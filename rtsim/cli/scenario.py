"""``rtsim scenario FILE --out DIR``: run a robot scenario, schedule and world in one SimPy run.

Writes to DIR: ``windows.csv`` (one row per processing window; schema in
docs/outputs.md) and ``windows.parquet`` with ``--parquet``, ``followers.csv`` (the same in
long form: one row per window and follower, `rtsim.coupling.tidy`), ``jobs.csv`` (the job
records of the schedule), ``summary.json``, the paper's figures as PNG (paths, window and
slack, effective bounds, leader speed, and the operating space) unless ``--no-figures``, and
``manifest.json`` (rtsim version, seed, argv, the scenario file's text and resolved values,
``timing.simulation_s`` — the simulation loop alone — and ``timing.total_s``).

DIR is written whole (`rtsim.io.outdir`): everything goes into a hidden staging
directory beside it, checked writable before the simulation starts, which replaces DIR only
at the end — a reader never sees files of two runs, an interrupted run leaves the earlier one
as it was, and files of an earlier run that this one does not write do not survive. DIR must
be new, empty or an earlier rtsim output. Windows and job records are written in chunks
during the run, and the summary and figures are made from the columns read back, so memory
stays flat on long runs.

``--duration`` is simulated seconds, exact, like the file's ``duration`` and ``--set
duration=S``; without any, the run ends with the lap (``until = "lap"``: the leader's lap plus
the followers' separation, `rtsim.coupling.duration`), and says so in one line.

A file's unsaid choices are the recommended model (``preset = "recommended"``: policy
``plan``, predictor ``commands``, follow-the-leader followers in a ``fan``, windows centred
at the predicted position, searches for visible followers only, as the shipped test1/test2);
``preset = "paper"`` (or ``--set preset=paper``) takes the paper's own (docs/configuration.md).
"""

from __future__ import annotations

import secrets
import sys
import time
from pathlib import Path
from typing import Any

from rtsim.cli._set import add_set_option, set_overrides, set_strings
from rtsim.cli.common import (
    add_exec,
    add_figure_options,
    add_force,
    add_json,
    add_quiet,
    check_suffix,
    simulation_bar,
)
from rtsim.cli.plausible import check_duration, check_scenario_units
from rtsim.control.policy import ADJUSTMENT_POLICIES, policy_class
from rtsim.errors import InputError
from rtsim.io.atomic import dumps, write_json
from rtsim.io.manifest import build_manifest, write_manifest
from rtsim.io.outdir import FileSet, sidecar, stage
from rtsim.io.spool import Spool, Tee
from rtsim.io.summary import summary_json
from rtsim.sim.records import jobs_frame

__all__ = ["register", "run"]

MODES = ("adjust", "fixed-wsch", "min-msb")


def register(sub: Any) -> None:
    """Add the ``scenario`` sub-command."""
    p = sub.add_parser(
        "scenario",
        help="run a robot-group scenario (schedule + world)",
        description=__doc__.splitlines()[0]
        + " A file's unsaid choices are the recommended model (policy plan, predictor "
        "commands, follow-the-leader followers in a fan, predicted/visible localization, "
        'as test2); preset = "paper" takes the paper\'s own (docs/configuration.md).',
    )
    p.add_argument("file", help="scenario TOML file")

    p.add_argument(
        "--policy",
        default=None,
        metavar="NAME",
        help="adjustment policy, overriding the file's [adjust] policy: "
        f"{', '.join(ADJUSTMENT_POLICIES)} (default plan, the recommended model; adjust is the "
        'paper\'s algorithm, also preset = "paper"), or package.module:Name '
        "(docs/adjustment.md)",
    )
    p.add_argument(
        "--mode",
        choices=MODES,
        default=None,
        help="alias of --policy: adjust (the paper's algorithm), fixed-wsch (w = "
        "w_sch, speed never lowered) or min-msb (w = min MSB, speed never "
        "lowered)",
    )
    p.add_argument(
        "--duration",
        type=float,
        default=None,
        metavar="SECONDS",
        help="simulated seconds, exact (default: the file's duration, else to the end of "
        'the lap, until = "lap")',
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    add_exec(p, "execution times of the fixed segments: wcet (default) or uniform in [bcet, wcet]")
    p.add_argument("--no-figures", action="store_true", help="do not draw the figures")
    p.add_argument("--parquet", action="store_true", help="also write windows.parquet")

    add_figure_options(p, default_dpi=300)  # rtsim.plots.scenario.DPI (not imported: slow)
    p.add_argument(
        "--perfetto",
        metavar="FILE",
        help="also write the schedule as a Chrome/Perfetto trace (JSON; open in ui.perfetto.dev)",
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")

    add_set_option(p)
    add_force(
        p,
        "run even above the work limits (2e6 windows, 2e8 world steps x "
        "followers), or a duration over 6 simulated hours",
    )
    add_json(p, "print summary.json on stdout instead of the summary line")
    add_quiet(p, "no progress bar, no summary line")
    p.set_defaults(func=run)


def run(args: Any) -> int:
    """Run the scenario and write DIR (see the module docstring)."""
    t0 = time.perf_counter()

    if args.duration is not None and not (0 < args.duration < float("inf")):
        raise InputError(f"--duration must be a positive number of seconds, got {args.duration!r}")
    if args.seed < 0:
        raise InputError(f"--seed must be a non-negative integer, got {args.seed!r}")

    check_duration(args, args.duration)
    from rtsim.config.scenario import load_scenario  # lazy: CLI start-up (numpy)
    from rtsim.coupling.duration import check_scenario  # lazy: CLI start-up (pandas)

    where = (
        f"--duration {args.duration:g}" if args.duration is not None else f"{args.file}: duration"
    )
    if args.mode is not None and args.policy is not None and args.mode != args.policy:
        raise InputError(
            f"--mode is an alias of --policy: give one, got --mode {args.mode} "
            f"and --policy {args.policy}"
        )
    if args.policy is not None:
        policy_class(args.policy, "--policy", allow_code=True)

    scenario = load_scenario(args.file, overrides=set_overrides(args))
    override = args.policy if args.policy is not None else args.mode
    args.mode = override if override is not None else scenario.adjust.policy

    check_scenario_units(args, scenario)  # the options' unit hints, for the file's keys
    check_scenario(scenario, args.duration, where, force=args.force)

    inputs = (args.file, scenario.taskset)  # (a packaged set's name is no path here)
    with stage(args.out, command="scenario") as staged, FileSet("scenario", inputs=inputs) as files:
        perfetto = _perfetto_target(args, staged.path, Path(args.out), files)
        res = _write(
            args,
            staged.path,
            Path(args.out),
            t0,
            scenario.source or str(args.file),
            override,
            perfetto,
            files,
        )
        staged.commit()
        files.commit()
    s = res.summary
    from rtsim.coupling.duration import (  # lazy: CLI start-up (pandas)
        heading_warning,
        run_length,
        run_note,
    )

    to_lap = run_length(scenario.world, args.duration, scenario.duration).stop_s is not None
    note = None if args.quiet else run_note(s, to_lap)
    if note is not None:
        print(note, file=sys.stderr)
    heading = s.get("assumptions", {}).get("predicted_heading_sd")
    if heading is not None and not heading["held"] and not args.quiet:
        print(heading_warning(heading), file=sys.stderr)
    if args.json:
        print(dumps(summary_json(s)))
        return 0
    if args.quiet:
        return 0
    print(
        f"{s['scenario'] or args.file} [{s['mode']}] {s['duration_s']:.1f} s, "
        f"{s['windows']} windows: violations > 5 % "
        f"{sum(s['violations_beyond_5pct'].values())} (max ratio "
        f"{max(s['max_violation_ratio'].values()):.2f}), missed {s['missed']}, tracks lost "
        f"{s['tracks_lost']}, critical {s['critical_share']:.1%}, "
        f"min MSB/w_sch {s['min_msb_over_wsch']:.3f}, min V_L/V_Ld "
        f"{s['min_speed_ratio']:.3f}  -> {args.out}"
    )
    return 0


#: Rows of followers.csv (one per window and follower) built per chunk: windows.csv is read
#: back ``FOLLOWER_CHUNK_ROWS // n`` windows at a time for ``n`` followers, so the chunk's
#: frame and its CSV text stay the same size at any run length and follower count.
FOLLOWER_CHUNK_ROWS = 8_192


def _write_followers(windows_csv: Path, target: Path) -> None:
    """followers.csv: windows.csv in long form, one row per window and follower
    (`rtsim.coupling.tidy`), from the file read back in chunks of a bounded number of
    long rows (`FOLLOWER_CHUNK_ROWS`)."""
    import pandas as pd

    from rtsim.coupling.tidy import (  # lazy: CLI start-up (pandas)
        follower_count,
        followers_frame,
    )
    from rtsim.io.columns import ChunkWriter  # lazy: CLI start-up (pandas)

    first = pd.read_csv(windows_csv, nrows=0)
    windows = max(1, FOLLOWER_CHUNK_ROWS // max(1, follower_count(first.columns)))
    writer = ChunkWriter([target], followers_frame(first))
    for chunk in pd.read_csv(windows_csv, chunksize=windows):
        writer.write(followers_frame(chunk))
    writer.close()


def _perfetto_target(args: Any, out: Path, target: Path, files: Any) -> Path | None:
    """Where ``--perfetto`` is written: inside DIR, in the staging directory (listed with
    the run); elsewhere, checked and staged in ``files`` with a manifest of its own."""
    if not args.perfetto:
        return None

    check_suffix(args.perfetto, "--perfetto", (".json",))
    perfetto = Path(args.perfetto)
    if (
        perfetto.resolve().is_relative_to(target.resolve())
        and perfetto.resolve().parent != target.resolve()
    ):
        raise InputError(
            f"--perfetto {args.perfetto}: is inside a subdirectory of --out, "
            f"which the run replaces; give it in --out itself or elsewhere"
        )
    if perfetto.resolve().parent == target.resolve():
        if perfetto.name in (
            "manifest.json",
            "summary.json",
            "windows.csv",
            "jobs.csv",
            "windows.parquet",
            "report.html",
        ):
            raise InputError(
                f"--perfetto {args.perfetto}: is also a file of --out; give "
                f"each output its own file"
            )
        return out / perfetto.name

    files.check(sidecar(perfetto), "--perfetto")
    staged = files.add(perfetto, "--perfetto")

    write_json(
        files.add(sidecar(perfetto), "--perfetto"),
        build_manifest(
            command="scenario",
            seed=args.seed,
            inputs={"scenario_file": str(args.file)},
            extra={"outputs": [perfetto.name]},
        ),
    )
    return staged


def _write(
    args: Any,
    out: Path,
    target: Path,
    t0: float,
    src: str,
    override: str | None,
    perfetto: Path | None,
    files: Any = None,
) -> Any:
    """Run the scenario (file ``src``), writing every file into ``out`` (the staging
    directory of ``target``); returns the result."""
    from rtsim.coupling import run_scenario  # lazy: CLI start-up (pandas)
    from rtsim.io.columns import ChunkWriter  # lazy: CLI start-up (pandas)

    windows_files = [out / "windows.csv", *([out / "windows.parquet"] if args.parquet else [])]
    windows = ChunkWriter(windows_files, None)
    jobs = ChunkWriter([out / "jobs.csv"], jobs_frame([]))
    spools: tuple[Any, Any] | None = None
    if args.perfetto:  # records for the trace, on disk in the staging directory meanwhile
        scratch = out / f".rtsim-spool-{secrets.token_hex(4)}"
        spools = (
            Spool(f"{scratch}-jobs", label=args.perfetto),
            Spool(f"{scratch}-trace", label=args.perfetto),
        )
    if files is not None:  # closed after an error too, before the staging goes
        for w in (windows, jobs, *(spools or ())):
            files.on_release(getattr(w, "discard", w.close))

    try:
        with simulation_bar(args, "scenario") as bar:
            res = run_scenario(
                Path(args.file),
                policy=override,
                duration_s=args.duration,
                seed=args.seed,
                record_jobs=True,
                exec_model=args.exec_model,
                window_sink=windows,
                job_sink=Tee(jobs, spools[0]) if spools else jobs,
                trace_sink=spools[1] if spools else None,
                force=args.force,
                overrides=set_overrides(args) or None,
                progress=bar if bar.enabled else None,
                scratch_dir=out,
            )
    except InputError as exc:  # raised inside the run (an estimate, a state): name the file
        if str(exc).startswith(src):
            raise
        raise type(exc)(f"{src}: during the run (seed {args.seed}): {exc}") from None
    outputs = ["windows.csv", "followers.csv", "jobs.csv", "summary.json"]
    if args.parquet:
        outputs.append("windows.parquet")
    jobs.close()
    _write_followers(out / "windows.csv", out / "followers.csv")

    write_json(out / "summary.json", summary_json(res.summary))
    if spools is not None:
        from rtsim.export.perfetto import stream_perfetto  # lazy: CLI start-up (pandas)

        assert perfetto is not None
        stream_perfetto(
            perfetto,
            spools[0],
            spools[1],
            windows=windows.paths[0],
            tasks=[t.name for t in sorted(res.inputs.taskset.tasks, key=lambda t: t.priority)],
            metadata={
                "command": "scenario",
                "scenario": res.summary["scenario"],
                "mode": args.mode,
                "seed": args.seed,
            },
        )
        for sp in spools:
            sp.close()
        if perfetto.parent == out:
            outputs.append(perfetto.name)
    if not args.no_figures:
        from rtsim.plots.scenario import (  # lazy: CLI start-up (matplotlib)
            write_scenario_figures,
        )

        label = f"{res.inputs.name or Path(args.file).stem}, {args.mode}"
        df, sketch = _figure_table(out / "windows.csv", int(res.summary["n"]))
        from rtsim.plots.scenario import DPI  # lazy: CLI start-up (matplotlib)

        paths = write_scenario_figures(
            df, out, label=label, fmt=args.fig_format or "png", dpi=args.dpi or DPI, sketch=sketch
        )
        del df, sketch
        outputs += [p.name for p in paths]
    inp = res.inputs
    timing = dict(res.timing)
    timing["total_s"] = time.perf_counter() - t0
    write_manifest(
        out,
        command="scenario",
        seed=args.seed,
        inputs={
            "scenario_file": str(args.file),
            "scenario_text": inp.text,
            "scenario": inp.resolved,
            "mode": args.mode,
            "duration_s": args.duration,
            "exec_model": args.exec_model,
            "set": set_strings(args),
        },
        argv=["rtsim", *sys.argv[1:]],
        extra={"timing": timing, "outputs": [*outputs, "report.html"]},
    )

    from rtsim.report import write_run_report  # lazy: CLI start-up (~2 ms)

    label = res.inputs.name or Path(args.file).stem
    write_run_report(out, title=f"rtsim scenario: {label}, {args.mode}")
    return res


def _figure_table(path: Path, n: int) -> tuple[Any, Any]:
    """The rows and columns the figures draw, read back from windows.csv in bounded chunks,
    and a long run's sketch of its paths and dots (`rtsim.plots.scenario_data.read_figures`)."""
    from rtsim.plots.scenario_data import read_figures  # lazy: CLI start-up (matplotlib)

    return read_figures(path, n)
