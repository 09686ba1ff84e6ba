"""Strict JSON out, numpy scalars and paths in (issue 13, item 4)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rtsim.analysis.bounds import w_rta, w_sch_of, w_susp, window_bounds
from rtsim.analysis.rta import analyze
from rtsim.cli import main
from rtsim.config.taskset import load_taskset
from rtsim.errors import InputError, TaskSetError
from rtsim.io.atomic import NonFiniteJSON, dumps, write_json
from rtsim.model.task import Task
from rtsim.model.taskset import TaskSet
from rtsim.sim import simulate

ROOT = Path(__file__).resolve().parents[2]
PAPER = ROOT / "tasksets" / "barrel_robots.toml"


def strict_load(path: Path) -> object:
    def refuse(name: str) -> None:
        raise ValueError(f"{path}: non-strict JSON constant {name}")

    return json.loads(path.read_text("utf-8"), parse_constant=refuse)


# -- strict JSON ----------------------------------------------------------------------
@settings(max_examples=50, deadline=None)
@given(
    st.recursive(
        st.one_of(st.floats(), st.integers(), st.text(max_size=3), st.none()),
        lambda kids: st.one_of(
            st.lists(kids, max_size=3),
            st.dictionaries(st.text("abc", min_size=1, max_size=2), kids, max_size=3),
        ),
        max_leaves=8,
    )
)
def test_dumps_writes_strict_json_or_names_the_non_finite_value(obj: object) -> None:
    try:
        text = dumps(obj)
    except NonFiniteJSON as exc:
        assert "non-finite number at " in str(exc)
        return
    json.loads(text, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c)))


def test_dumps_names_the_path_of_a_nan(tmp_path: Path) -> None:
    with pytest.raises(NonFiniteJSON, match=r"at a\.b\[1\]"):
        write_json(tmp_path / "x.json", {"a": {"b": [1.0, math.nan]}})
    assert not (tmp_path / "x.json").exists()
    assert json.loads(dumps({"x": np.float32(0.5), "n": np.int64(3)})) == {"x": 0.5, "n": 3}


def test_a_short_scenario_writes_strict_summary_and_manifest(tmp_path: Path) -> None:
    out = tmp_path / "o"
    assert main(["scenario", "test1", "--duration", "0.05", "--out", str(out), "--no-figures"]) == 0
    summary = strict_load(out / "summary.json")
    assert isinstance(summary, dict) and summary["windows"] == 0
    assert summary["min_msb_over_wsch"] is None and summary["max_response"] is None
    manifest = strict_load(out / "manifest.json")
    assert isinstance(manifest, dict)
    assert manifest["inputs"]["scenario"]["follower"]["max_turn_rate"] is None  # no limit


def test_simulate_json_and_jobs_manifest_are_strict(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["simulate", str(PAPER), "--horizon", "2000", "--json"]) == 0
    json.loads(
        capsys.readouterr().out, parse_constant=lambda c: (_ for _ in ()).throw(ValueError(c))
    )


# -- numpy scalars --------------------------------------------------------------------
@pytest.mark.parametrize("cast", [np.int64, np.int32, np.float32, np.float64, np.uint16])
def test_numpy_scalars_are_numbers(cast: type) -> None:
    t = Task("t", wcet=cast(5), period=cast(40), priority=np.int64(1))
    assert t.wcet == 5.0 and type(t.wcet) is float and type(t.priority) is int
    ts = load_taskset().with_window(n=np.int64(3), r_H=cast(25))
    assert ts.window is not None and ts.window.n == 3 and type(ts.window.n) is int
    res = simulate(TaskSet((t,)), cast(400), seed=np.int64(2))
    assert res.tasks["t"].completed == 10
    assert analyze(ts, w=cast(400)).tasks


def test_numpy_bools_are_not_numbers() -> None:
    with pytest.raises(TaskSetError, match="wcet"):
        Task("t", wcet=np.bool_(True), period=40)


# -- paths in public functions ------------------------------------------------------
def test_the_top_level_functions_accept_a_path() -> None:
    """rtsim.analyze, rtsim.window_bounds and rtsim.simulate read a task-set file (the
    configuration layer's loader, above the analysis and the simulator); the top-level
    analyze adds the offset-based bounds, as ``rtsim analyze`` does."""
    import rtsim
    from rtsim.analysis.transaction import with_transaction_bounds

    ref = load_taskset(PAPER)
    for arg in (PAPER, str(PAPER)):
        assert rtsim.analyze(arg) == with_transaction_bounds(ref, analyze(ref))
        assert rtsim.window_bounds(arg) == window_bounds(ref)
        assert rtsim.simulate(arg, 500.0).tasks == simulate(ref, 500.0).tasks


@pytest.mark.parametrize(
    "fn", [analyze, w_sch_of, w_rta, w_susp, window_bounds, lambda p: simulate(p, 500.0)]
)
def test_the_layers_take_task_sets_not_paths(fn: object) -> None:
    """The analysis and the simulator take task sets: a path is a one-line error saying how to
    read it (they never import the file loader)."""
    for arg in (PAPER, str(PAPER)):
        with pytest.raises(
            TaskSetError,
            match=r"expected a TaskSet, got the path .*"
            r"read the file with rtsim\.load_taskset",
        ):
            fn(arg)  # type: ignore[operator]


@pytest.mark.parametrize(
    "fn", [analyze, w_sch_of, w_rta, w_susp, window_bounds, lambda p: simulate(p, 500.0)]
)
@pytest.mark.parametrize("bad", [None, 3, {"tasks": []}, b"file.toml"])
def test_public_functions_refuse_other_things_with_an_input_error(fn: object, bad: object) -> None:
    with pytest.raises(InputError):
        fn(bad)  # type: ignore[operator]


def test_a_missing_file_names_the_file() -> None:
    import rtsim

    with pytest.raises(TaskSetError, match="nope.toml: no such file"):
        rtsim.analyze("nope.toml")  # the top level reads files; rtsim.analysis takes task sets
    with pytest.raises(
        TaskSetError,
        match=r"analyze: expected a TaskSet, got the path "
        r"'nope.toml' \(read the file with "
        r"rtsim.load_taskset\)",
    ):
        analyze("nope.toml")


def test_simulate_refuses_a_horizon_out_of_range_at_once() -> None:
    with pytest.raises(InputError, match=r"simulate: horizon: 1e\+15 ms is outside"):
        simulate(load_taskset(PAPER), 1e15)


@pytest.mark.parametrize(
    ("changes", "key"),
    [({"r_H": 1e154}, "r_H"), ({"n": 10**6}, "n"), ({"n": np.int64(10**6)}, "n")],
)
def test_window_changes_out_of_range_name_the_key(changes: dict[str, float], key: str) -> None:
    with pytest.raises(TaskSetError, match=rf"window 'window': {key}: .* is outside"):
        window_bounds(load_taskset(PAPER), **changes)  # type: ignore[arg-type]
