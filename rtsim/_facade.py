"""The top level's entry points that take a task-set file as well as a task set.

The analyses and the simulator take task sets ([`TaskSet`][rtsim.model.taskset.TaskSet]); reading
a file is the configuration layer's work, above them. For convenience at the top level,
[`rtsim.analyze`][rtsim.analyze], [`rtsim.window_bounds`][rtsim.window_bounds] and
[`rtsim.simulate`][rtsim.simulate] also take the
path of a task-set file or the name of a packaged one (``"example"``), read with
[`rtsim.config.taskset.load_taskset`][rtsim.config.taskset.load_taskset].
[`run_sweep`][rtsim._facade.run_sweep] is a grid of scenario runs in one
call, returning a DataFrame. This module sits with `rtsim` above every layer.
"""

from __future__ import annotations

import functools
import os
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

from rtsim._numbers import is_int
from rtsim.analysis.bounds import window_bounds as _window_bounds
from rtsim.analysis.rta import analyze as _analyze
from rtsim.analysis.transaction import with_transaction_bounds
from rtsim.config.taskset import as_taskset
from rtsim.errors import InputError
from rtsim.sim.run import simulate as _simulate
from rtsim.sweep.engine import Sweep
from rtsim.sweep.spec import parse_sweep

if TYPE_CHECKING:
    import pandas as pd

__all__ = ["analyze", "run_sweep", "simulate", "window_bounds"]


def _read(ts: Any, function: str) -> Any:
    return as_taskset(ts, function) if isinstance(ts, str | os.PathLike) else ts


@functools.wraps(_analyze)
def analyze(ts: Any, *args: Any, force: bool = False, **kwargs: Any) -> Any:
    ts = _read(ts, "analyze")
    return with_transaction_bounds(ts, _analyze(ts, *args, **kwargs), force=force)


@functools.wraps(_window_bounds)
def window_bounds(ts: Any, *args: Any, **kwargs: Any) -> Any:
    return _window_bounds(_read(ts, "window_bounds"), *args, **kwargs)


@functools.wraps(_simulate)
def simulate(ts: Any, *args: Any, **kwargs: Any) -> Any:
    return _simulate(_read(ts, "simulate"), *args, **kwargs)


for _f in (analyze, window_bounds, simulate):
    _f.__doc__ = (_f.__doc__ or "") + (
        f"\n\n    At the top level (``rtsim.{_f.__name__}``), ``ts`` may also be the path of a "
        f"task-set file or the name of a packaged set."
    )
analyze.__doc__ = (analyze.__doc__ or "") + (
    "\n\n    At the top level the result also holds each task's offset-based (transaction) "
    "bound, as ``rtsim analyze`` reports it "
    "(``rtsim.analysis.transaction.with_transaction_bounds``): its "
    "work limit raises `TooMuchWork` unless ``force=True``."
)


def run_sweep(
    base: str | os.PathLike[str],
    grid: Mapping[str, Sequence[Any] | str],
    *,
    seeds: int | Sequence[int] = 0,
    duration_s: float | None = None,
    workers: int | None = None,
    out: str | os.PathLike[str] | None = None,
    mode: str | None = None,
    overrides: Mapping[str, Any] | None = None,
    kind: str = "scenario",
    options: Mapping[str, Any] | None = None,
    progress: bool = False,
    force: bool = False,
) -> pd.DataFrame:
    """Run a scenario at every point of a grid and return one row per point and seed.

    A row equals ``run_scenario(base, overrides={**overrides, **point}, seed=s,
    duration_s=duration_s, policy=mode).summary``: every point runs with each seed of ``seeds``
    itself, so the ``seed`` and ``point_seed`` columns are equal here (a sweep file without
    a grid seed derives ``point_seed`` from its seed and the point, [`rtsim.sweep`][rtsim.sweep]).

    Parameters
    ----------
    base : str or path
        A scenario file, or a shipped one by name (``"test2"``).
    grid : mapping
        Dotted key of the scenario file → the values to take (``{"formation.followers":
        [1, 2, 4], "sensing.r_H": [20, 25, 30]}``; a list, or a range ``"1..10"``,
        ``"10..50:10"``); every combination runs, the last key varying fastest.
    seeds : int or sequence of int
        The seeds each point runs with (default 0).
    duration_s : float, optional
        Simulated seconds of each run, exact (None: the file's ``duration``, else to the
        end of the lap, ``until = "lap"``).
    workers : int, optional
        Local processes (None: one per CPU; 1 runs here).
    out : str or path, optional
        A directory to keep the results in (``results.parquet``, one JSON file per point,
        ``manifest.json``): calling again with a grown grid runs only the new points. None:
        nothing is written (a temporary directory, removed at the end).
    mode : str, optional
        The adjustment policy of every run (as ``run_scenario``'s ``policy``).
    overrides : mapping, optional
        Dotted keys set at every point, before the grid's.
    kind, options
        Another sweep kind (``"simulate"``, ``"analyze"``, ``"bounds"`` on a task set) and
        its options (`rtsim.sweep.kinds`).
    progress, force
        A progress bar on stderr; run above the grid-size limit.

    Returns
    -------
    pandas.DataFrame
        One row per point: the grid's columns, ``seed``, ``point_seed``, ``status``
        (``ok`` or ``failed``, with ``error``), then the run's summary, flattened
        (``violations_beyond_5pct.separation``, ``missed``, ``tracks_lost`` …).
    """
    import tempfile
    from pathlib import Path

    seed_list = [seeds] if is_int(seeds) else list(seeds)  # type: ignore[arg-type]
    if not seed_list or not all(is_int(s) and 0 <= s < 2**63 for s in seed_list):
        raise InputError(f"run_sweep: seeds: expected non-negative integers, got {seeds!r}")
    if not isinstance(grid, Mapping) or not grid:
        raise InputError(
            "run_sweep: grid: expected a mapping of dotted keys to values, such as "
            "{'formation.followers': [1, 2], 'sensing.r_H': [20, 30]}"
        )
    if "seed" in grid:
        raise InputError("run_sweep: grid: give the seeds as seeds=[...], not in the grid")
    table: dict[str, Any] = {"kind": kind, "options": dict(options or {})}
    if duration_s is not None:
        table["options"]["duration"] = duration_s
    if mode is not None:
        table["options"]["mode"] = mode
    if overrides:
        table["set"] = dict(overrides)
    where = Path(os.fspath(base))
    table["base"] = str(where.resolve()) if where.exists() else os.fspath(base)
    values = {k: v if isinstance(v, str) else list(v) for k, v in grid.items()}
    data = {"sweep": table, "grid": {**values, "seed": [int(s) for s in seed_list]}}
    import json

    text = json.dumps(data, default=str)
    spec = parse_sweep(data, "run_sweep", Path.cwd(), text)
    if out is not None:
        return Sweep(spec, out, force=force).run(workers=workers, progress=progress).table
    with tempfile.TemporaryDirectory(prefix="rtsim-sweep-") as tmp:
        return Sweep(spec, tmp, force=force).run(workers=workers, progress=progress).table
