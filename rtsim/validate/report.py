"""``report.md`` of a validation run: headline numbers first, then failures, figures, tables
and the method."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import pandas as pd

from rtsim._version import __version__
from rtsim.io.atomic import write_text

if TYPE_CHECKING:
    from rtsim.validate.outcome import ValidationConfig, ValidationOutcome

__all__ = ["write_report", "markdown_table"]


def _fmt(v: Any, digits: int = 4) -> str:
    if v is None:
        return "–"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            return "–"
        return f"{v:.{digits}g}" if abs(v) < 1e4 else f"{v:.1f}"
    return str(v)


def markdown_table(df: pd.DataFrame, columns: Sequence[str] | None = None, digits: int = 5) -> str:
    """A GitHub Markdown table of ``df`` (numbers to ``digits`` significant digits)."""
    cols = list(df.columns if columns is None else columns)
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for rec in df[cols].to_dict("records"):
        lines.append("| " + " | ".join(_fmt(rec[c], digits) for c in cols) + " |")
    return "\n".join(lines)


def _rng(entry: dict[str, Any] | None, digits: int = 6) -> str:
    if not entry or entry.get("min") is None:
        return "–"
    return (
        f"{_fmt(entry['min'], digits)} – {_fmt(entry['max'], digits)} "
        f"(median {_fmt(entry['median'], digits)})"
    )


def _headline(outcome: ValidationOutcome) -> list[str]:
    s = outcome.summary
    t = outcome.table
    fails = [f for f in outcome.failures if f.severity == "failure"]
    warns = [f for f in outcome.failures if f.severity == "warning"]
    lines = ["## Summary", ""]
    verdict = "**PASS**" if outcome.ok else "**FAIL**"
    lines.append(
        f"- Verdict: {verdict} — {len(fails)} simulated result(s) above their analytic "
        f"bound, {len(warns)} warning(s), {len(outcome.point_errors)} sweep point(s) "
        f"failed to run."
    )
    paper = t[t["source"] == "paper"]
    if not paper.empty:
        cfg = paper.drop_duplicates("config")
        lines.append(
            f"- Paper's task set: {cfg.shape[0]} configurations "
            f"(n = {', '.join(str(int(x)) for x in sorted(cfg['n'].unique()))}; "
            f"r_H = {', '.join(f'{x:g}' for x in sorted(cfg['r_H'].unique()))} cm)."
        )
        gap = (cfg["w_sch"] - cfg["w_rta"]) / cfg["w_rta"]
        lines.append(
            f"- w_sch (Eq 7/11) is above the exact w_rta by "
            f"{100 * gap.min():.2f} – {100 * gap.max():.2f} % "
            f"({_fmt(float((cfg['w_sch'] - cfg['w_rta']).min()))} – "
            f"{_fmt(float((cfg['w_sch'] - cfg['w_rta']).max()))} ms)."
        )
        for mode, label in (
            ("wcet-cpu", "WCET, Δt as CPU time"),
            ("counted-idle", "counted beams, Δt idle"),
            ("edf-cpu", "the CPU under EDF, WCET, Δt as CPU time"),
        ):
            e = s.get(f"paper/{mode}")
            if not e:
                continue
            lines.append(
                f"- Search **{mode}** ({label}): w_sch / w_sim = "
                f"{_rng(e.get('w_sch_over_w_sim'))}; w_rta / w_sim = "
                f"{_rng(e.get('w_rta_over_w_sim'))}; WCRT / simulated max at w_sch "
                f"(all tasks) = {_rng(e.get('wcrt_over_sim_max'))}."
            )
            if mode == "edf-cpu" and e.get("w_edf_over_w_sim"):
                lines.append(
                    f"  EDF: w_edf / w_sim = {_rng(e.get('w_edf_over_w_sim'))} "
                    f"(WCRT here: Spuri's bound)."
                )
            if mode == "counted-idle" and e.get("w_susp_over_w_sim"):
                lines.append(
                    f"  Suspension-aware (Δt idle): w_susp / w_sim = "
                    f"{_rng(e.get('w_susp_over_w_sim'))}; with the geometric k "
                    f"(followers at ≥ rho_min): {_rng(e.get('w_geo_over_w_sim'))}; "
                    f"suspension-aware WCRT / simulated max at w_sch (all tasks) = "
                    f"{_rng(e.get('wcrt_susp_over_sim_max'))}."
                )
            sub = paper[paper["mode"] == mode]
            for task, g in sub.groupby("task", sort=False):
                v = g["wcrt_over_sim_max"].astype(float)
                q = (g["p999"] / g["wcrt"]).astype(float)
                lines.append(
                    f"  - {task}: WCRT / simulated max {_fmt(float(v.min()), 6)} – "
                    f"{_fmt(float(v.max()), 6)}; p99.9 / WCRT "
                    f"{_fmt(float(q.min()), 6)} – {_fmt(float(q.max()), 6)}"
                )
        dev = paper[paper["mode"] == "wcet-cpu"].drop_duplicates("config")
        d = (dev["w_sim"] - dev["w_rta"]).astype(float)
        lines.append(
            f"- wcet-cpu: w_sim − w_rta = {_fmt(float(d.min()))} – "
            f"{_fmt(float(d.max()))} ms (search tolerance 0.01 ms)."
        )
        nm = int(paper.drop_duplicates(["config", "mode"])["nonmonotone"].fillna(0).sum())
        lines.append(f"- Non-monotone spots found by the w_sim scans: {nm}.")
        lines.append(
            f"- Counted beams per window: {int(cfg['points_min'].min())} – "
            f"{int(cfg['points_max'].max())} points in total (Eq 1 assumes "
            f"min(361, k·n) = {_fmt(float(cfg['points_wcet'].min()))} – "
            f"{_fmt(float(cfg['points_wcet'].max()))}); windows beyond that: "
            f"{int(cfg['beyond_wcet'].sum())}; tracks lost in the world runs: "
            f"{int(cfg['tracks_lost'].sum())}, of which "
            f"{int(cfg['tracks_lost_sensor'].fillna(0).sum())} the sensor's limit "
            "(the follower returned fewer than min_points beams: hidden behind a "
            "nearer follower in a turn, or out of the laser's view) and the rest "
            "followers that moved more than r_H in the leader's frame within one "
            "window (far behind the turning leader at a fixed w_sch and V_Ld: the "
            "localization bound broken, which the adjustment would prevent by "
            "slowing the leader)."
        )
    rnd = t[t["source"] == "random"]
    if not rnd.empty:
        for mode in ("wcet-sync", "uniform-offsets"):
            e = s.get(f"random/{mode}")
            if e:
                sub = rnd[rnd["mode"] == mode]
                sched = sub[sub["wcrt"].notna()]
                lines.append(
                    f"- Random sets, **{mode}**: {e['configs']} sets, "
                    f"{sched.shape[0]} schedulable tasks; WCRT / simulated max = "
                    f"{_rng(e.get('wcrt_over_sim_max'))}."
                )
    return lines + [""]


def _figure_lines(out: Path) -> list[str]:
    """The report's figures and response-time histograms found under ``out``."""
    lines: list[str] = []
    figs = out / "figures"
    from rtsim.plots.scenario import (  # lazy: only this needs matplotlib
        FIGURE_FORMATS,
    )

    lines += ["## Figures", ""]
    for name, caption in (
        ("bounds_vs_n", "w_sch, w_rta and w_sim against n, per r_H"),
        ("pessimism_wsch", "pessimism w_sch / w_sim over (n, r_H)"),
        ("pessimism_wrta", "w_rta / w_sim over (n, r_H)"),
        (
            "scheduler_bounds",
            "the paper set's w_sch, w_rta (fixed priority) and w_edf (EDF) against n, per r_H",
        ),
    ):
        for fmt in FIGURE_FORMATS:
            if (figs / f"{name}.{fmt}").exists():
                lines += [
                    f"![{caption}](figures/{name}.{fmt})",
                    "",
                    f"*{caption}* (data: `figures/{name}.csv`)",
                    "",
                ]
    hist = (
        sorted(
            p
            for p in (out / "histograms").glob("*/histogram-*.*")
            if p.suffix.lstrip(".") in FIGURE_FORMATS
        )
        if (out / "histograms").exists()
        else []
    )
    if hist:
        lines += [
            "### Response-time histograms at w = w_sch",
            "",
            "Vertical lines: the exact WCRT (suspension-oblivious WCET analysis), the "
            "deadline, and w_sch for the window chain and the command task.",
            "",
        ]
        for p in hist:
            rel = p.relative_to(out).as_posix()
            lines += [f"![{p.stem}]({rel})", ""]
    return lines


def _method_lines(config: ValidationConfig, world: str) -> list[str]:
    """The report's method section (``world``: the scenario the beams were counted in)."""
    return [
        "## Method",
        "",
        "- **Analysis**: w_sch = max(Eq 7, Eq 11); w_rta = the least w at which exact "
        "response-time analysis (chain as one task of cost g, Δt counted as CPU time) "
        "finds every task schedulable; WCRT = that analysis at w_sch.",
        "- **Simulation**: the window is fixed at w, all tasks released at 0, jobs "
        f"released in [0, {config.windows}·w) run to completion. Mode `wcet-cpu`: every "
        "segment at its WCET, the radio round trip Δt holds the CPU. Mode "
        "`edf-cpu`: as `wcet-cpu` with the CPU under EDF; its w_sim is checked against "
        "w_edf (EDF demand criterion) and its responses against Spuri's bounds. Mode "
        "`counted-idle`: the Hough segment takes π r_H² n e_cal + P_j e_trans with P_j "
        "the beams counted at window j of a world run (" + world + ", with n followers "
        "placed by its formation model's default and its Hough radius set to r_H; fixed "
        "window w_sch, each follower commanded at the end of its send segment every "
        "window), replayed by window index; Δt frees the CPU; re-acquisition costs of "
        "lost tracks are not added.",
        "- **w_sim**: bisection to the tolerance between 0.999 × the longest chain "
        "length g_j (which must miss) and max(w_sch, w_rta) + tol (which must pass), "
        "each trial a run of all windows stopped at its first miss, then a scan "
        f"of {config.scan} windows above the result; a miss in the scan (a non-monotone "
        "spot) restarts the bisection above it. w_sim is the least window, to the "
        "tolerance, above which no tried window missed.",
        "- **Checks**: a simulated maximum above the WCRT (+1e-6 ms) is a failure; so is "
        "w_sim above w_rta + tol, and w_sch below w_rta. Under the model of the "
        "suspension-aware analysis (`counted-idle`, Δt idle), also w_sim above w_susp "
        "or the geometric w_susp + tol, w_susp above w_rta, and a simulated maximum "
        "above the suspension-aware WCRT. Rows whose counted beams exceeded the "
        "bound's k·n are warnings, not failures (the WCET assumption broke).",
        "- **Random sets**: UUniFast utilizations, periods from {10, 20, 25, 40, 50, "
        "100, 200} ms, constrained deadlines, deadline-monotonic priorities; `wcet-sync` "
        "simulates one hyperperiod at WCET from the critical instant (with release "
        "jitter J ≤ 0.1·T per task: first releases together after J, later ones at "
        "arrival), `uniform-offsets` several hyperperiods with execution times uniform "
        "in [wcet/2, wcet], random offsets and release delays in [0, J].",
        "",
    ]


def write_report(
    outcome: ValidationOutcome, config: ValidationConfig, sched: pd.DataFrame | None = None
) -> Path:
    """Write ``report.md`` into the outcome's directory and return its path (``sched``: the
    analytic w_sch / w_rta / w_edf table of `rtsim.validate.runner.scheduler_table`)."""
    out = outcome.out_dir
    t = outcome.table
    world = (
        f"scenario `{config.scenario_path}`"
        if config.scenario_path
        else "Test 1, `experiments/scenarios/test1.toml`: V_Ld = 25 cm/s, r_t = 2 m, ρ = 390 cm"
    )
    lines = [
        "# rtsim validation report",
        "",
        f"rtsim {__version__}, `{config.name}` run: n ∈ {list(config.n)}, "
        f"r_H ∈ {[float(r) for r in config.r_H]} cm, {config.windows} windows per run, "
        f"w_sim to {config.tol} ms, {config.random_sets} random sets, seed {config.seed}.",
        "",
    ]
    lines += _headline(outcome)
    lines += ["## Failures", ""]
    if outcome.failures:
        fdf = pd.DataFrame([f.as_dict() for f in outcome.failures])
        lines += [markdown_table(fdf), ""]
    else:
        lines += [
            "None: no simulated response above its analytic bound, no w_sim above "
            "w_rta, w_sch ≥ w_rta everywhere.",
            "",
        ]
    if outcome.point_errors:
        lines += ["Sweep points that failed to run:", ""]
        lines += [f"- {e}" for e in outcome.point_errors] + [""]
    lines += _figure_lines(out)
    paper = t[t["source"] == "paper"]
    if not paper.empty:
        lines += ["## Windows per configuration (ms)", ""]
        wide = paper.drop_duplicates(["config", "mode"]).pivot(
            index=["n", "r_H", "w_sch", "w_rta"], columns="mode", values="w_sim"
        )
        wide = wide.reset_index()
        wide.columns = [
            c if c in ("n", "r_H", "w_sch", "w_rta") else f"w_sim {c}" for c in wide.columns
        ]
        for mode in ("wcet-cpu", "counted-idle"):
            if f"w_sim {mode}" in wide:
                wide[f"w_sch/w_sim {mode}"] = wide["w_sch"] / wide[f"w_sim {mode}"]
        lines += [markdown_table(wide.sort_values(["r_H", "n"]), digits=6), ""]
        lines += ["## Response times at w = w_sch (ms)", ""]
        cols = [
            "config",
            "mode",
            "task",
            "wcrt",
            "deadline",
            "sim_max",
            "p50",
            "p99",
            "p999",
            "wcrt_over_sim_max",
            "jobs",
        ]
        lines += [markdown_table(paper.sort_values(["r_H", "n"]), cols, digits=6), ""]
    if sched is not None and not sched.empty:
        gain = 1 - sched["w_edf_over_w_rta"]
        lines += [
            "## The window under EDF: w_sch, w_rta and w_edf (ms)",
            "",
            "The paper's set, Δt counted as CPU time, for every n and r_H below "
            "(whatever the run's grid). EDF is optimal on one processor in this model, "
            f"so w_edf ≤ w_rta: here smaller by {100 * gain.min():.2f} – "
            f"{100 * gain.max():.2f} %. With the paper's implicit deadlines w_edf is "
            "where the utilization reaches 1.",
            "",
            markdown_table(sched, digits=6),
            "",
        ]
    rnd = t[t["source"] == "random"]
    if not rnd.empty:
        lines += ["## Random task sets (ms)", ""]
        cols = [
            "config",
            "mode",
            "task",
            "wcrt",
            "deadline",
            "sim_max",
            "p99",
            "wcrt_over_sim_max",
            "jobs",
            "misses",
        ]
        lines += [markdown_table(rnd, cols, digits=6), ""]
    lines += _method_lines(config, world)
    path = out / "report.md"
    write_text(path, "\n".join(lines))
    return path
