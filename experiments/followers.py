"""How many followers, and how large a Hough window, can the co-simulated group take?

Runs the shipped Test 1 and Test 2 (their own defaults: the predicted window centre, the
search only for followers the laser can be expected to see, the fan formation) with
n = 1..10 followers and r_H = 15, 25, 35, 50 cm, one lap each (the runs' default duration),
seeds 0–2, and n = 1..6 at r_H = 25 cm also with seeds 3 and 4 (the goal: no miss and no lost
track with up to six followers, any seed). Per run: misses, lost tracks by cause, searches,
lap time, critical share, min V_L/V_Ld, w_sch. Per (test, n, r_H), over the seeds: sums of
misses and lost tracks (by cause), mean lap time and critical share, min V_L/V_Ld; and the
reasons the group stops working, computed from the analysis and the formation:

* ``wsch_over_path``: w_sch / the path-diversion bound on a straight at V_Ld (T_ε·ρ_d/V_Ld):
  above 1 the windows cannot be short enough even on straights and the leader slows there;
* ``beams``: beams a lone follower at ρ_d returns (the laser's resolution at range, Eq 2's k);
* ``width_cm`` and ``turn_speed``: the fan's widest lateral offset on the turns' outer side
  and the speed it needs in a turn, (1 + o/R)·V_Ld, against the followers' top speed.

Outputs in DIR: ``followers.csv`` (one row per run), ``followers_summary.csv`` and
``followers.md`` (the table), ``followers.png`` (misses + lost tracks + confusions and lap
time against r_H, one line per n, per test), ``manifest.json``. Per run also the confusions,
the fix error (p95, max), radio losses, the laps driven, the leader's distance, the lap time
and the loop's CPU time.

    python experiments/followers.py [--quick] [--choices] [--out DIR] [--workers N]
        [--followers 2,4] [--hough-radius 15,30] [--seeds 0] [--tests test2]

Any of ``--followers``, ``--hough-radius``, ``--seeds``, ``--tests`` replaces the default
grid by their product (the others at their defaults), one lap each.

``--choices`` instead measures what each modelling choice moves, one lap, seed 0, n = 2, 4, 6,
r_H = 25 cm: the original choices (``previous`` centre, ``always`` search, the line,
Eq 19), the full localization bound, each new choice alone, and the shipped set —
``choices.csv`` and ``choices.md`` (misses, lost tracks by cause, searches, mean w, lap time,
critical share).

``--quick``: n = 2, 3, r_H = 25 cm, seed 0, 15 simulated seconds, in this process (the test
suite runs it).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from rtsim.coupling import run_scenario
from rtsim.io.atomic import write_table, write_text
from rtsim.io.manifest import write_manifest
from rtsim.world.localization import LOST_CAUSES

TESTS = ("test1", "test2")
NS = tuple(range(1, 11))
RADII = (15.0, 25.0, 35.0, 50.0)
SEEDS = (0, 1, 2)
#: the goal's extra seeds: n = 1..6 at r_H = 25 cm
GOAL_NS, GOAL_R, GOAL_SEEDS = tuple(range(1, 7)), 25.0, (3, 4)
CAUSES = LOST_CAUSES


def _choice(centre: str, search: str, layout: str, bound: str) -> dict[str, Any]:
    return {
        "localization.centre": centre,
        "localization.search": search,
        "formation.layout": layout,
        "thresholds.localization": bound,
    }


#: (label, overrides): the modelling choices --choices compares
CHOICES: tuple[tuple[str, dict[str, Any]], ...] = (
    ("original (previous, always, line, Eq 19)", _choice("previous", "always", "line", "radial")),
    ("previous + full bound", _choice("previous", "always", "line", "full")),
    ("predicted centre", _choice("predicted", "always", "line", "predicted")),
    ("visible search", _choice("previous", "visible", "line", "radial")),
    ("fan", _choice("previous", "always", "fan", "radial")),
    ("shipped (predicted, visible, fan)", {}),
)


def run_choice(task: tuple[str, int, str]) -> dict[str, Any]:
    """One --choices run: (test, n, label)."""
    test, n, label = task
    ov = dict(CHOICES)[label]
    res = run_scenario(test, record_jobs=False, overrides={**ov, "formation.followers": n})
    s, df = res.summary, res.windows
    return {
        "test": test,
        "n": n,
        "choice": label,
        "missed": s["missed"],
        "tracks_lost": s["tracks_lost"],
        **{f"lost_{c}": s["tracks_lost_by_cause"][c] for c in CAUSES},
        "searches": s["searches"],
        "mean_w": float(df["w"].mean()),
        "lap_s": np.nan if s["lap_time_s"] is None else s["lap_time_s"],
        "critical_share": s["critical_share"],
        "max_response": s["max_response"],
    }


def choices_markdown(df: pd.DataFrame) -> str:
    lines = [
        "| test | n | choice | misses | lost (window/occl./range/neighb.) | searches | mean w (ms) "
        "| lap (s) | critical |",
        "|" + "---|" * 9,
    ]
    for r in df.to_dict("records"):
        by = "/".join(str(int(r[f"lost_{c}"])) for c in CAUSES)
        lines.append(
            f"| {r['test']} | {r['n']} | {r['choice']} | {r['missed']} | "
            f"{r['tracks_lost']} ({by}) | {r['searches']} | {r['mean_w']:.0f} | "
            f"{r['lap_s']:.1f} | {r['critical_share']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def tasks(
    quick: bool, grid: tuple[Any, Any, Any, Any] | None = None
) -> list[tuple[str, int, float, int, float | None]]:
    """(test, n, r_H, seed, duration) of every run: ``grid`` (tests, ns, radii, seeds, each
    None for the default's) one lap each, else the default grid (module docstring)."""
    if grid is not None and any(g is not None for g in grid):
        ts, ns, rs, ss = grid
        return [
            (t, n, r, seed, None)
            for t in ts or TESTS
            for n in ns or NS
            for r in rs or RADII
            for seed in ss or SEEDS
        ]
    if quick:
        return [(t, n, 25.0, 0, 15.0) for t in TESTS for n in (2, 3)]
    # the goal's runs first (n = 1..6 at r_H = 25 cm, seeds 0-4), then the rest of the grid
    out = [(t, n, GOAL_R, s, None) for t in TESTS for n in GOAL_NS for s in (*SEEDS, *GOAL_SEEDS)]
    out += [
        (t, n, r, s, None)
        for t in TESTS
        for n in NS
        for r in RADII
        for s in SEEDS
        if (t, n, r, s, None) not in out
    ]
    return out


def run_one(task: tuple[str, int, float, int, float | None]) -> dict[str, Any]:
    """One run's numbers (a row of followers.csv); a scenario the loader refuses (a
    formation that does not fit) is a row with ``error`` set."""
    test, n, r_H, seed, duration = task
    t0 = time.perf_counter()
    row: dict[str, Any] = {"test": test, "n": n, "r_H": r_H, "seed": seed, "error": ""}
    try:
        res = run_scenario(
            test,
            seed=seed,
            duration_s=duration,
            record_jobs=False,
            overrides={"formation.followers": n, "sensing.r_H": r_H},
        )
    except Exception as exc:  # noqa: BLE001 - a refused scenario is a result of the sweep
        row["error"] = str(exc)
        return row
    s = res.summary
    err = s.get("localization_error_cm") or {}
    row.update(
        {
            "missed": s["missed"],
            "tracks_lost": s["tracks_lost"],
            **{f"lost_{c}": s["tracks_lost_by_cause"][c] for c in CAUSES},
            "searches": s["searches"],
            "confusions": s.get("confusions", 0),
            "radio_losses": s.get("radio_losses", 0),
            "fix_error_p95_cm": err.get("p95", np.nan),
            "fix_error_max_cm": err.get("max", np.nan),
            "windows": s["windows"],
            "w_sch": s["w_sch"],
            "infeasible": s["infeasible"],
            "laps": s["laps"],
            "leader_cm": s["distance_cm"]["leader"] if "distance_cm" in s else np.nan,
            "lap_s": np.nan if s["lap_time_s"] is None else s["lap_time_s"],
            "critical_share": s["critical_share"],
            "min_speed_ratio": s["min_speed_ratio"],
            "max_response": s["max_response"],
            "cpu_s": res.timing["simulation_cpu_s"],
            "wall_s": time.perf_counter() - t0,
        }
    )
    # the physical outcomes, where the run reports them
    if "collisions" in s:
        cross = s.get("cross_track_cm") or {}
        dist = s.get("min_robot_distance_cm")
        row.update(
            {
                "collisions": s["collisions"],
                "min_robot_distance_cm": np.nan if dist is None else dist,
                "cross_track_max_cm": cross.get("max", np.nan),
            }
        )
    return row


def reasons(test: str, n: int, r_H: float) -> dict[str, float]:
    """Why the group stops working (module docstring), from the analysis and the formation."""
    from rtsim.config.scenario import load_scenario
    from rtsim.world.laser import max_points

    try:
        sc = load_scenario(test, overrides={"formation.followers": n, "sensing.r_H": r_H})
    except Exception:  # noqa: BLE001 - the formation does not fit
        return {
            "wsch_over_path": math.nan,
            "beams": math.nan,
            "width_cm": math.nan,
            "turn_speed": math.nan,
        }
    from rtsim.analysis.bounds import window_bounds

    w = sc.world
    rho_d = w.formation.rho_d[0]
    v = w.leader_speed
    w_sch = window_bounds(sc.load_taskset(), n=n, r_H=r_H).w_sch
    path_ms = 1000.0 * w.thresholds.T_eps * rho_d / v
    radius = min(1.0 / abs(g.curvature) for g in w.path.segments if g.curvature != 0.0)
    width = max(abs(o) for o in w.formation.lateral)
    return {
        "wsch_over_path": w_sch / path_ms,
        "beams": max_points(rho_d, w.follower.radius),
        "width_cm": width,
        "turn_speed": (1.0 + width / radius) * v,
    }


def summarize(runs: pd.DataFrame) -> pd.DataFrame:
    """Per (test, n, r_H) over the seeds that ran (module docstring). Pure but for
    :func:`reasons`."""
    ok = runs[runs["error"] == ""]
    agg: dict[str, Any] = {
        "seed": "count",
        "missed": "sum",
        "tracks_lost": "sum",
        **{f"lost_{c}": "sum" for c in CAUSES},
        "searches": "sum",
        "confusions": "sum",
        "fix_error_max_cm": "max",
        "laps": "min",
        "lap_s": "mean",
        "critical_share": "mean",
        "min_speed_ratio": "min",
        "w_sch": "first",
    }
    for col, how in (
        ("collisions", "sum"),
        ("min_robot_distance_cm", "min"),
        ("cross_track_max_cm", "max"),
    ):
        if col in ok:
            agg[col] = how
    out = ok.groupby(["test", "n", "r_H"], sort=True).agg(agg).reset_index()
    out = out.rename(columns={"seed": "seeds"})
    extra = pd.DataFrame(
        [
            reasons(t, int(n), float(r))
            for t, n, r in out[["test", "n", "r_H"]].itertuples(index=False)
        ]
    )
    return pd.concat([out, extra], axis=1)


def markdown(df: pd.DataFrame) -> str:
    """The summary as a Markdown table."""
    phys = "collisions" in df
    lines = [
        "| test | n | r_H (cm) | seeds | misses | lost (window/occl./range/neighb.) | searches "
        "| confusions | fix error max (cm) | laps (min) "
        "| lap (s) | critical | min V_L/V_Ld | w_sch (ms) | w_sch / path bound | "
        "beams at ρ_d | width (cm) | turn speed (cm/s) |"
        + (" collisions | min distance (cm) |" if phys else ""),
        "|" + "---|" * (20 if phys else 18),
    ]
    for r in df.to_dict("records"):
        by = "/".join(str(int(r[f"lost_{c}"])) for c in CAUSES)
        lines.append(
            f"| {r['test']} | {r['n']} | {r['r_H']:g} | {r['seeds']} | "
            f"{r['missed']} | {r['tracks_lost']} ({by}) | {r['searches']} | "
            f"{r['confusions']} | {r['fix_error_max_cm']:.1f} | {r['laps']:.2f} | "
            f"{r['lap_s']:.1f} | {r['critical_share']:.2f} | "
            f"{r['min_speed_ratio']:.2f} | {r['w_sch']:.0f} | "
            f"{r['wsch_over_path']:.2f} | {r['beams']:.0f} | {r['width_cm']:.0f} | "
            f"{r['turn_speed']:.0f} |"
            + (f" {int(r['collisions'])} | {r['min_robot_distance_cm']:.0f} |" if phys else "")
        )
    return "\n".join(lines) + "\n"


def figure(df: pd.DataFrame, path: Path) -> None:
    """Per test, against r_H, one line per n: what a window loses (misses + lost tracks +
    confusions, summed over the seeds, log scale: too small a window loses its follower, too
    large lets a neighbour in) and what it costs (the lap time, the leader's progress; a run
    that did not finish its lap is drawn hollow). The right r_H lies between."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rtsim.io.atomic import atomic_path

    tests = sorted(df["test"].unique())
    fig, axes = plt.subplots(
        2, len(tests), figsize=(5.5 * len(tests), 6.5), squeeze=False, sharex=True
    )
    for j, test in enumerate(tests):
        for i, n in enumerate(sorted(df["n"].unique())):
            sel = df[(df["test"] == test) & (df["n"] == n)].sort_values("r_H")
            if sel.empty:
                continue
            bad = (sel["missed"] + sel["tracks_lost"] + sel["confusions"]).to_numpy(float)
            axes[0][j].plot(sel["r_H"], bad + 1.0, marker="o", color=f"C{i}", label=f"n = {n}")
            done = sel["laps"].to_numpy(float) >= 1.0
            axes[1][j].plot(sel["r_H"], sel["lap_s"], color=f"C{i}", label=f"n = {n}")
            axes[1][j].scatter(
                sel["r_H"],
                sel["lap_s"],
                facecolors=[f"C{i}" if d else "none" for d in done],
                edgecolors=f"C{i}",
            )
        axes[0][j].set_yscale("log")
        axes[0][j].set_title(test, fontsize=10)
        axes[0][j].set_ylabel("1 + misses + lost + confusions")
        axes[1][j].set_ylabel("lap time (s, mean over seeds)")
        axes[1][j].set_xlabel("Hough window radius r_H (cm)")
        axes[0][j].legend(fontsize=7)
    fig.tight_layout()
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format="png", dpi=100)
    plt.close(fig)


def _list(text: str | None, kind: Any, flag: str) -> list[Any] | None:
    """A comma-separated option as a list of ``kind`` (None when not given); a bad value is
    a ValueError naming the flag."""
    if text is None:
        return None
    out = []
    for part in text.split(","):
        try:
            v = kind(part.strip())
        except ValueError:
            raise ValueError(f"{flag}: not a list of {kind.__name__}s: {text!r}") from None
        if kind is int and (v < (1 if flag == "--followers" else 0)):
            raise ValueError(f"{flag}: {v} is out of range")
        if kind is float and not (0 < v < math.inf):
            raise ValueError(f"{flag}: {v:g} must be a positive number of cm")
        if kind is str and not v:
            raise ValueError(f"{flag}: an empty name in {text!r}")
        out.append(v)
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument(
        "--quick",
        action="store_true",
        help="n = 2, 3, r_H = 25 cm, seed 0, 15 simulated s, in this process",
    )
    p.add_argument("--out", metavar="DIR", help="output directory")
    p.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    p.add_argument(
        "--choices",
        action="store_true",
        help="compare the modelling choices instead (n = 2, 4, 6, seed 0)",
    )
    p.add_argument("--followers", metavar="N,N,...", help="follower counts (default 1..10)")
    p.add_argument("--hough-radius", metavar="CM,CM,...", help="r_H values (default 15,25,35,50)")
    p.add_argument("--seeds", metavar="S,S,...", help="seeds (default 0,1,2)")
    p.add_argument("--tests", metavar="NAME,...", help="scenarios (default test1,test2)")
    args = p.parse_args(argv)
    try:
        grid = (
            _list(args.tests, str, "--tests"),
            _list(args.followers, int, "--followers"),
            _list(args.hough_radius, float, "--hough-radius"),
            _list(args.seeds, int, "--seeds"),
        )
    except ValueError as exc:
        print(f"experiments/followers.py: {exc}", file=sys.stderr)
        return 2
    if args.choices:
        out = Path(args.out or "out/followers-choices")
        todo_c = [(t, n, label) for t in TESTS for n in (2, 4, 6) for label, _ in CHOICES]
        with ProcessPoolExecutor(max(1, args.workers)) as ex:
            table = pd.DataFrame(list(ex.map(run_choice, todo_c, chunksize=1)))
        out.mkdir(parents=True, exist_ok=True)
        write_table(out / "choices.csv", table)
        write_text(out / "choices.md", choices_markdown(table))
        print(choices_markdown(table), end="")
        return 0
    out = Path(args.out or ("out/followers-quick" if args.quick else "out/followers"))
    todo = tasks(args.quick, grid)
    out.mkdir(parents=True, exist_ok=True)
    # every finished run is appended to followers.partial.csv; a rerun skips those (resume)
    partial = out / "followers.partial.csv"
    done: list[dict[str, Any]] = []
    if partial.exists() and not args.quick:
        done = pd.read_csv(partial, keep_default_na=False).to_dict("records")
    have = {(r["test"], int(r["n"]), float(r["r_H"]), int(r["seed"])) for r in done}
    left = [t for t in todo if t[:4] not in have]
    if args.quick or args.workers <= 1:
        rows = done + [run_one(t) for t in left]
    else:
        rows = list(done)
        with ProcessPoolExecutor(args.workers) as ex:
            for row in ex.map(run_one, left, chunksize=1):
                rows.append(row)
                pd.DataFrame([row]).to_csv(
                    partial, mode="a", index=False, header=not partial.exists()
                )
    runs = pd.DataFrame(rows)
    runs["error"] = runs["error"].fillna("").astype(str)
    summary = summarize(runs)
    write_table(out / "followers.csv", runs)
    write_table(out / "followers_summary.csv", summary)
    write_text(out / "followers.md", markdown(summary))
    figure(summary, out / "followers.png")
    write_manifest(
        out,
        command="experiments/followers.py",
        seed=0,
        inputs={
            "quick": args.quick,
            "tests": sorted({t[0] for t in todo}),
            "runs": [list(t) for t in todo],
        },
        argv=[sys.argv[0], *(argv if argv is not None else sys.argv[1:])],
        extra={
            "outputs": ["followers.csv", "followers_summary.csv", "followers.md", "followers.png"]
        },
    )
    print(markdown(summary), end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
