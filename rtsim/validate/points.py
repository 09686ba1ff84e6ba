"""The two sweep-point functions of the validation (``call`` kind: ``fn(params, options, seed)``):
`paper_point`, one (n, r_H) of the paper's task set (its bounds, the counted beams, and w_sim
searched in three modes), and `random_point`, one UUniFast set's WCRTs against simulation.
What each computes: docs/validation.md.
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

import numpy as np

from rtsim.analysis.bounds import w_susp, window_bounds
from rtsim.analysis.edf import analyze_edf
from rtsim.analysis.rta import analyze
from rtsim.analysis.validation import (
    PERCENTILES,
    SEARCH_TOL,
    percentiles,
    smallest_passing,
    task_bounds,
)
from rtsim.analysis.window import k_geometric
from rtsim.config.load import with_overrides
from rtsim.config.taskset import load_taskset, parse_taskset
from rtsim.model.generate import random_taskset
from rtsim.model.taskset import TaskSet
from rtsim.sim import EPS, build_cpu, simulate
from rtsim.validate.beams import Test1, count_window_beams, scenario_world, world_config

__all__ = [
    "paper_point",
    "random_point",
    "paper_taskset",
    "PAPER_MODES",
    "RANDOM_MODES",
    "FP_MODES",
    "simulate_mode",
    "beam_counts_for",
    "random_taskset_for",
]

#: The fixed-priority modes (their histograms are drawn against the FP bounds).
FP_MODES: tuple[str, ...] = ("wcet-cpu", "counted-idle")
PAPER_MODES: tuple[str, ...] = (*FP_MODES, "edf-cpu")
RANDOM_MODES: tuple[str, ...] = ("wcet-sync", "uniform-offsets")
_QNAMES = {50.0: "p50", 99.0: "p99", 99.9: "p999"}


def paper_taskset(options: Mapping[str, Any], n: int, r_H: float) -> TaskSet:
    """The task set of the options (TOML text, default the packaged paper set; changed by
    ``taskset_set``, ``--set``'s dotted paths) at (n, r_H)."""
    text = options.get("taskset_text")
    if not text:
        ts = load_taskset()
    else:
        source = str(options.get("taskset_source", "taskset"))
        data = with_overrides(tomllib.loads(text), options.get("taskset_set"), source)
        ts = parse_taskset(data, source)
    return ts.with_window(n=int(n), r_H=float(r_H))


def beam_counts_for(
    ts: TaskSet, w: float, windows: int, seed: int, options: Mapping[str, Any]
) -> Any:
    """The Test 1 beam counts of this configuration (see `rtsim.validate.beams`)."""
    assert ts.window is not None
    n, r_H = ts.window.n, ts.window.r_H
    text = options.get("scenario_text")
    if text:
        source = str(options.get("scenario_source", "scenario"))
        cfg = scenario_world(text, source, n, r_H, options.get("scenario_set"))
    else:
        cfg = world_config(n, Test1(**dict(options.get("world", {}))))
    return count_window_beams(ts.window, w, windows, np.random.default_rng(seed), cfg)


class _Missed(Exception):
    """Raised by the job-end hook of `passes_at` to stop a run at its first miss."""


def simulate_mode(
    ts: TaskSet,
    mode: str,
    w: float,
    windows: int,
    hough: np.ndarray | None,
    *,
    record_jobs: bool = False,
    stop_at_miss: bool = False,
) -> Any:
    """One run of ``windows`` windows at fixed ``w`` in ``mode`` (a `SimResult`).

    ``stop_at_miss``: raise `_Missed` from a job-end hook at the first deadline miss
    (the search only needs to know whether one happens).
    """
    assert ts.window is not None
    suspension = "idle" if mode == "counted-idle" else "cpu"
    cpu, info = build_cpu(
        ts,
        window=w,
        suspension=suspension,
        exec_model="wcet",
        record_jobs=record_jobs,
        scheduler="edf" if mode == "edf-cpu" else "fp",
    )
    if mode == "counted-idle":
        assert hough is not None
        times = [float(x) for x in hough]

        def counted(job: Any, segment: Any, rng: Any) -> float:
            return times[job.index % len(times)]

        cpu.set_exec_time(ts.window.name, "hough", counted)
    if stop_at_miss:

        def check(job: Any) -> None:
            if job.aborted or (job.finish is not None and job.finish > job.deadline + EPS):
                raise _Missed

        cpu.on("job_end", check)
    proc = cpu.start(windows * w)
    cpu.env.run(until=proc)
    return cpu.result(window=info)


def _response_metrics(out: dict[str, Any], mode: str, res: Any) -> None:
    jobs = res.jobs
    for name, st in res.tasks.items():
        resp = jobs.loc[jobs["task"] == name, "response"].to_numpy(dtype=float)
        out[f"sim_max.{mode}.{name}"] = (
            math.nan if st.max_response is None else float(st.max_response)
        )
        for q, v in percentiles(resp, PERCENTILES).items():
            out[f"{_QNAMES[q]}.{mode}.{name}"] = v
        out[f"jobs.{mode}.{name}"] = int(st.completed)
        out[f"misses.{mode}.{name}"] = int(st.misses)


def paper_point(params: Mapping[str, Any], options: Mapping[str, Any], seed: int) -> dict[str, Any]:
    """Validation metrics of one (n, r_H) of the paper's set (module doc)."""
    n, r_H = int(params["n"]), float(params["r_H"])
    windows = int(options.get("windows", 100))
    scan = int(options.get("scan", 10))
    tol = float(options.get("tol", SEARCH_TOL))
    if windows < 1:
        raise ValueError(f"windows must be at least 1, got {windows}")
    ts = paper_taskset(options, n, r_H)
    assert ts.window is not None
    wb = window_bounds(ts)
    out: dict[str, Any] = {
        k: float(getattr(wb, k))
        for k in ("e_hough", "g", "w_eq7", "w_eq11", "w_sch", "w_rta", "w_susp", "w_edf")
    }
    rho_min = float(options.get("rho_min", 300.0))
    geo = ts.with_window(k=float(k_geometric(rho_min)), rho_min=rho_min)
    assert geo.window is not None
    out["rho_min"] = rho_min
    out["k_geo"] = float(geo.window.k)
    out["w_susp_geo"] = float(w_susp(geo))
    beams = beam_counts_for(ts, wb.w_sch, windows, seed, options)
    out["beyond_geo"] = beams.beyond_wcet(geo.window)
    hough = beams.hough_times(ts.window)
    out.update(
        windows=windows,
        points_min=int(beams.total.min()),
        points_max=int(beams.total.max()),
        points_mean=float(beams.total.mean()),
        points_max_follower=int(beams.points.max()),
        points_wcet=float(min(361, ts.window.k * n)),
        tracks_lost=int(beams.lost.sum()),
        tracks_lost_sensor=int(beams.lost.sum()) - beams.lost_moved,
        beyond_wcet=beams.beyond_wcet(ts.window),
        hough_min=float(hough.min()),
        hough_max=float(hough.max()),
    )
    bounds = task_bounds(ts, wb.w_sch)
    for name, b in bounds.items():
        out[f"wcrt.{name}"] = math.nan if b.wcrt is None else float(b.wcrt)
        out[f"deadline.{name}"] = float(b.deadline)
    for t in analyze(ts, wb.w_sch, suspension="idle").tasks:  # Δt idle: counted-idle's model
        out[f"wcrt_susp.{t.name}"] = math.nan if t.wcrt is None else float(t.wcrt)
    for te in analyze_edf(ts, wb.w_sch).tasks:  # Spuri's bounds: edf-cpu's model
        out[f"wcrt_edf.{te.name}"] = math.nan if te.wcrt is None else float(te.wcrt)
    # every chain job needs at least its own length g_j: any w below the longest one misses
    g_longest = {
        "wcet-cpu": ts.window.g(),
        "counted-idle": ts.window.g(float(hough.max())),
        "edf-cpu": ts.window.g(),
    }
    for mode in PAPER_MODES:
        res = simulate_mode(ts, mode, wb.w_sch, windows, hough, record_jobs=True)
        _response_metrics(out, mode, res)

        def passes(w: float, mode: str = mode) -> bool:
            try:
                return simulate_mode(ts, mode, w, windows, hough, stop_at_miss=True).misses == 0
            except _Missed:
                return False

        hi = max(wb.w_sch, wb.w_rta) + tol
        sr = smallest_passing(passes, 0.999 * g_longest[mode], hi, tol=tol, scan=scan)
        out[f"w_sim.{mode}"] = sr.w
        out[f"evaluations.{mode}"] = sr.evaluations
        out[f"nonmonotone.{mode}"] = sr.nonmonotone
        out[f"hi_doublings.{mode}"] = sr.hi_doublings
    return out


def _lcm(values: list[float]) -> float:
    if all(float(v).is_integer() for v in values):
        return float(math.lcm(*(int(v) for v in values)))
    return math.inf


def random_taskset_for(params: Mapping[str, Any], options: Mapping[str, Any], seed: int) -> TaskSet:
    """The random set of this point: size, utilization and periods drawn from ``seed``."""
    rng = np.random.default_rng(seed)
    lo_n, hi_n = (int(x) for x in options.get("tasks", (2, 8)))
    lo_u, hi_u = (float(x) for x in options.get("utilization", (0.5, 0.9)))
    n = int(rng.integers(lo_n, hi_n + 1))
    u = float(rng.uniform(lo_u, hi_u))
    periods = str(options.get("periods", "10,20,25,40,50,100,200"))
    df = tuple(float(x) for x in options.get("deadline_factor", (0.8, 1.0)))
    return random_taskset(
        n, u, rng, periods, name=f"random-{params.get('set', 0)}", deadline_factor=(df[0], df[1])
    )


def random_point(
    params: Mapping[str, Any], options: Mapping[str, Any], seed: int
) -> dict[str, Any]:
    """Validation metrics of one random task set (module doc)."""
    ts = random_taskset_for(params, options, seed)
    jit_rng = np.random.default_rng([seed, 2])  # its own stream: the sets stay the same
    frac = float(options.get("jitter", 0.1))
    ts = TaskSet(
        tuple(
            replace(t, jitter=round(float(jit_rng.uniform(0, frac * t.period)), 3))
            for t in ts.tasks
        ),
        name=ts.name,
    )
    hyper = _lcm([t.period for t in ts.tasks])
    if not math.isfinite(hyper) or hyper > float(options.get("max_horizon", 1e5)):
        hyper = float(options.get("max_horizon", 1e5))
    out: dict[str, Any] = {
        "n_tasks": len(ts.tasks),
        "utilization": float(sum(t.wcet / t.period for t in ts.tasks)),
        "hyperperiod": hyper,
    }
    bounds = task_bounds(ts)
    for name, b in bounds.items():
        out[f"wcrt.{name}"] = math.nan if b.wcrt is None else float(b.wcrt)
        out[f"deadline.{name}"] = float(b.deadline)
    runs: dict[str, Callable[[], Any]] = {}
    runs["wcet-sync"] = lambda: simulate(ts, hyper, seed=seed, record_jobs=True, jitter="worst")
    ratio = float(options.get("bcet_ratio", 0.5))
    rng = np.random.default_rng([seed, 1])
    varied = TaskSet(
        tuple(
            replace(
                t,
                bcet=ratio * t.wcet,
                offset=float(rng.integers(0, max(1, int(t.period)))),
                jitter=t.jitter,
            )
            for t in ts.tasks
        ),
        name=ts.name,
    )
    reps = int(options.get("hyperperiods", 10))
    runs["uniform-offsets"] = lambda: simulate(
        varied, reps * hyper, seed=seed, exec_model="uniform", record_jobs=True
    )
    for mode in RANDOM_MODES:
        _response_metrics(out, mode, runs[mode]())
    return out
