"""What a process reuses across a sweep's points — the base file's parse, the task sets built,
the settled start speed — is keyed by the values it depends on, bounded, and changes no
result: the same grid gives the same bytes whatever the order its points run in, the number
of workers and what the process prepared before."""

from __future__ import annotations

import json
import random
import tomllib
from pathlib import Path

import pytest

import rtsim.config.scenario as scenario_mod
import rtsim.coupling.prepared as prepared_mod
import rtsim.sweep.base as base_mod
from rtsim.config.scenario import load_scenario
from rtsim.control.oracle import start_speed
from rtsim.coupling.prepared import settled_speed
from rtsim.sweep import load_sweep, run_sweep
from rtsim.sweep.base import BaseFile
from rtsim.sweep.grid import point_input, points
from rtsim.sweep.kinds import forget_prepared
from rtsim.sweep.point import execute_point

ROOT = Path(__file__).resolve().parents[2]
TEST2 = ROOT / "experiments" / "scenarios" / "test2.toml"

GRID = """
[sweep]
kind = "scenario"
base = "test2"
seed = 4
[sweep.options]
duration = 3
[grid]
"formation.followers" = [1, 2]
"sensing.r_H" = [20, 30]
seed = [0, 1]
"""


def test_base_file_parsed_once_and_copied(monkeypatch: pytest.MonkeyPatch) -> None:
    text = TEST2.read_text(encoding="utf-8")
    base_mod._parsed.cache_clear()
    calls = []
    real = tomllib.loads

    def counting(s: str) -> object:
        calls.append(1)
        return real(s)

    monkeypatch.setattr(base_mod.tomllib, "loads", counting)
    a, b = BaseFile(str(TEST2), text), BaseFile(str(TEST2), text)
    first = a.data()
    assert first == real(text)
    first["leader"]["speed"] = -1.0  # a caller's change stays its own
    second = b.data()
    assert second == real(text) and second is not first
    assert len(calls) == 1  # two files of the same text, one parse
    BaseFile(None, text + "\n# another text\n").data()
    assert len(calls) == 2
    assert base_mod._parsed.cache_info().maxsize == base_mod.PARSED_MAX


def test_taskset_built_once_per_content(tmp_path: Path) -> None:
    ts_file = tmp_path / "set.toml"
    sc_file = tmp_path / "sc.toml"
    packaged = (ROOT / "rtsim" / "data" / "barrel_robots.toml").read_text("utf-8")
    ts_file.write_text(packaged, encoding="utf-8")
    text = TEST2.read_text(encoding="utf-8")
    assert 'taskset = "barrel_robots"' in text
    sc_file.write_text(text.replace('taskset = "barrel_robots"', 'taskset = "set.toml"'), "utf-8")
    scenario_mod._built_taskset.cache_clear()
    one = load_scenario(sc_file).load_taskset()
    two = load_scenario(sc_file).load_taskset()
    assert scenario_mod._built_taskset.cache_info().hits >= 1
    assert one == two
    # an edited file has other bytes: built again, and the edit shows
    edited = packaged.replace("e_send = 2 ", "e_send = 3 ")
    assert edited != packaged
    ts_file.write_text(edited, encoding="utf-8")
    three = load_scenario(sc_file).load_taskset()
    assert three.window is not None and three.window.e_send == 3.0
    assert one.window is not None and one.window.e_send == 2.0


def test_settled_speed_keyed_by_values_not_objects() -> None:
    prepared_mod.clear()
    a = load_scenario(TEST2, overrides={"formation.followers": 6}).world
    b = load_scenario(TEST2, overrides={"formation.followers": 6}).world
    assert a.path is not b.path  # two parses: two path objects, equal values
    w = 1000.0  # ms: a long window caps the start below V_Ld
    got = settled_speed(a, w)
    assert got == start_speed(a, w) < a.leader_speed
    assert len(prepared_mod._SETTLED) == 1
    assert settled_speed(b, w) == got and len(prepared_mod._SETTLED) == 1
    assert settled_speed(b, 2 * w) == start_speed(b, 2 * w) and len(prepared_mod._SETTLED) == 2
    for k in range(prepared_mod.SETTLED_MAX + 5):  # bounded
        settled_speed(a, 100.0 + k)
    assert len(prepared_mod._SETTLED) == prepared_mod.SETTLED_MAX


def test_settled_world_kept_per_object_and_window() -> None:
    """The settled start's world is the one `dataclasses.replace` makes, made once per
    configuration object and w_sch (another object of equal values: another entry, the same
    value), bounded; the window chain's task once per task set, w and Hough time."""
    from dataclasses import replace

    from rtsim.coupling.prepared import settled_world

    prepared_mod.clear()
    a = load_scenario(TEST2, overrides={"formation.followers": 6}).world
    b = load_scenario(TEST2, overrides={"formation.followers": 6}).world
    w = 1000.0
    got = settled_world(a, w)
    assert got == replace(a, start_speed=start_speed(a, w)) and got.start_speed < a.leader_speed
    assert settled_world(a, w) is got and len(prepared_mod._WORLDS) == 1
    other = settled_world(b, w)  # (its own path object: LeaderPath compares by identity)
    assert other is not got and other.path is b.path and other.start_speed == got.start_speed
    assert settled_world(a, 2 * w).start_speed == start_speed(a, 2 * w)
    for k in range(prepared_mod.SETTLED_MAX + 5):  # bounded
        settled_world(a, 100.0 + k)
    assert len(prepared_mod._WORLDS) == prepared_mod.SETTLED_MAX
    prepared_mod.clear()
    assert not prepared_mod._WORLDS

    import rtsim.model.taskset as taskset_mod
    from rtsim.config.scenario import _read_taskset

    ts = _read_taskset("barrel_robots", "test")
    one = ts.window_task(1.0)
    assert ts.window_task(1.0) is one and one == ts._window_task(1.0, None)
    assert ts.window_task(1) == ts._window_task(1, None)
    assert ts.window_task(2.0, 3.0) == ts._window_task(2.0, 3.0)
    for k in range(taskset_mod.WINDOW_TASKS_KEPT + 5):  # bounded
        ts.window_task(10.0 + k)
    assert len(taskset_mod._WINDOW_TASKS) == taskset_mod.WINDOW_TASKS_KEPT


def _metrics(recs: list[dict[str, object]]) -> bytes:
    by_index = sorted(recs, key=lambda r: int(r["index"]))  # type: ignore[call-overload]
    return json.dumps(
        [(r["index"], r["status"], r["error"], r["metrics"]) for r in by_index],
        sort_keys=True,
        allow_nan=True,
    ).encode()


def test_same_grid_same_bytes_whatever_order_and_workers(tmp_path: Path) -> None:
    spec_file = tmp_path / "grid.toml"
    spec_file.write_text(GRID, encoding="utf-8")
    spec = load_sweep(spec_file)
    inputs = [point_input(spec, p) for p in points(spec)]
    assert len(inputs) == 8
    forget_prepared()
    fresh = [execute_point(p) for p in inputs]  # each content prepared on first use
    assert all(r["status"] == "ok" for r in fresh), [r["error"] for r in fresh]
    shuffled = inputs[:]
    random.Random(7).shuffle(shuffled)
    assert shuffled != inputs
    warm = [execute_point(p) for p in shuffled]  # everything reused, in another order
    assert _metrics(warm) == _metrics(fresh)
    forget_prepared()
    again = [execute_point(p) for p in reversed(inputs)]  # prepared in reverse order
    assert _metrics(again) == _metrics(fresh)
    forget_prepared()
    run_sweep(spec_file, tmp_path / "w1", workers=1)
    run_sweep(spec_file, tmp_path / "w2", workers=2)  # workers forked with warm caches
    one = (tmp_path / "w1" / "results.parquet").read_bytes()
    assert one == (tmp_path / "w2" / "results.parquet").read_bytes()
    table = __import__("pandas").read_parquet(tmp_path / "w1" / "results.parquet")
    by_index = {int(r["index"]): r["metrics"] for r in fresh}
    for i, row in table.iterrows():
        assert row["windows"] == by_index[int(i)]["windows"]  # type: ignore[index]
        assert row["critical_share"] == by_index[int(i)]["critical_share"]  # type: ignore[index]


def test_window_bound_keyed_by_the_task_sets_values() -> None:
    from rtsim.analysis.bounds import lower_bound
    from rtsim.coupling.inputs import fitted_taskset
    from rtsim.coupling.prepared import window_bound

    prepared_mod.clear()
    sc = load_scenario(TEST2, overrides={"formation.followers": 3})
    one = fitted_taskset(sc.load_taskset(), sc.world, "t")
    scenario_mod._built_taskset.cache_clear()
    other = load_scenario(TEST2, overrides={"formation.followers": 3})
    two = fitted_taskset(other.load_taskset(), other.world, "t")
    assert one is not two and one == two
    kw = {"scheduler": "fp", "suspension": "idle", "where": "t"}
    for name in ("w_sch", "w_rta"):
        got = window_bound(one, name, **kw)
        assert got == lower_bound(one, name, **kw)
        assert window_bound(two, name, **kw) == got  # another object, equal values: kept
    assert len(prepared_mod._BOUNDS) == 2
    wider = two.with_window(r_H=two.window.r_H + 5)  # type: ignore[union-attr]
    w_sch = window_bound(wider, "w_sch", **kw)
    assert w_sch == lower_bound(wider, "w_sch", **kw) != window_bound(one, "w_sch", **kw)
    assert len(prepared_mod._BOUNDS) == 3
    with pytest.raises(Exception, match="t: lower_bound"):  # errors are not kept
        window_bound(one, "w_edf", **kw)
    assert len(prepared_mod._BOUNDS) == 3
    for k in range(prepared_mod.BOUNDS_MAX + 5):  # bounded
        window_bound(two.with_window(r_H=10.0 + k), "w_sch", **kw)  # type: ignore[union-attr]
    assert len(prepared_mod._BOUNDS) == prepared_mod.BOUNDS_MAX


def test_caches_stay_bounded_over_many_contents(tmp_path: Path) -> None:
    import rtsim.sweep.kinds as kinds

    spec_file = tmp_path / "many.toml"
    spec_file.write_text(
        '[sweep]\nkind = "scenario"\nbase = "test2"\n[sweep.options]\nduration = 0.5\n'
        '[grid]\n"sensing.r_H" = "20..43"\n',
        encoding="utf-8",
    )
    spec = load_sweep(spec_file)
    forget_prepared()
    recs = [execute_point(point_input(spec, p)) for p in points(spec)]
    assert len(recs) == 24 and all(r["status"] == "ok" for r in recs)
    assert len(kinds._PREPARED) == kinds._PREPARED_MAX < 24  # the oldest contents dropped
    assert len(prepared_mod._BOUNDS) == len(prepared_mod._SETTLED) == 24
    assert base_mod._parsed.cache_info().currsize == 1
    # the first point again, prepared anew after its eviction: the same metrics
    assert execute_point(point_input(spec, points(spec)[0]))["metrics"] == recs[0]["metrics"]


def test_run_state_kept_changes_no_result() -> None:
    """The followers' starting states on the trace and the thresholds per follower, kept
    per process by their inputs: two scenarios run in turn give what each gives alone, on
    a fresh process's state (`prepared.clear`)."""
    import pandas as pd

    import rtsim.world.world as world_mod
    from rtsim.coupling import run_scenario

    kw = {"record_jobs": False, "duration_s": 3.0}
    runs = {"a": {"formation.followers": 2}, "b": {"formation.followers": 3, "sensing.r_H": 25}}

    def one(name: str) -> tuple[str, pd.DataFrame]:
        res = run_scenario("test2", overrides=runs[name], **kw)
        assert res.windows is not None
        return json.dumps(res.summary, sort_keys=True, default=str), res.windows

    alone = {}
    for name in runs:
        prepared_mod.clear()
        assert not world_mod._INITIAL and not prepared_mod._CONSTANTS
        alone[name] = one(name)
    assert len(world_mod._INITIAL) == 1 and len(prepared_mod._CONSTANTS) == 2
    for name in ("a", "b", "a", "b"):  # each after the other's state was kept
        summary, windows = one(name)
        assert summary == alone[name][0]
        pd.testing.assert_frame_equal(windows, alone[name][1], check_exact=True)
    assert len(world_mod._INITIAL) == 2 and len(prepared_mod._CONSTANTS) == 4
