"""``rtsim validate``: the analytic-versus-simulated validation, end to end.

Two sweeps run through the sweep engine (kind ``call``, so they run on local processes or a
Dask cluster and resume when run again): the paper's set over the (n, r_H) grid
(`rtsim.validate.points.paper_point`) and random UUniFast sets
(`rtsim.validate.points.random_point`). Their rows become one validation table
(`rtsim.validate.tidy`), which is checked (`rtsim.analysis.validation.check_results`),
summarised, drawn and written up.

Output directory ``OUT``::

    report.md            summary numbers, failures, figures, tables
    validation.csv       the validation table (also results.parquet)
    failures.csv         every flagged row (empty table when none)
    summary.json         the headline numbers
    figures/             bounds_vs_n.png/.csv, pessimism_wsch.png/.csv, pessimism_wrta.png/.csv,
                         scheduler_bounds.png/.csv (the paper set's w_sch, w_rta, w_edf for
                         n = 1..10, r_H = 10..50: `scheduler_table`)
    histograms/<config>/ per-task response-time histograms with the bounds (PNG + CSV)
    sweeps/<name>/       the two sweeps (results.parquet, per-point files, manifests)
    manifest.json

Exit status (CLI): 1 when a failure is flagged or a sweep point failed, else 0.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import pandas as pd

from rtsim.analysis.bounds import w_edf, w_rta, w_sch_of
from rtsim.analysis.validation import check_results, summarize, task_bounds
from rtsim.config.dotted import shortcuts
from rtsim.config.load import parse_toml
from rtsim.config.scenario import load_scenario, scenario_bytes
from rtsim.config.taskset import load_taskset, taskset_bytes
from rtsim.errors import OverrideError, TaskSetError
from rtsim.io.atomic import write_json, write_table
from rtsim.io.lock import lock_directory
from rtsim.io.manifest import write_manifest
from rtsim.io.outdir import check_resumable
from rtsim.report import REPORT_NAME, write_run_report
from rtsim.sweep.engine import Sweep
from rtsim.sweep.spec import parse_sweep
from rtsim.validate import tidy
from rtsim.validate.histogram import JobSource, write_histograms
from rtsim.validate.outcome import (
    DEFAULT_SCENARIO,
    FULL,
    QUICK,
    ValidationConfig,
    ValidationOutcome,
)
from rtsim.validate.points import FP_MODES as PAPER_MODES
from rtsim.validate.points import beam_counts_for, paper_taskset, simulate_mode
from rtsim.validate.report import write_report

#: Resolution (dots per inch) of the PNG figures.
DPI = 300  # rtsim.plots.style.DPI: print resolution

__all__ = [
    "ValidationConfig",
    "QUICK",
    "FULL",
    "DEFAULT_SCENARIO",
    "ValidationOutcome",
    "run_validation",
    "paper_sweep_spec",
    "random_sweep_spec",
    "scheduler_table",
]


#: Keys each grid point sets itself (``--followers``, ``--hough-radius`` change them).
_GRID_KEYS = {
    "n": "--followers",
    "window.n": "--followers",
    "formation.followers": "--followers",
    "r_H": "--hough-radius",
    "window.r_H": "--hough-radius",
    "sensing.r_H": "--hough-radius",
}


def _scenario_path(cfg: ValidationConfig) -> str:
    if cfg.scenario_path is not None:
        return cfg.scenario_path
    return str(DEFAULT_SCENARIO) if DEFAULT_SCENARIO.exists() else "test1"  # packaged copy


def split_overrides(cfg: ValidationConfig) -> tuple[dict[str, Any], dict[str, Any]]:
    """``cfg.overrides`` as (the task set's, the scenario's): a key goes to the task set when
    its first part is a table or shortcut of the task set (``tasks.command.wcet``,
    ``delta_t``), else to the scenario (``leader.speed``); a key the grid sets is refused."""
    ts_out: dict[str, Any] = {}
    sc_out: dict[str, Any] = {}
    if not cfg.overrides:
        return ts_out, sc_out
    raw, source = taskset_bytes(cfg.taskset_path)
    ts_data = parse_toml(raw, source, OverrideError)
    ts_keys = {str(k) for k in ts_data} | set(shortcuts(ts_data))
    for name, value in cfg.overrides:
        if name in _GRID_KEYS:
            raise OverrideError(
                f"--set {name}: set by the validation grid at every point; "
                f"use {_GRID_KEYS[name]} instead"
            )
        (ts_out if name.split(".")[0] in ts_keys else sc_out)[name] = value
    return ts_out, sc_out


def _scenario_options(cfg: ValidationConfig) -> dict[str, Any]:
    path = _scenario_path(cfg)
    overrides = split_overrides(cfg)[1]
    load_scenario(path, overrides)  # checked here: a bad file or key is an input error (exit 2)
    raw, p = scenario_bytes(path)
    opts = {"scenario_text": raw.decode("utf-8"), "scenario_source": str(p)}
    return {**opts, "scenario_set": overrides} if overrides else opts


def _taskset_options(cfg: ValidationConfig) -> dict[str, Any]:
    opts = _scenario_options(cfg)
    overrides = split_overrides(cfg)[0]
    if cfg.taskset_path is None and not overrides:
        return opts

    # checked here: a bad file or key is an input error (exit 2)
    ts = load_taskset(cfg.taskset_path, overrides)
    raw, source = taskset_bytes(cfg.taskset_path)
    if ts.window is None:
        raise TaskSetError(f"{source}: has no [window]; validate needs a processing-window set")
    opts = {**opts, "taskset_text": raw.decode("utf-8"), "taskset_source": source}
    return {**opts, "taskset_set": overrides} if overrides else opts


def paper_sweep_spec(cfg: ValidationConfig, source: str = "rtsim validate: paper") -> Any:
    """The sweep spec of the paper grid (kind ``call``)."""
    options = {"windows": cfg.windows, "scan": cfg.scan, "tol": cfg.tol, **_taskset_options(cfg)}
    data = {
        "sweep": {
            "kind": "call",
            "function": "rtsim.validate.points:paper_point",
            "seed": cfg.seed,
            "options": options,
            "name": f"validate-{cfg.name}",
        },
        "grid": {"n": [int(k) for k in cfg.n], "r_H": [float(r) for r in cfg.r_H]},
    }
    return parse_sweep(data, source, allow_code=True)  # rtsim's own function, not a file's


def random_sweep_spec(cfg: ValidationConfig, source: str = "rtsim validate: random") -> Any:
    """The sweep spec of the random sets (kind ``call``)."""
    data = {
        "sweep": {
            "kind": "call",
            "function": "rtsim.validate.points:random_point",
            "seed": cfg.seed,
            "options": {"hyperperiods": cfg.hyperperiods},
            "name": f"validate-random-{cfg.name}",
        },
        "grid": {"set": list(range(cfg.random_sets))},
    }
    return parse_sweep(data, source, allow_code=True)  # rtsim's own function, not a file's


def _run(
    spec: Any,
    out: Path,
    workers: int | None,
    dask: Any,
    progress: bool | None,
    restart: bool,
    argv: Sequence[str] | None,
) -> pd.DataFrame:
    return (
        Sweep(spec, out)
        .run(workers=workers, dask=dask, progress=progress, restart=restart, argv=argv)
        .table
    )


def _histogram_configs(table: pd.DataFrame, k: int) -> list[tuple[int, float, int]]:
    """(n, r_H, seed) of up to k paper configurations: n nearest 2 and r_H nearest 25 cm,
    then the largest n at that r_H."""
    paper = table[table["source"] == "paper"].drop_duplicates("config")
    if paper.empty or k < 1:
        return []
    r = min(paper["r_H"].unique(), key=lambda x: (abs(x - 25.0), x))
    at_r = paper[paper["r_H"] == r]
    first = min(at_r["n"].unique(), key=lambda x: (abs(x - 2), x))
    picks = [first]
    if k > 1 and at_r["n"].max() != first:
        picks.append(at_r["n"].max())
    out = []
    for n in picks:
        row = at_r[at_r["n"] == n].iloc[0]
        out.append((int(n), float(r), int(row["seed"])))
    return out


def _histograms(
    cfg: ValidationConfig, table: pd.DataFrame, out: Path, fmt: str = "png", dpi: int = DPI
) -> list[Path]:
    """Re-run the chosen configurations at w_sch (same seeds) and draw their histograms."""
    opts = _taskset_options(cfg)
    written: list[Path] = []
    for n, r_H, seed in _histogram_configs(table, cfg.histogram_configs):
        ts = paper_taskset(opts, n, r_H)
        assert ts.window is not None
        w = w_sch_of(ts)
        beams = beam_counts_for(ts, w, cfg.windows, seed, opts)
        hough = beams.hough_times(ts.window)
        bounds = task_bounds(ts, w)
        d = out / "histograms" / f"n{n}-rH{r_H:g}"
        for mode in PAPER_MODES:
            res = simulate_mode(ts, mode, w, cfg.windows, hough, record_jobs=True)
            src = JobSource(
                res.jobs,
                bounds,
                {
                    "source": "validate",
                    "n": n,
                    "r_H": r_H,
                    "w": w,
                    "mode": mode,
                    "seed": seed,
                    "windows": cfg.windows,
                },
            )
            written += write_histograms(
                src,
                d,
                suffix=f"-{mode}",
                title=f"n={n}, r_H={r_H:g} cm, w=w_sch, {mode}",
                manifest=False,
                fmt=fmt,
                dpi=dpi,
            )

        write_manifest(
            d,
            command="validate histograms",
            seed=seed,
            inputs={"n": n, "r_H": r_H, "w": w, "windows": cfg.windows, "modes": list(PAPER_MODES)},
            extra={"outputs": sorted(p.name for p in written if p.parent == d)},
        )
    return written


def scheduler_table(
    cfg: ValidationConfig,
    n: Sequence[int] = tuple(range(1, 11)),
    r_H: Sequence[float] = (10.0, 20.0, 30.0, 40.0, 50.0),
) -> pd.DataFrame:
    """The analytic table of the task set's window bounds under both schedulers: n, r_H,
    w_sch, w_rta (fixed priority), w_edf (EDF), and the gains w_rta/w_sch and w_edf/w_rta
    (all with Δt counted as CPU time; whatever the run's grid)."""
    opts = _taskset_options(cfg)
    rows = []
    for r in r_H:
        for k in n:
            ts = paper_taskset(opts, k, r)
            sch, rta, edf = w_sch_of(ts), w_rta(ts), w_edf(ts)
            rows.append(
                {
                    "n": k,
                    "r_H": float(r),
                    "w_sch": sch,
                    "w_rta": rta,
                    "w_edf": edf,
                    "w_rta_over_w_sch": rta / sch,
                    "w_edf_over_w_rta": edf / rta,
                }
            )
    return pd.DataFrame(rows)


def _figures(
    table: pd.DataFrame,
    out: Path,
    sched: pd.DataFrame | None = None,
    fmt: str = "png",
    dpi: int = DPI,
) -> list[Path]:
    from rtsim.plots.scenario import (  # lazy: only this needs matplotlib
        save_figure,
    )
    from rtsim.plots.validation import (  # lazy: only this needs matplotlib
        bounds_vs_n,
        bounds_vs_n_data,
        pessimism_data,
        pessimism_heatmap,
        scheduler_bounds,
    )

    figs = out / "figures"
    written: list[Path] = []
    if (table["source"] == "paper").any():
        jobs = [
            ("bounds_vs_n", bounds_vs_n(table), bounds_vs_n_data(table)),
            (
                "pessimism_wsch",
                pessimism_heatmap(table, "w_sch_over_w_sim"),
                pessimism_data(table, "w_sch_over_w_sim"),
            ),
            (
                "pessimism_wrta",
                pessimism_heatmap(table, "w_rta_over_w_sim"),
                pessimism_data(table, "w_rta_over_w_sim"),
            ),
        ]
        for name, fig, data in jobs:
            written.append(save_figure(fig, figs / f"{name}.{fmt}", dpi=dpi, fmt=fmt))
            write_table(figs / f"{name}.csv", data)
            written.append(figs / f"{name}.csv")
    if sched is not None:
        written.append(
            save_figure(scheduler_bounds(sched), figs / f"scheduler_bounds.{fmt}", dpi=dpi, fmt=fmt)
        )
        write_table(figs / "scheduler_bounds.csv", sched)
        written.append(figs / "scheduler_bounds.csv")
    return written


#: What validate makes in its directory (the lock file aside).
MADE = {
    "sweeps",
    "validation.csv",
    "results.parquet",
    "failures.csv",
    "summary.json",
    "figures",
    "histograms",
    "report.md",
    "report.html",
    "manifest.json",
}


def run_validation(
    out_dir: str | os.PathLike[str],
    config: ValidationConfig = FULL,
    *,
    workers: int | None = None,
    dask: Any = None,
    progress: bool | None = False,
    restart: bool = False,
    argv: Sequence[str] | None = None,
    fig_format: str = "png",
    dpi: int = DPI,
) -> ValidationOutcome:
    """Run (or resume) both sweeps into ``out_dir`` and write the report (module doc).
    ``fig_format``: the figures' file format (png, svg or pdf; ``dpi`` for PNG).

    ``out_dir`` is locked while it runs (`rtsim.io.lock`): a second validation into it
    is refused, naming the holder. A directory holding anything validate does not make
    (another command's output, a user's file) is refused before anything is done; a new
    directory is claimed at once by a ``manifest.json`` of ``validate`` (rewritten at the
    end), so a resumed run knows it."""
    check_resumable(out_dir, "validate", MADE, before_manifest={"sweeps"})
    with lock_directory(out_dir, argv):
        check_resumable(out_dir, "validate", MADE, before_manifest={"sweeps"}, clean=True)
        return _run_validation(
            out_dir,
            config,
            workers=workers,
            dask=dask,
            progress=progress,
            restart=restart,
            argv=argv,
            fig_format=fig_format,
            dpi=dpi,
        )


def _run_validation(
    out_dir: str | os.PathLike[str],
    config: ValidationConfig,
    *,
    workers: int | None,
    dask: Any,
    progress: bool | None,
    restart: bool,
    argv: Sequence[str] | None,
    fig_format: str = "png",
    dpi: int = DPI,
) -> ValidationOutcome:
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    inputs = {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(config).items()}

    def manifest(**extra: Any) -> None:
        argv_ = None if argv is None else list(argv)
        write_manifest(
            out, command="validate", seed=config.seed, inputs=inputs, argv=argv_, extra=extra
        )

    if not (out / "manifest.json").exists():  # claim the directory (see run_validation)
        manifest(outputs=[])
    suffix = "" if config.name == "full" else f"-{config.name}"
    paper = _run(
        paper_sweep_spec(config),
        out / "sweeps" / f"paper{suffix}",
        workers,
        dask,
        progress,
        restart,
        argv,
    )
    parts = [tidy.tidy_paper(paper)]  # (looked up at the call: tests replace it)
    errors = [
        f"paper n={r['n']}, r_H={r['r_H']}: {r['error']}"
        for r in paper[paper["status"] == "failed"].to_dict("records")
    ]
    if config.random_sets:
        rnd = _run(
            random_sweep_spec(config),
            out / "sweeps" / f"random{suffix}",
            workers,
            dask,
            progress,
            restart,
            argv,
        )
        parts.append(tidy.tidy_random(rnd))
        errors += [
            f"random set {r['set']}: {r['error']}"
            for r in rnd[rnd["status"] == "failed"].to_dict("records")
        ]
    table = pd.concat([p for p in parts if not p.empty] or [parts[0]], ignore_index=True)
    table = table.reindex(columns=list(tidy.COLUMNS))
    failures = check_results(table)
    summary = summarize(table) if not table.empty else {"rows": 0, "failures": 0}
    summary["point_errors"] = len(errors)
    files: list[Path] = []
    write_table(out / "validation.csv", table)
    write_table(out / "results.parquet", table)
    fail_df = pd.DataFrame(
        [f.as_dict() for f in failures],
        columns=["config", "task", "mode", "check", "value", "bound", "severity"],
    )
    write_table(out / "failures.csv", fail_df)
    write_json(out / "summary.json", summary)
    files += [
        out / "validation.csv",
        out / "results.parquet",
        out / "failures.csv",
        out / "summary.json",
    ]
    sched = scheduler_table(config)
    files += _figures(table, out, sched, fig_format, dpi)
    files += _histograms(config, table, out, fig_format, dpi)
    outcome = ValidationOutcome(table, failures, summary, errors, out, files)
    files.append(write_report(outcome, config, sched))
    html_path = out / REPORT_NAME
    manifest(outputs=sorted(str(p.relative_to(out)) for p in [*files, html_path]), ok=outcome.ok)
    # report.html last: it embeds the manifest just written.
    files.append(
        write_run_report(
            out, title=f"rtsim validate: {out.name}", extra_html=_report_md_html(out / "report.md")
        )
    )
    return replace(outcome, files=files)


def _report_md_html(md: Path) -> str:
    """report.md shown as preformatted text in report.html."""
    import html

    if not md.exists():
        return ""
    return f"<h2>Findings (report.md)</h2><pre>{html.escape(md.read_text('utf-8'))}</pre>"
