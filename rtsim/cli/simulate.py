"""``rtsim simulate FILE --horizon H``: run a task set on the virtual CPU and report per task.

Output files (``--jobs``, ``--trace``, ``--gantt``, ``--histogram``, ``--perfetto``) are
written to temporary files beside their targets — made before the simulation starts, so an
unwritable place is refused at once — and renamed in together at the end
(`rtsim.io.outdir.FileSet`). Every directory that receives one also gets a manifest
(rtsim version, seed, resolved inputs including the task set, command line, and the list of
outputs written there): ``manifest.json`` when the directory has none or has one of an
earlier ``simulate`` whose files this run replaces all of, else ``<file>.manifest.json``
beside each file, so another run's ``manifest.json`` (a scenario directory's, say) is never
overwritten. Records are never held for the whole run: job records and trace rows go to
their files in chunks as the run makes them (``--jobs``, ``--trace``), to scratch files in
the staging directory that ``--perfetto`` is written from afterwards, and ``--gantt`` keeps
only those inside its time range (a range holding more than 2,000 jobs is cut, and the
chart's title says so) — memory stays flat for any horizon.

For a processing-window set (``[window]``), ``--followers``/``--hough-radius`` change n and
r_H, the window is fixed at ``--window`` (default: the analytic w_sch), and the report puts
the chain's simulated response times beside w_sch and w_rta.
"""

from __future__ import annotations

import argparse
import math
import re
import secrets
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any, NamedTuple

from rtsim.analysis.bounds import window_bounds
from rtsim.analysis.rta import analyze
from rtsim.analysis.transaction import transaction_bounds
from rtsim.cli import one_line
from rtsim.cli._set import add_set_option, set_overrides, set_strings
from rtsim.cli.common import (
    add_figure_options,
    add_force,
    add_json,
    add_quiet,
    add_simulation,
    check_suffix,
    figure_format,
    note,
    simulation_bar,
)
from rtsim.cli.plausible import check_horizon, check_hough_radius, periods_ms, warn_short_horizon
from rtsim.config.taskset import load_taskset, taskset_to_dict
from rtsim.errors import InputError
from rtsim.io.atomic import dumps, write_json
from rtsim.io.manifest import build_manifest
from rtsim.io.outdir import FileSet, sidecar
from rtsim.io.spool import Spool, Tee
from rtsim.io.work import TooMuchWork, check_simulate, simulate_jobs
from rtsim.sim import simulate
from rtsim.sim.policy import resolve_scheduler
from rtsim.sim.records import jobs_frame, trace_frame
from rtsim.sim.run import worst_jitter_shifts

__all__ = ["register", "run"]

#: Resolution (dots per inch) of the raster --gantt and --histogram figures.
GANTT_DPI = HISTOGRAM_DPI = 120

_RANGE = re.compile(r"^\s*([-+0-9.eE]+)\s*\.\.\s*([-+0-9.eE]+)\s*$")


def worst_jitter_note(late: list[str]) -> str:
    """The line ``--jitter worst`` prints for per-window tasks it cannot move to the
    critical instant (`rtsim.sim.run.worst_jitter_shifts`)."""
    names = ", ".join(f"'{n}'" for n in late)
    return (
        f"--jitter worst: {names} cannot arrive before the window's first arrival "
        "(a per-window task): its first release is at the window's arrival plus its "
        "jitter, not at the critical instant"
    )


def register(sub: Any) -> None:
    """Add the ``simulate`` sub-command."""
    p = sub.add_parser(
        "simulate",
        help="simulate a task set on the virtual CPU",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("file", help="task-set TOML file")
    p.add_argument(
        "--horizon",
        type=float,
        required=True,
        help="jobs released in [0, H) ms are simulated to completion",
    )
    p.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    p.add_argument(
        "--overhead",
        type=float,
        default=None,
        help="context-switch overhead in ms (default: the file's overhead, or 0)",
    )
    p.add_argument(
        "--jitter",
        choices=("random", "worst", "none"),
        default="random",
        help="release delays of tasks with a jitter: uniform in [0, J] (default), "
        "worst (the analysis' critical instant) or none",
    )
    p.add_argument(
        "--scheduler",
        help="the CPU's scheduling policy: fp (fixed priority) or edf (earliest "
        "deadline first), or package.module:Name (default: the file's "
        "[scheduler] policy, else fp)",
    )
    add_simulation(p)
    p.add_argument("--jobs", help="per-job records, .csv or .parquet")
    p.add_argument("--trace", help="execution-interval trace, .csv or .parquet")
    p.add_argument("--gantt", help="Gantt chart, .png, .svg or .pdf (with --gantt-range A..B ms)")
    p.add_argument("--gantt-range", help="time range of the Gantt chart, A..B in ms")
    p.add_argument(
        "--histogram", help="response-time histograms, .png, .svg or .pdf, one panel per task"
    )
    p.add_argument(
        "--perfetto",
        metavar="FILE",
        help="the schedule as a Chrome/Perfetto trace (JSON; open in ui.perfetto.dev)",
    )

    add_figure_options(
        p,
        default_dpi=GANTT_DPI,
        what="--gantt and --histogram figures",
        default="the file's suffix, else png",
    )
    add_json(p)
    add_quiet(p, "no progress bar, no table")
    add_set_option(p)
    add_force(
        p,
        "run even when the horizon gives more than 5e7 jobs, or looks like a "
        "mistake of unit (shorter than one window)",
    )
    p.set_defaults(func=run)


def _gantt_range(text: str | None, horizon: float) -> tuple[float, float]:
    if text is None:
        return 0.0, min(horizon, 2000.0)
    m = _RANGE.match(text)
    try:
        a, b = (float(m.group(1)), float(m.group(2))) if m else (math.nan, math.nan)
    except ValueError:
        a = b = math.nan
    if not (math.isfinite(a) and math.isfinite(b) and b > a):
        raise InputError(f"--gantt-range: expected A..B with A < B (ms), got {text!r}")
    return a, b


def _bounded_range(
    ts: Any, rng: tuple[float, float], w: float | None
) -> tuple[tuple[float, float], float | None]:
    """The Gantt range, cut to hold at most GANTT_MAX_JOBS jobs (estimated from the periods),
    and the end it had when cut (None: not cut)."""
    from rtsim.plots.gantt import GANTT_MAX_JOBS  # lazy: CLI start-up (matplotlib)

    a, b = rng
    jobs = simulate_jobs(ts, b - a, w)
    if jobs <= GANTT_MAX_JOBS:
        return rng, None
    return (a, a + (b - a) * GANTT_MAX_JOBS / jobs), b


def require_bcet(ts: Any, source: str) -> None:
    """``--exec uniform`` draws in [bcet, wcet]: a task (other than the processing window,
    whose Hough time varies anyway) with no bcet would silently run at its WCET."""
    win = ts.window.name if ts.window is not None else None
    for t in ts.tasks:
        if t.name == win or t.bcet is not None:
            continue
        if t.segments and all(s.bcet is not None for s in t.segments):
            continue
        raise InputError(
            f"{source}: task '{t.name}': --exec uniform needs a bcet (times are "
            f"uniform in [bcet, wcet]); add bcet = ... to the task or use --exec "
            f"wcet"
        )


def run(args: argparse.Namespace) -> int:
    """Run the sub-command (InputError is reported by the caller)."""
    with FileSet("simulate", inputs=(args.file,)) as files:
        rc = _run(args, files)
        files.commit()
    return rc


def _manifest_names(names: dict[Path, list[str]]) -> dict[Path, list[str]]:
    """Where each directory's manifest goes: {manifest path: outputs it lists} (see the
    module docstring)."""
    import json

    out: dict[Path, list[str]] = {}
    for d, files in names.items():
        man = d / "manifest.json"
        own = True
        if man.exists():
            try:
                old = json.loads(man.read_text("utf-8"))
                own = (
                    isinstance(old, dict)
                    and old.get("command") == "simulate"
                    and set(old.get("outputs") or []) <= set(files)
                )
            except (OSError, ValueError):
                own = False
        if own:
            out[man] = files
        else:
            for f in files:
                out[sidecar(d / f)] = [f]
    return out


def window_taskset(args: argparse.Namespace) -> Any:
    """The task set FILE with ``--set``, ``--followers`` and ``--hough-radius`` applied (the
    last two and ``--window`` refused for a set without [window])."""
    ts = load_taskset(args.file, overrides=set_overrides(args))
    changes: dict[str, Any] = {}
    if args.followers is not None:
        changes["n"] = args.followers
    if args.hough_radius is not None:
        changes["r_H"] = args.hough_radius
    if (changes or args.window is not None) and ts.window is None:
        raise InputError(
            f"{args.file}: has no [window]; --followers, --hough-radius and "
            f"--window apply to processing-window sets only"
        )
    return ts.with_window(**changes) if changes else ts


def _taskset(args: argparse.Namespace) -> tuple[Any, float, str, Any, float | None]:
    """The task set of ``rtsim simulate`` with its options applied and checked: (task set,
    overhead, scheduler, window bounds or None, the window's estimate in ms or None)."""
    ts = window_taskset(args)
    overhead = ts.overhead if args.overhead is None else args.overhead
    if not (math.isfinite(overhead) and overhead >= 0):
        raise InputError(f"--overhead must be a non-negative number of ms, got {overhead:g}")
    if args.exec_model == "uniform":
        require_bcet(ts, str(args.file))
    scheduler = ts.scheduler
    if args.scheduler is not None:
        resolve_scheduler(args.scheduler, where="--scheduler", allow_code=True)
        scheduler = args.scheduler
    bounds = None
    if ts.window is not None:
        bounds = window_bounds(ts)

    w_est = (
        args.window if args.window is not None else (bounds.w_sch if bounds is not None else None)
    )
    return ts, overhead, scheduler, bounds, w_est


def _analysis(
    args: argparse.Namespace, ts: Any, res: Any, overhead: float, scheduler: str
) -> tuple[dict[str, float | None], dict[str, float], dict[str, float | None]]:
    """The analysis of the run's task set: (each task's least sound WCRT bound, its deadline,
    its offset-based bound)."""
    w = res.window["w"] if res.window else None
    # the analysis of the policy simulated (EDF: Spuri's bound; none for a policy of one's own:
    # the deadlines still come from the fixed-priority analysis's table)

    analyze_with = resolve_scheduler(scheduler).analysis
    known = analyze_with is not None
    if analyze_with is None:
        analyze_with = analyze
    analysis = (
        analyze_with(ts, w, overhead=overhead, suspension=args.suspension)
        if ts.window is not None
        else analyze_with(ts, overhead=overhead, suspension=args.suspension)
    )
    wcrt = {t.name: t.wcrt if known else None for t in analysis.tasks}
    deadlines = {t.name: t.deadline for t in analysis.tasks}
    # the offset-based (transaction) bound, for fixed priority at a fixed window; the
    # report's wcrt_analysis is the least of the sound bounds (docs/analysis.md)
    txn: dict[str, float | None] = {}
    if known and analyze_with is analyze and (ts.window is None or w is not None):
        # --jitter worst moves each task's arrivals by (largest jitter - its own), a
        # per-window task's no earlier than the window's (worst_jitter_shifts)
        shifts = worst_jitter_shifts(ts)[0] if args.jitter == "worst" else None

        try:  # (the report's bound, after the run: above its work limit it is left out)
            txn = transaction_bounds(
                ts,
                w,
                overhead=overhead,
                suspension=args.suspension,
                shifts=shifts,
                force=args.force,
            )
        except TooMuchWork as exc:
            note(args, f"{exc}; wcrt_transaction left out")
            txn = {}
        for name, r in txn.items():
            old = wcrt.get(name)
            if r is not None and (old is None or r < old):
                wcrt[name] = r
    return wcrt, deadlines, txn


def _write_manifests(
    args: argparse.Namespace,
    files: Any,
    outputs: dict[Path, list[str]],
    ts: Any,
    overhead: float,
    scheduler: str,
    window: Any,
) -> None:
    """The manifest of the outputs in each directory (``outputs``: their names by directory)."""
    inputs = {
        "file": str(args.file),
        "horizon": args.horizon,
        "exec": args.exec_model,
        "suspension": args.suspension,
        "overhead": overhead,
        "jitter": args.jitter,
        "scheduler": scheduler,
        "window": window,
        "taskset": taskset_to_dict(ts),
        "set": set_strings(args),
    }
    for man, names in _manifest_names(outputs).items():
        write_json(
            files.add(man, "--jobs/--trace/... manifest"),
            build_manifest(
                command="simulate",
                seed=args.seed,
                inputs=inputs,
                argv=["rtsim", *sys.argv[1:]],
                extra={"outputs": names},
            ),
        )


def _run(args: argparse.Namespace, files: Any) -> int:
    from rtsim.io.columns import ChunkWriter  # lazy: CLI start-up (pandas)

    if not (math.isfinite(args.horizon) and args.horizon > 0):
        raise InputError(f"--horizon must be a positive number of ms, got {args.horizon:g}")

    ts, overhead, scheduler, bounds, w_est = _taskset(args)
    if args.hough_radius is not None:
        check_hough_radius(args, [args.hough_radius])
    check_horizon(args, args.horizon, w_est, periods=periods_ms(ts, w_est))
    check_simulate(ts, args.horizon, w_est, f"--horizon {args.horizon:g}", force=args.force)
    rng = _gantt_range(args.gantt_range, args.horizon) if args.gantt else None
    cut = None
    if rng is not None:
        rng, cut = _bounded_range(ts, rng, w_est)
    for opt in ("jobs", "trace"):
        name = getattr(args, opt)
        if name and Path(name).suffix.lower() not in (".csv", ".parquet"):
            raise InputError(f"--{opt} {name}: output must end in .csv or .parquet")

    if args.perfetto:  # (an input or a user's file named first: that is the worse mistake)
        files.check(args.perfetto, "--perfetto")
        check_suffix(args.perfetto, "--perfetto", (".json",))

    formats = {
        opt: figure_format(args, getattr(args, opt), f"--{opt}")
        for opt in ("gantt", "histogram")
        if getattr(args, opt)
    }
    # every output reserved (a temporary file beside it) before the simulation
    tmp = {
        opt: files.add(getattr(args, opt), f"--{opt}")
        for opt in ("jobs", "trace", "perfetto", "gantt", "histogram")
        if getattr(args, opt)
    }
    # every record goes to disk as the run makes it (the --jobs / --trace files, the scratch
    # spools of --perfetto) or is kept only inside the Gantt range: memory stays flat
    jobs_out = ChunkWriter([tmp["jobs"]], jobs_frame([])) if args.jobs else None
    trace_out = ChunkWriter([tmp["trace"]], trace_frame([])) if args.trace else None
    spools: tuple[Any, Any] | None = None
    if args.perfetto:
        scratch = Path(tmp["perfetto"]).parent / f".rtsim-spool-{secrets.token_hex(4)}"
        spools = (
            Spool(f"{scratch}-jobs", label=args.perfetto),
            Spool(f"{scratch}-trace", label=args.perfetto),
        )
    chart = None
    if args.gantt:
        from rtsim.plots.gantt import GanttRows  # lazy: CLI start-up (matplotlib)

        assert rng is not None
        chart = GanttRows(*rng)
    for out in (jobs_out, trace_out, *(spools or ())):
        if out is not None:  # closed after an error too, before the staging goes
            files.on_release(getattr(out, "discard", out.close))
    job_sink = Tee(jobs_out, spools and spools[0], chart and chart.jobs)
    trace_sink = Tee(trace_out, spools and spools[1], chart and chart.trace)

    warn_short_horizon(args)  # every input checked: the run goes ahead
    if args.jitter == "worst":
        late = worst_jitter_shifts(ts)[1]
        if late:
            note(args, worst_jitter_note(late))
    with simulation_bar(args, "simulate") as bar:
        res = simulate(
            ts,
            args.horizon,
            seed=args.seed,
            exec_model=args.exec_model,
            suspension=args.suspension,
            window=args.window,
            record_jobs=bool(job_sink.sinks),
            overhead=overhead,
            jitter=args.jitter,
            scheduler=scheduler,
            job_sink=job_sink if job_sink.sinks else None,
            trace_sink=trace_sink if trace_sink.sinks else None,
            force=args.force,
            progress=bar if bar.enabled else None,
        )
    wcrt, deadlines, txn = _analysis(args, ts, res, overhead, scheduler)
    report = res.to_json()
    for entry in report["tasks"]:
        entry["wcrt_analysis"] = wcrt.get(entry["name"])
        entry["wcrt_transaction"] = txn.get(entry["name"])
    if bounds is not None:
        report["window"] = {
            **report.get("window", {}),
            **{k: v for k, v in bounds.as_dict().items() if k != "inputs"},
        }
        report["window"]["n"] = ts.window.n  # type: ignore[union-attr]
        report["window"]["r_H"] = ts.window.r_H  # type: ignore[union-attr]

    outputs: dict[Path, list[str]] = defaultdict(list)
    for opt in tmp:
        outputs[Path(getattr(args, opt)).resolve().parent].append(Path(getattr(args, opt)).name)
    for out in (jobs_out, trace_out):
        if out is not None:
            out.close()
    if spools is not None:
        from rtsim.export.perfetto import stream_perfetto  # lazy: CLI start-up (pandas)

        stream_perfetto(
            tmp["perfetto"],
            spools[0],
            spools[1],
            tasks=list(res.tasks),
            metadata={"command": "simulate", "file": str(args.file), "seed": args.seed},
        )
        for sp in spools:
            sp.close()
    if chart is not None:
        assert rng is not None
        trace, jobs = chart.frames()
        _save_gantt(
            _Tables(trace, jobs, res.tasks),
            tmp["gantt"],
            rng,
            formats["gantt"],
            args.dpi or GANTT_DPI,
            cut,
        )
    if args.histogram:
        _save_histograms(
            res,
            tmp["histogram"],
            wcrt,
            deadlines,
            report.get("window"),
            ts.window.name if ts.window is not None else None,
            formats["histogram"],
            args.dpi or HISTOGRAM_DPI,
        )
    _write_manifests(args, files, outputs, ts, overhead, scheduler, res.window)

    if args.json:
        print(dumps(report))
    elif not args.quiet:
        _print_table(report)
    return 0


def _fmt(x: Any) -> str:
    if x is None:
        return "-"
    if isinstance(x, float):
        return f"{x:.3f}"
    return str(x)


def _print_table(report: dict[str, Any]) -> None:
    win = report.get("window")
    if win:
        print(
            f"window: w = {_fmt(win.get('w'))} ms ({win.get('mode')}), "
            f"w_sch = {_fmt(win.get('w_sch'))} ms, w_rta = {_fmt(win.get('w_rta'))} ms, "
            f"w_edf = {_fmt(win.get('w_edf'))} ms, "
            f"n = {win.get('n')}, r_H = {_fmt(win.get('r_H'))} cm"
        )
    print(
        f"horizon {report['horizon']:g} ms, seed {report['seed']}, exec {report['exec_model']}, "
        f"suspension {report['suspension']}, scheduler {report['scheduler']}"
    )
    cols = (
        "name",
        "released",
        "jobs",
        "aborted",
        "skipped",
        "misses",
        "max_response",
        "mean_response",
        "wcrt_analysis",
        "max_backlog",
    )

    # names escaped as in error lines (a line break or ESC in a name cannot fake a line)
    rows = [[one_line(_fmt(t.get(c))) for c in cols] for t in report["tasks"]]
    widths = [max(len(c), *(len(r[i]) for r in rows)) for i, c in enumerate(cols)]
    print("  ".join(c.ljust(widths[i]) for i, c in enumerate(cols)))
    for r in rows:
        print(
            "  ".join(v.ljust(widths[i]) if i == 0 else v.rjust(widths[i]) for i, v in enumerate(r))
        )


class _Tables(NamedTuple):
    """What the Gantt chart reads of a run: its trace, its jobs, its tasks."""

    trace: Any
    jobs: Any
    tasks: Any


def gantt_figure(res: Any, rng: tuple[float, float], cut: float | None = None) -> Any:
    """The ``--gantt`` figure of a run (its trace and jobs) over ``rng`` (ms); ``cut``: the
    end of the range asked for, when it was cut to GANTT_MAX_JOBS (the title says so)."""
    from rtsim.plots.gantt import GANTT_MAX_JOBS, gantt  # lazy: CLI start-up (matplotlib)

    title = f"schedule {rng[0]:g}..{rng[1]:g} ms"
    if cut is not None:
        title += f" (of ..{cut:g} ms: at most {GANTT_MAX_JOBS:,} jobs are drawn)"
    return gantt(
        res.trace, jobs=res.jobs, start=rng[0], end=rng[1], tasks=list(res.tasks), title=title
    )


def _save_gantt(
    res: Any, path: str, rng: tuple[float, float], fmt: str, dpi: int, cut: float | None = None
) -> None:
    from rtsim.plots.scenario import save_figure  # lazy: CLI start-up (matplotlib)

    save_figure(gantt_figure(res, rng, cut), path, dpi=dpi, fmt=fmt)


def _save_histograms(
    res: Any,
    path: str,
    wcrt: dict[str, Any],
    deadlines: dict[str, Any],
    window: dict[str, Any] | None,
    window_name: str | None,
    fmt: str,
    dpi: int,
) -> None:
    from rtsim.plots.scenario import save_figure  # lazy: CLI start-up (matplotlib)

    save_figure(histogram_figure(res, wcrt, deadlines, window, window_name), path, dpi=dpi, fmt=fmt)


def histogram_figure(
    res: Any,
    wcrt: dict[str, Any],
    deadlines: dict[str, Any],
    window: dict[str, Any] | None,
    window_name: str | None,
) -> Any:
    """The ``--histogram`` figure: one panel per task of the run, its analytic WCRT and
    deadline drawn in (and w_sch, w_rta on the window's)."""
    from matplotlib.figure import Figure

    from rtsim.plots.histogram import response_histogram  # lazy: CLI start-up (matplotlib)

    names = list(res.tasks)
    fig = Figure(figsize=(7, 3 * len(names)), layout="constrained")
    axes = fig.subplots(len(names), 1, squeeze=False)
    for ax, name in zip(axes[:, 0], names, strict=True):
        stats = res.tasks[name]
        lines: dict[str, float | None] = {
            "WCRT (analysis)": wcrt.get(name),
            "deadline": deadlines.get(name),
        }
        if window and name == window_name:
            lines.update({"w_sch": window.get("w_sch"), "w_rta": window.get("w_rta")})
        if stats.histogram is None:
            ax.set_title(f"{name}: no completed job")
            continue
        response_histogram(stats.histogram, lines=lines, ax=ax, title=name)
    return fig
