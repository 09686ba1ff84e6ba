"""The paper's experiments reproduced: Test 1 and Test 2 in the paper's three window modes and
``plan`` beside them (``rtsim reproduce``, or [`run`][rtsim.reproduce.run] with
[`ReproduceOptions`][rtsim.reproduce.ReproduceOptions] from Python). What it runs, for how
long, and what it writes: docs/results.md.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from rtsim.config.dotted import parse_assignment
from rtsim.errors import InputError
from rtsim.io.atomic import dumps, write_json, write_table, write_text
from rtsim.io.manifest import write_manifest
from rtsim.io.outdir import stage
from rtsim.io.summary import summary_json
from rtsim.sim.progress import progress_bar

if TYPE_CHECKING:
    from concurrent.futures import ProcessPoolExecutor

    import pandas as pd

SCENARIOS = Path(__file__).resolve().parent / "data" / "scenarios"  # = experiments/scenarios
TESTS: tuple[str, ...] = ("test1", "test2")
#: The paper's three window modes (``adjust`` on the paper's predictor, §3.3), then rtsim's
#: improvement ``plan`` (the shipped scenarios' policy) beside them.
PAPER_MODES: tuple[str, ...] = ("adjust", "fixed-wsch", "min-msb")
MODES: tuple[str, ...] = (*PAPER_MODES, "plan")
TEST_LABELS = {"test1": "Test 1", "test2": "Test 2"}
QUICK_DURATION_S = 60.0
DEFAULT_OUT = "results/paper"
DOCS_DPI = 100
BOUND_KINDS: tuple[str, ...] = ("localization", "separation", "path_diversion", "bearing")

#: The paper's figures drawn from the adjust runs: number → (test, figure name).
PAPER_FIGURES: dict[int, tuple[str, str]] = {
    8: ("test1", "paths"),
    9: ("test1", "window_slack"),
    10: ("test1", "msb"),
    11: ("test1", "speed"),
    12: ("test2", "paths"),
    13: ("test2", "window_slack"),
    14: ("test2", "msb"),
    15: ("test2", "speed"),
}
#: The per-follower, per-kind detail beside Figs 10/14: number → (test, figure name).
DETAIL_FIGURES: dict[int, tuple[str, str]] = {10: ("test1", "bounds"), 14: ("test2", "bounds")}
#: Side-by-side mode figures: kind of
#: [`rtsim.plots.scenario.plot_modes`][rtsim.plots.scenario.plot_modes] → figure_data name.
MODE_FIGURES: dict[str, str] = {
    "window": "window_slack",
    "bounds": "bounds",
    "speed": "speed",
    "paths": "paths",
}
_TITLES = {
    "paths": "robots' paths",
    "window_slack": "processing window and slack time",
    "bounds": "effective processing-window bounds per kind (min over followers)",
    "msb": "min MSB at $V_{Ld}$ (predicted, true) against $w_{sch}$",
    "speed": "desired and actual leader speed",
    "operating_space": "operating space ($w_{sch}$ ≤ w ≤ min MSB)",
}
#: Figures also written with --docs (stems).
DOCS_FIGURES: tuple[str, ...] = (
    *(f"fig{n:02d}_{t}_{name}" for n, (t, name) in PAPER_FIGURES.items()),
    *(f"fig{n:02d}_{t}_{name}_detail" for n, (t, name) in DETAIL_FIGURES.items()),
    "fig02_test1_operating_space",
    "fig02_test2_operating_space",
    "modes_test2_window",
)

SUMMARY_COLUMNS: tuple[str, ...] = (
    "test",
    "mode",
    "viol5",
    "max_viol_ratio",
    "missed",
    "tracks_lost",
    "lap_time_s",
    "lap_oracle_s",
    "lap_over_oracle",
    "collisions",
    "min_robot_distance_cm",
    "separation_binds",
    "critical_windows",
    *(f"viol5_{k}" for k in BOUND_KINDS),
    *(f"max_viol_ratio_{k}" for k in BOUND_KINDS),
    "seed",
    "duration_s",
    "laps",
    "w_sch",
    "windows",
    *(f"viol_{k}" for k in BOUND_KINDS),
    "critical_share",
    "min_msb_over_wsch",
    "min_speed_ratio",
    "methods",
    "predictor",
    "formation_model",
    "max_response",
    "wall_s",
)


def figure_stems() -> list[str]:
    """Every figure stem the script writes in ``figures/`` (each as .png — or the ``--format``
    — and .csv)."""
    stems = [f"fig{n:02d}_{t}_{name}" for n, (t, name) in PAPER_FIGURES.items()]
    stems += [f"fig{n:02d}_{t}_{name}_detail" for n, (t, name) in DETAIL_FIGURES.items()]
    stems += [f"fig02_{t}_operating_space" for t in TESTS]
    stems += [f"modes_{t}_{kind}" for t in TESTS for kind in MODE_FIGURES]
    return stems


# --- one run ------------------------------------------------------------------------------


def write_run(
    out: Path,
    res: Any,
    *,
    scenario_file: Path,
    mode: str,
    seed: int,
    duration_s: float | None,
    argv: list[str],
    wall_s: float,
    set_: Iterable[str] | None = None,
) -> list[str]:
    """Write a run's directory as ``rtsim scenario --no-figures`` does (rtsim/cli/scenario.py).

    The CLI has no writer function of its own, so this calls the same library functions with
    the same manifest keys. Returns the names written.
    """
    out.mkdir(parents=True, exist_ok=True)
    outputs = ["windows.csv", "jobs.csv", "summary.json"]
    write_table(out / "windows.csv", res.windows)
    if res.jobs is not None:
        write_table(out / "jobs.csv", res.jobs)
    else:
        outputs.remove("jobs.csv")

    write_json(out / "summary.json", summary_json(res.summary))
    timing = dict(res.timing)
    timing["total_s"] = wall_s
    inp = res.inputs
    write_manifest(
        out,
        command="scenario",
        seed=seed,
        inputs={
            "scenario_file": str(scenario_file),
            "scenario_text": inp.text,
            "scenario": inp.resolved,
            "mode": mode,
            "duration_s": duration_s,
            "exec_model": "wcet",
            "set": list(set_ or []),
        },
        argv=argv,
        extra={"timing": timing, "outputs": [*outputs, "manifest.json"]},
    )
    return [*outputs, "manifest.json"]


def run_one(spec: dict[str, Any]) -> dict[str, Any]:
    """Run one (test, mode) and write ``spec['out']``; returns windows, summary and timing."""
    from rtsim.coupling import run_scenario  # lazy: CLI start-up (pandas)

    t0 = time.perf_counter()
    file = Path(spec["scenario_file"])
    set_ = list(spec.get("set") or [])
    res = run_scenario(
        file,
        policy=spec["mode"],
        duration_s=spec["duration_s"],
        seed=spec["seed"],
        record_jobs=True,
        overrides=_overrides(set_) or None,
    )
    flag = "--mode" if spec["mode"] in PAPER_MODES else "--policy"
    argv = ["rtsim", "scenario", str(file), flag, spec["mode"], "--seed", str(spec["seed"])]
    argv += [a for s in set_ for a in ("--set", s)]
    if spec["duration_s"] is not None:
        argv += ["--duration", repr(spec["duration_s"])]
    argv += ["--no-figures", "--out", str(spec.get("shown_out", spec["out"]))]
    written = write_run(
        Path(spec["out"]),
        res,
        scenario_file=file,
        mode=spec["mode"],
        seed=spec["seed"],
        duration_s=spec["duration_s"],
        argv=argv,
        wall_s=time.perf_counter() - t0,
        set_=set_,
    )
    timing = dict(res.timing)
    timing["total_s"] = time.perf_counter() - t0
    return {
        "test": spec["test"],
        "mode": spec["mode"],
        "duration_s": spec["duration_s"],
        "windows": res.windows,
        "summary": res.summary,
        "timing": timing,
        "written": written,
    }


def run_specs(
    out: Path,
    *,
    seed: int,
    duration_s: float | None,
    scenarios: Path = SCENARIOS,
    set_: Iterable[str] | None = None,
) -> list[dict[str, Any]]:
    """The eight runs: every test in every mode, each with its output directory.

    With ``duration_s`` None the adjust runs take the scenario's default (at least one lap)
    and the baselines are marked ``match_adjust``: `run_all` runs them as long as the
    adjust run of their test, so the three modes cover the same simulated time.
    """
    return [
        {
            "test": t,
            "mode": m,
            "seed": seed,
            "duration_s": duration_s,
            "match_adjust": duration_s is None and m != "adjust",
            "scenario_file": str(scenarios / f"{t}.toml"),
            "out": str(out / t / m),
            "set": list(set_ or []),
        }
        for t in TESTS
        for m in MODES
    ]


# --- figures ------------------------------------------------------------------------------


def modes_data(dfs: dict[str, pd.DataFrame], name: str) -> pd.DataFrame:
    """The data of a side-by-side figure: each mode's figure_data, stacked, ``mode`` first."""
    from rtsim.plots.scenario import figure_data  # lazy: CLI start-up (matplotlib)

    parts = []
    for mode, df in dfs.items():
        part = figure_data(df, name)
        part.insert(0, "mode", mode)
        parts.append(part)
    import pandas as pd

    return pd.concat(parts, ignore_index=True)


def figure_tasks(
    runs: dict[tuple[str, str], pd.DataFrame],
    fig_dir: Path,
    docs: Path | None,
    fmt: str = "png",
    dpi: int | None = None,
) -> list[dict[str, Any]]:
    """One task per figure: what to draw, from which run(s), and where to write it (in
    format ``fmt`` at ``dpi``; the docs' copies are always PNG at `DOCS_DPI`)."""
    tasks: list[dict[str, Any]] = []

    def add(stem: str, kind: str, data: Any, title: str, name: str) -> None:
        tasks.append(
            {
                "stem": stem,
                "kind": kind,
                "data": data,
                "title": title,
                "name": name,
                "dir": str(fig_dir),
                "fmt": fmt,
                "dpi": dpi,
                "docs": str(docs) if docs is not None and stem in DOCS_FIGURES else None,
            }
        )

    for n, (test, name) in PAPER_FIGURES.items():
        add(
            f"fig{n:02d}_{test}_{name}",
            name,
            runs[(test, "adjust")],
            f"Fig {n}. {TEST_LABELS[test]} (adjust): {_TITLES[name]}",
            name,
        )
    for n, (test, name) in DETAIL_FIGURES.items():
        add(
            f"fig{n:02d}_{test}_{name}_detail",
            name,
            runs[(test, "adjust")],
            f"Fig {n}, detail. {TEST_LABELS[test]} (adjust): {_TITLES[name]}",
            name,
        )
    for test in TESTS:
        add(
            f"fig02_{test}_operating_space",
            "operating_space",
            runs[(test, "adjust")],
            f"Fig 2. {TEST_LABELS[test]} (adjust): {_TITLES['operating_space']}",
            "operating_space",
        )
    for test in TESTS:
        dfs = {m: runs[(test, m)] for m in PAPER_MODES}  # plan: in the table
        for kind, name in MODE_FIGURES.items():
            add(
                f"modes_{test}_{kind}",
                f"modes:{kind}",
                dfs,
                f"{TEST_LABELS[test]}: {_TITLES[name]}, three modes",
                name,
            )
    return tasks


def make_figure(task: dict[str, Any]) -> tuple[Any, pd.DataFrame]:
    """The figure of one figure task (`figure_tasks`) and the data it draws."""
    from rtsim.plots.scenario import (  # lazy: CLI start-up (matplotlib)
        SCENARIO_FIGURES,
        figure_data,
        plot_modes,
    )

    kind, name, data = task["kind"], task["name"], task["data"]
    if kind.startswith("modes:"):
        return plot_modes(data, kind.split(":", 1)[1], title=task["title"]), modes_data(data, name)
    return SCENARIO_FIGURES[kind](data, title=task["title"]), figure_data(data, name)


def draw(task: dict[str, Any]) -> list[str]:
    """Draw one figure task; write the figure and CSV (and the docs PNG). Returns the
    paths."""
    from rtsim.plots.scenario import save_figure  # lazy: CLI start-up (matplotlib)

    fig, table = make_figure(task)
    out = Path(task["dir"])
    fmt = task.get("fmt", "png")
    path, csv = out / f"{task['stem']}.{fmt}", out / f"{task['stem']}.csv"
    from rtsim.plots.scenario import DPI  # lazy: CLI start-up (matplotlib)

    save_figure(fig, path, dpi=task.get("dpi") or DPI)
    write_table(csv, table)
    written = [str(path), str(csv)]
    if task["docs"]:
        written.append(
            str(save_figure(fig, Path(task["docs"]) / f"{task['stem']}.png", dpi=DOCS_DPI))
        )
    return written


# --- summary ------------------------------------------------------------------------------


def _or_nan(x: Any) -> float:
    return math.nan if x is None else float(x)


def summary_row(test: str, mode: str, summary: dict[str, Any], wall_s: float) -> dict[str, Any]:
    """One row of summary.csv from a run's summary.json."""
    row: dict[str, Any] = {
        "test": test,
        "mode": mode,
        "seed": summary["seed"],
        "duration_s": summary["duration_s"],
        "laps": summary.get("laps", math.nan),
        "w_sch": summary["w_sch"],
        "windows": summary["windows"],
        "missed": summary["missed"],
        "tracks_lost": summary["tracks_lost"],
        "lap_time_s": _or_nan(summary.get("lap_time_s")),
        "lap_oracle_s": _or_nan(summary.get("lap_oracle_s")),
        "lap_over_oracle": _or_nan(summary.get("lap_over_oracle")),
        "collisions": summary.get("collisions", -1),
        "min_robot_distance_cm": _or_nan(summary.get("min_robot_distance_cm")),
        "separation_binds": summary["binding_critical"].get("separation", 0),
        "critical_windows": summary["critical_windows"],
    }
    for k in BOUND_KINDS:
        row[f"viol_{k}"] = summary["violations"][k]
    row.update(
        critical_share=summary["critical_share"],
        min_msb_over_wsch=summary["min_msb_over_wsch"],
        min_speed_ratio=summary["min_speed_ratio"],
        methods=";".join(f"{k}={v}" for k, v in sorted(summary["methods"].items())),
    )
    ratios = summary.get("max_violation_ratio", {})
    beyond = summary.get("violations_beyond_5pct", {})
    for k in BOUND_KINDS:
        row[f"max_viol_ratio_{k}"] = ratios.get(k, math.nan)
    for k in BOUND_KINDS:
        row[f"viol5_{k}"] = beyond.get(k, -1)
    row["viol5"] = sum(beyond.get(k, 0) for k in BOUND_KINDS)
    row["max_viol_ratio"] = max((ratios.get(k, math.nan) for k in BOUND_KINDS), default=math.nan)
    row["predictor"] = summary.get("predictor", "")
    row["formation_model"] = summary.get("formation_model", "")
    row["max_response"] = summary.get("max_response", math.nan)
    row["wall_s"] = wall_s
    return row


def summary_markdown(df: pd.DataFrame) -> str:
    """The summary as a Markdown table (as in docs/results.md)."""
    head = (
        "| test | mode | violations > 5 % loc / sep / path / bear | max violation ratio "
        "loc / sep / path / bear | misses | lost tracks | sim. s | windows | all violations "
        "| critical share | min MSB / w_sch | min V_L / V_Ld | methods | lap s | lap / oracle "
        "| separation binds / critical | collisions |"
    )
    lines = [head, "|" + "---|" * 17]
    r: Any  # a row (its fields typed by the columns, not by pandas)
    for r in df.itertuples(index=False):
        lines.append(
            f"| {TEST_LABELS.get(r.test, r.test)} | {r.mode} | {r.viol5_localization} / "
            f"{r.viol5_separation} / {r.viol5_path_diversion} / {r.viol5_bearing} | "
            f"{r.max_viol_ratio_localization:.2f} / {r.max_viol_ratio_separation:.2f} / "
            f"{r.max_viol_ratio_path_diversion:.2f} / {r.max_viol_ratio_bearing:.2f} | "
            f"{r.missed} | {r.tracks_lost} | {r.duration_s:.1f} | {r.windows} | "
            f"{r.viol_localization + r.viol_separation + r.viol_path_diversion + r.viol_bearing}"
            f" | {r.critical_share:.3f} | {r.min_msb_over_wsch:.3f} | {r.min_speed_ratio:.3f} | "
            f"{r.methods.replace(';', ', ')} | {r.lap_time_s:.1f} | {r.lap_over_oracle:.3f} | "
            f"{r.separation_binds} / {r.critical_windows} | {r.collisions} |"
        )
    notes = (
        "\nViolations > 5 % count (window, follower) pairs whose truth, between this window's "
        "scan and the next, broke a bound's threshold (r_H, T_ρ·ρ_d, T_ε·ρ_d, T_β) by more "
        "than 5 % (all violations: by any amount); the max "
        "violation ratio is the largest observed change over its threshold (>1: broken). "
        "Critical share: the share of simulated time with min MSB (at V_Ld) < w_sch. "
        "Methods: how each window's w and V_L were set (none: no overload; coupled / "
        "closed-form / numeric: speed lowered; fixed: the first window, or a baseline mode). "
        "adjust is the paper's algorithm on the paper's predictor (its §3.3); plan is rtsim's "
        "improvement (the rollout on the followers' commands), shown beside it. Lap / oracle: "
        "the first lap over the fastest lap that keeps every bound (rtsim.control.oracle; nan "
        "when the run ends before the lap).\n"
    )
    return "\n".join(lines) + "\n" + notes


# --- driver -------------------------------------------------------------------------------


def _pool_map(
    pool: ProcessPoolExecutor | None, fn: Callable[[Any], Any], items: Iterable[Any]
) -> Iterator[tuple[Any, Any]]:
    """(item, fn(item)) in completion order; in this process when ``pool`` is None."""
    items = list(items)
    if pool is None:
        for it in items:
            yield it, fn(it)
        return
    from concurrent.futures import as_completed  # (multiprocessing: ~30 ms of CLI start-up)

    futures = {pool.submit(fn, it): it for it in items}
    for fut in as_completed(futures):
        yield futures[fut], fut.result()


def run_all(
    specs: list[dict[str, Any]],
    pool: ProcessPoolExecutor | None = None,
    progress: Callable[[str], None] | None = None,
) -> dict[tuple[str, str], dict]:
    """Run ``specs`` (see `run_specs`); results keyed by (test, mode).

    Specs marked ``match_adjust`` run after the others, with the duration their test's adjust
    run reached (``summary['duration_s']``).
    """
    results: dict[tuple[str, str], dict[str, Any]] = {}
    first = [sp for sp in specs if not sp.get("match_adjust")]
    later = [sp for sp in specs if sp.get("match_adjust")]
    done = 0
    for phase in (first, later):
        if phase is later:
            phase = [
                {**sp, "duration_s": results[(sp["test"], "adjust")]["summary"]["duration_s"]}
                for sp in later
            ]
        for _, res in _pool_map(pool, run_one, phase):
            done += 1
            results[(res["test"], res["mode"])] = res
            if progress is not None:
                s = res["summary"]
                progress(
                    f"[{done}/{len(specs)}] {res['test']} {res['mode']}: "
                    f"{s['duration_s']:.1f} s simulated, {s['windows']} windows, "
                    f"violations > 5 % {sum(s['violations_beyond_5pct'].values())} "
                    f"(max ratio {max(s['max_violation_ratio'].values()):.2f}), "
                    f"missed {s['missed']}, tracks lost {s['tracks_lost']}, min V_L/V_Ld "
                    f"{s['min_speed_ratio']:.2f} ({res['timing']['total_s']:.1f} s)"
                )
    return results


def _check_args(args: ReproduceOptions) -> None:
    if args.seed < 0:
        raise InputError(f"--seed must be a non-negative integer, got {args.seed}")
    if args.duration is not None and not (0 < args.duration < math.inf):
        raise InputError(f"--duration must be a positive number of seconds, got {args.duration!r}")
    if args.workers is not None and args.workers < 1:
        raise InputError(f"--workers must be at least 1, got {args.workers}")
    for opt, path in (("--out", args.out), ("--docs", args.docs)):
        if path is not None and Path(path).exists() and not Path(path).is_dir():
            raise InputError(f"{opt} {path}: exists and is not a directory")
    if args.docs is not None:
        out, docs = Path(args.out).resolve(), Path(args.docs).resolve()
        if docs == out or out in docs.parents:
            raise InputError(
                f"--docs {args.docs}: is inside --out {args.out}, which is "
                f"replaced whole at the end; give a directory outside it"
            )
    for t in TESTS:
        if not (SCENARIOS / f"{t}.toml").is_file():
            raise InputError(f"{SCENARIOS / f'{t}.toml'}: scenario file not found")
    if args.set:  # checked before any run, by the scenario model
        from rtsim.config.scenario import load_scenario  # lazy: CLI start-up (numpy)

        for t in TESTS:
            load_scenario(SCENARIOS / f"{t}.toml", overrides=_overrides(args.set))


def _overrides(strings: Iterable[str]) -> dict[str, Any]:
    """``--set KEY=VALUE`` strings as dotted path -> value."""
    return dict(parse_assignment(s) for s in strings)


@dataclass(frozen=True)
class ReproduceOptions:
    """What [`run`][rtsim.reproduce.run] reproduces: the options of ``rtsim reproduce``
    (module docstring), typed. ``duration`` in simulated s (None: each scenario's, at least one
    lap; ``quick``: 60 s); ``workers`` None: min(6, cpu count); ``docs``: also write the
    documentation's figures there; ``fig_format`` png (default), svg or pdf; ``force``: run a
    duration over six simulated hours; ``set``: ``KEY=VALUE`` changes to both scenarios."""

    out: str | Path = DEFAULT_OUT
    quick: bool = False
    seed: int = 0
    duration: float | None = None
    workers: int | None = None
    docs: str | Path | None = None
    quiet: bool = False
    fig_format: str | None = None
    dpi: int | None = None
    json: bool = False
    force: bool = False
    set: tuple[str, ...] = field(default=())


def run(
    args: ReproduceOptions,
    *,
    finish: Callable[[Path], None] | None = None,
    argv: list[str] | None = None,
    t0: float | None = None,
) -> int:
    """Run the eight scenarios, draw the figures, write the tables (module docstring), for the
    options ``args``; returns the exit status (2 with one line on stderr for bad options).

    ``--out`` is written whole (`rtsim.io.outdir`): into a staging directory beside it,
    checked before the runs start, swapped in at the end. ``finish`` (the CLI's report
    writer) is called with the staging directory just before the swap; what it writes,
    ``report.html`` at the top and in each run directory, is listed in the manifest.
    ``argv``: the command line the manifest records (default: this process's).
    """
    t0 = time.perf_counter() if t0 is None else t0
    try:
        _check_args(args)

        with stage(args.out, command="reproduce") as staged:
            rc = _main(args, argv, t0, staged.path, finish)
            if rc == 0:
                staged.commit()
        return rc
    except InputError as exc:
        print(f"rtsim: {exc}", file=sys.stderr)
        return 2


def _write_summary(
    out: Path,
    args: ReproduceOptions,
    results: dict[tuple[str, str], Any],
    *,
    duration: float | None,
    workers: int,
    docs: Path | None,
    fmt: str,
    finished: bool,
    argv: list[str] | None,
    times: tuple[float, float, float],
) -> tuple[Any, str]:
    """summary.csv, summary.md and the manifest of a reproduction; (the summary table, its
    Markdown). ``times``: the start, the end of the runs and the end of the figures
    (``time.perf_counter``); ``finished``: the reports are written after."""
    t0, t_runs, t_figs = times
    rows = [
        summary_row(t, m, results[(t, m)]["summary"], results[(t, m)]["timing"]["total_s"])
        for t in TESTS
        for m in MODES
    ]
    import pandas as pd

    table = pd.DataFrame(rows, columns=list(SUMMARY_COLUMNS))
    write_table(out / "summary.csv", table)
    md = summary_markdown(table)
    write_text(out / "summary.md", md)
    runs_meta = [
        {
            "test": t,
            "mode": m,
            "seed": args.seed,
            "duration_s": results[(t, m)]["duration_s"],
            "out": str(Path(t) / m),
            "timing": results[(t, m)]["timing"],
        }
        for t in TESTS
        for m in MODES
    ]
    write_manifest(
        out,
        command="rtsim reproduce",
        seed=args.seed,
        inputs={
            "quick": args.quick,
            "duration_s": duration,
            "workers": workers,
            "tests": list(TESTS),
            "modes": list(MODES),
            "scenarios": {
                t: {
                    "file": str(SCENARIOS / f"{t}.toml"),
                    "text": (SCENARIOS / f"{t}.toml").read_text("utf-8"),
                }
                for t in TESTS
            },
            "docs": str(docs) if docs is not None else None,
            "set": list(args.set),
        },
        argv=[sys.argv[0], *(argv if argv is not None else sys.argv[1:])],
        extra={
            "runs": runs_meta,
            "timing": {
                "runs_s": t_runs - t0,
                "figures_s": t_figs - t_runs,
                "total_s": time.perf_counter() - t0,
            },
            "outputs": [
                "summary.csv",
                "summary.md",
                "manifest.json",
                *(f"figures/{s}.{e}" for s in figure_stems() for e in (fmt, "csv")),
                *(f"{t}/{m}/{f}" for t in TESTS for m in MODES for f in results[(t, m)]["written"]),
                *(
                    ["report.html", *(f"{t}/{m}/report.html" for t in TESTS for m in MODES)]
                    if finished
                    else []
                ),
            ],
        },
    )
    return table, md


def _main(
    args: ReproduceOptions,
    argv: list[str] | None,
    t0: float,
    out: Path,
    finish: Callable[[Path], None] | None = None,
) -> int:
    docs = Path(args.docs) if args.docs is not None else None
    duration = (
        args.duration if args.duration is not None else (QUICK_DURATION_S if args.quick else None)
    )
    workers = args.workers if args.workers is not None else min(6, os.cpu_count() or 1)
    specs = run_specs(out, seed=args.seed, duration_s=duration, set_=args.set)
    for sp in specs:  # the command lines in the run manifests name the real --out
        sp["shown_out"] = str(Path(args.out) / sp["test"] / sp["mode"])

    fmt = args.fig_format or "png"
    tasks_total = len(specs) + len(figure_stems())
    bar = progress_bar(args, total=tasks_total, desc="reproduce", unit="step")

    def say(line: str) -> None:  # a progress line (above the bar when there is one)
        if args.quiet:
            return
        if bar.disable:
            print(line, file=sys.stderr, flush=True)
        else:
            bar.write(line, file=sys.stderr)

    def run_done(line: str) -> None:
        bar.update(1)
        say(line)

    from rtsim.sweep.point import worker_init  # lazy: CLI start-up (rtsim.sweep, ~27 ms)

    # workers ignore Ctrl-C (the parent stops them) and exit when the parent dies, even by
    # kill -9, releasing the staging directory's lock that a fork inherits
    if workers > 1:  # the kernels compiled (or loaded) here once, not once per worker
        from rtsim.config.scenario import load_scenario  # lazy: CLI start-up (numpy)
        from rtsim.coupling.warm import warm_world  # lazy: CLI start-up (pandas)

        files = dict.fromkeys(sp["scenario_file"] for sp in specs)
        warm_world(load_scenario(f, _overrides(args.set or []) or None) for f in files)
    from concurrent.futures import ProcessPoolExecutor  # (as in _pool_map)

    pool = (
        ProcessPoolExecutor(workers, initializer=worker_init, initargs=(os.getpid(),))
        if workers > 1
        else None
    )
    try:
        results = run_all(specs, pool, run_done)
        t_runs = time.perf_counter()
        windows = {key: res["windows"] for key, res in results.items()}
        fig_dir = out / "figures"
        fig_dir.mkdir(parents=True, exist_ok=True)
        if docs is not None:
            docs.mkdir(parents=True, exist_ok=True)
        written: list[str] = []
        for _, paths in _pool_map(pool, draw, figure_tasks(windows, fig_dir, docs, fmt, args.dpi)):
            written += paths
            bar.update(1)
        say(
            f"figures: {len(written)} files in {Path(args.out) / 'figures'} "
            f"({time.perf_counter() - t_runs:.1f} s)"
        )
    finally:
        bar.close()
        if pool is not None:
            pool.shutdown()
    t_figs = time.perf_counter()

    table, md = _write_summary(
        out,
        args,
        results,
        duration=duration,
        workers=workers,
        docs=docs,
        fmt=fmt,
        finished=finish is not None,
        argv=argv,
        times=(t0, t_runs, t_figs),
    )
    if finish is not None:
        finish(out)
    if args.json:
        finite = table.replace([math.inf, -math.inf], math.nan).astype(object)
        records = finite.where(finite.notna(), None).to_dict("records")  # NaN, inf: null
        print(dumps({"out": str(args.out), "runs": records}))
    elif not args.quiet:
        print(md, end="")
    if not args.quiet:
        print(f"-> {args.out} ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    return 0
