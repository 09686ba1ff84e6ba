"""Inputs refused early and clearly (issue 13, item 3): every numeric key has a range, the
docs table is the registry, extreme values exit 2 with one line naming file and key or
option, the work a command would do is refused above its limit unless --force, and the
silent-nonsense cases are errors."""

from __future__ import annotations

import argparse
import math
import tomllib
from dataclasses import fields
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rtsim.cli import build_parser, main, numeric_options
from rtsim.config.docs import ranges, render_markdown
from rtsim.config.scenario import load_scenario, parse_scenario
from rtsim.config.taskset import load_taskset, parse_taskset
from rtsim.coupling.duration import check_scenario
from rtsim.errors import InputError, ScenarioError, TaskSetError
from rtsim.io import limits
from rtsim.io.limits import UnregisteredKey, check
from rtsim.io.work import LIMITS, TooMuchWork, check_simulate, check_work
from rtsim.world.config import SensingParams
from rtsim.world.ekf import EkfParams
from rtsim.world.follower import FollowerParams

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs" / "input_ranges.md"
#: Every range: the input files' (the models' metadata) and the options'.
REGISTRY = {**ranges(), **limits.REGISTRY}


# -- the registry ---------------------------------------------------------------------
def test_docs_table_is_generated_from_the_registry() -> None:
    assert DOCS.read_text("utf-8") == render_markdown() + "\n", (
        "run: python -m rtsim.config.docs > docs/input_ranges.md"
    )


def _numeric_fields(cls: type) -> list[str]:
    return [f.name for f in fields(cls) if f.type in ("float", "int")]


def test_every_numeric_key_of_the_models_has_a_range() -> None:
    """Walk the models: every int or float field carries a range (its metadata)."""
    import typing

    from pydantic import BaseModel

    from rtsim.config.docs import _leaves
    from rtsim.config.scenario import ScenarioFile
    from rtsim.config.taskset import TaskSetFile

    missing = []

    def walk(model: type[BaseModel], prefix: str) -> None:
        for name, info in model.model_fields.items():
            leaves, models = _leaves(info.annotation)
            leaves += [m for m in info.metadata if hasattr(m, "range")]
            plain = {a for a in typing.get_args(info.annotation) or (info.annotation,)}
            numeric = plain & {int, float} or any(
                typing.get_origin(a) is typing.Annotated and a.__origin__ in (int, float)
                for a in plain
            )
            if numeric and not any(leaf.range for leaf in leaves):
                missing.append(prefix + name)
            for sub in models:
                walk(sub, f"{prefix}{name}.")

    walk(TaskSetFile, "taskset: ")
    walk(ScenarioFile, "scenario: ")
    assert not missing, f"give these a range (rtsim/config): {missing}"
    for table, cls in (
        ("follower", FollowerParams),
        ("ekf", EkfParams),
        ("sensing", SensingParams),
    ):
        names = _numeric_fields(cls)
        assert names, cls
        gaps = [k for k in names if f"scenario: {table}.{k}" not in REGISTRY]
        assert not gaps, gaps
    keys = [
        f"scenario: {k}"
        for k in (
            "duration",
            "leader.speed",
            "leader.accel_max",
            "leader.decel_max",
            "leader.start_s",
            "leader.start.x",
            "leader.start.y",
            "leader.start.heading",
            "leader.path.straight",
            "leader.path.radius",
            "leader.path.angle",
            "leader.shape.length",
            "leader.shape.width",
            "leader.shape.radius",
            "formation.followers",
            "formation.separation",
            "formation.bearing_offset",
            "formation.slot.rho_d",
            "formation.slot.beta_d",
            "sensing.r_H",
            "thresholds.T_rho",
            "thresholds.T_eps",
            "thresholds.T_beta",
            "adjust.cap",
            "adjust.floor",
            "world.step_ms",
        )
    ]
    keys += [
        f"taskset: tasks.{k}"
        for k in ("wcet", "bcet", "period", "deadline", "offset", "jitter", "priority")
    ]
    keys += [f"taskset: window.{k}" for k in ("n", "r_H", "k", "e_scan", "delta_t")]
    assert not [k for k in keys if k not in REGISTRY]


def test_every_numeric_option_of_every_command_has_a_range() -> None:
    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = []
    for command in sub.choices:
        for action in numeric_options(parser, command):
            name = max(action.option_strings, key=len)
            if f"option: {name}" not in REGISTRY:
                missing.append(f"{command} {name}")
    assert not missing, f"register these in rtsim/io/limits.py: {missing}"


def test_every_range_is_finite_and_ordered() -> None:
    for r in REGISTRY.values():
        assert math.isfinite(r.lo) and math.isfinite(r.hi) and r.lo <= r.hi, r
        assert r.why, r


def test_strict_mode_refuses_a_numeric_key_without_a_range(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("RTSIM_STRICT_RANGES", "1")
    with pytest.raises(UnregisteredKey, match="no_such.key"):
        check("scenario: no_such.key", 1.0, "f.toml: no_such.key")
    check("scenario: no_such.key", "text", "f.toml: no_such.key")  # not a number: no range
    monkeypatch.setenv("RTSIM_STRICT_RANGES", "0")
    check("scenario: no_such.key", 1.0, "f.toml: no_such.key")


def test_the_packaged_inputs_are_inside_every_range() -> None:
    for name in ("test1", "test2"):
        load_scenario(name)
    load_taskset()
    load_taskset(ROOT / "tasksets" / "example.toml")


# -- files: hypothesis over the registered keys -------------------------------------
_SCENARIO_KEYS = sorted(
    k.split(": ", 1)[1]
    for k in REGISTRY
    if k.startswith("scenario: ")
    and k.split(": ", 1)[1]
    in {
        "duration",
        "leader.speed",
        "formation.separation",
        "follower.radius",
        "follower.max_speed",
        "follower.max_accel",
        "follower.control_offset",
        "follower.gain_rho",
        "follower.speed_noise",
        "sensing.r_H",
        "sensing.r_reacq",
        "sensing.position_noise",
        "sensing.max_range",
        "ekf.measurement_noise",
        "ekf.speed_noise",
        "ekf.position_drift",
        "ekf.init_position_sd",
        "thresholds.T_rho",
        "thresholds.T_eps",
        "leader.shape.length",
        "leader.shape.width",
        "leader.shape.radius",
    }
)


def _outside(r: limits.Range, factor: float, below: bool) -> float:
    if below:
        return r.lo - (abs(r.lo) + 1.0) * factor if not r.lo_open else r.lo - abs(r.lo) * factor
    return r.hi + (abs(r.hi) + 1.0) * factor


@settings(max_examples=80, deadline=None)
@given(key=st.sampled_from(_SCENARIO_KEYS), factor=st.floats(1e-6, 1e290), below=st.booleans())
def test_a_scenario_value_outside_its_range_is_one_error_naming_file_and_key(
    key: str, factor: float, below: bool
) -> None:
    r = REGISTRY[f"scenario: {key}"]
    value = _outside(r, factor, below)
    if r.lo_open and below and value == r.lo:
        value = r.lo  # (0, ...]: zero itself is outside
    data = tomllib.loads((ROOT / "experiments" / "scenarios" / "test2.toml").read_text())
    node: Any = data
    *path, leaf = key.split(".")
    for p in path:
        node = node[p]
    node[leaf] = value
    with pytest.raises(ScenarioError) as exc:
        parse_scenario(data, "test2.toml", ROOT / "experiments" / "scenarios")
    msg = str(exc.value)
    assert msg.startswith("test2.toml: ") and "\n" not in msg
    assert leaf in msg, msg


_TASK_KEYS = ["wcet", "period", "deadline", "offset", "jitter"]


@settings(max_examples=60, deadline=None)
@given(
    key=st.sampled_from(
        _TASK_KEYS + ["window.r_H", "window.n", "window.e_cal", "window.delta_t", "overhead"]
    ),
    exponent=st.integers(10, 300),
)
def test_a_task_set_value_far_out_of_range_is_one_error_naming_file_and_key(
    key: str, exponent: int
) -> None:
    data = tomllib.loads(
        (resources.files("rtsim") / "data" / "barrel_robots.toml").read_text("utf-8")
    )
    value: float | int = 10.0**exponent
    if key == "window.n":
        value = 10 ** min(exponent, 30)
    if key.startswith("window."):
        data["window"][key.split(".")[1]] = value
    elif key == "overhead":
        data["overhead"] = value
    else:
        data["tasks"][0][key] = value
        data["tasks"][0].pop("deadline", None) if key == "period" else None
    with pytest.raises(TaskSetError) as exc:
        parse_taskset(data, "set.toml")
    msg = str(exc.value)
    assert msg.startswith("set.toml: ") and "\n" not in msg
    assert key.split(".")[-1] in msg, msg


def _scenario_file(tmp_path: Path, **changes: str) -> Path:
    text = (ROOT / "experiments" / "scenarios" / "test2.toml").read_text("utf-8")
    for old, new in changes.items():
        assert old in text, old
        text = text.replace(old, new)
    p = tmp_path / "s.toml"
    p.write_text(text, encoding="utf-8")
    return p


@pytest.mark.parametrize(
    ("old", "new", "key"),
    [
        ('until = "lap"', "duration = 1e300", "duration"),
        ("step_ms = 10", "step_ms = 1e-300", "world.step_ms"),
        ("r_H = 25 ", "r_H = 1e154 ", "sensing.r_H"),
        ("speed = 30 ", "speed = 30\nstart_s = 1e300 ", "leader.start_s"),
        ("speed = 30 ", "speed = 30\nstart_s = 5000 ", "leader.start_s"),  # beyond one lap
        ("radius = 120", "radius = 1e-9", "leader.shape.radius"),
        ("max_speed = 150", "max_speed = 20", "leader.speed"),  # leader faster than followers
        ("separation = 325", "separation = 0", "formation"),
    ],
)
def test_extreme_and_nonsense_scenarios_exit_2_with_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, key: str
) -> None:
    path = _scenario_file(tmp_path, **{old: new})
    assert main(["scenario", str(path), "--out", str(tmp_path / "o"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"rtsim: {path}: "), err
    assert key in err, err


@pytest.mark.parametrize(
    ("argv", "name"),
    [
        (["analyze", "/dev/zero"], "/dev/zero"),
        (["simulate", "{ts}", "--horizon", "1e15"], "--horizon"),
        (["simulate", "{ts}", "--horizon", "1000", "--window", "1e-9"], "--window"),
        (["simulate", "{ts}", "--horizon", "1000", "--followers", "1000000"], "--followers"),
        (["simulate", "{ts}", "--horizon", "1000", "--hough-radius", "1e154"], "--hough-radius"),
        (["bounds", "{ts}", "--hough-radius", "1e154"], "--hough-radius"),
        (["bounds", "{ts}", "--followers", "1..2000"], "--followers"),
        (["analyze", "{ts}", "--window", "1e-9"], "--window"),
        (["scenario", "test2", "--duration", "1e300", "--out", "{tmp}"], "--duration"),
        (["simulate", "{tiny}", "--horizon", "1e6"], "--horizon"),
        (["simulate", "{tiny_file}", "--horizon", "1000"], "period"),
    ],
)
def test_extreme_command_lines_exit_2_with_one_line_naming_the_input(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], argv: list[str], name: str
) -> None:
    tiny = tmp_path / "tiny.toml"
    tiny.write_text('[[tasks]]\nname = "t"\nwcet = 0.0001\nperiod = 0.001\n')
    tiny_file = tmp_path / "tiny_file.toml"
    tiny_file.write_text('[[tasks]]\nname = "t"\nwcet = 1e-300\nperiod = 1e-290\n')
    subs = {
        "{ts}": str(ROOT / "tasksets" / "barrel_robots.toml"),
        "{tmp}": str(tmp_path / "o"),
        "{tiny}": str(tiny),
        "{tiny_file}": str(tiny_file),
    }
    argv = [subs.get(a, a) for a in argv]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("rtsim: ") and name in err, err


# -- work limits ----------------------------------------------------------------------
def test_work_above_a_limit_is_refused_and_force_overrides() -> None:
    with pytest.raises(
        TooMuchWork,
        match=r"--horizon 1e\+12: about .* jobs, above the "
        r"limit of 5e\+07; use --force",
    ):
        check_work("jobs", 6e7, "--horizon 1e+12")
    assert check_work("jobs", 6e7, "--horizon 1e+12", force=True) == 6e7
    with pytest.raises(TooMuchWork, match="never finish"):
        check_work("jobs", math.inf, "x", force=True)


def test_default_limits_admit_the_long_benchmarks() -> None:
    from rtsim.analysis.bounds import w_sch_of

    ts = load_taskset()
    check_simulate(ts, 24 * 3600e3, w_sch_of(ts), "--horizon")  # 24 h simulate --jobs
    check_scenario(load_scenario("test2"), 6 * 3600.0, "--duration")  # 6 h coupled Test 2
    with pytest.raises(TooMuchWork, match="processing windows"):
        check_scenario(load_scenario("test2"), 1e6, "--duration")


def test_simulate_force_runs_above_the_jobs_limit(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(LIMITS, "jobs", 10)
    ts = str(ROOT / "tasksets" / "barrel_robots.toml")
    assert main(["simulate", ts, "--horizon", "1000"]) == 2
    assert "--force" in capsys.readouterr().err
    assert main(["simulate", ts, "--horizon", "1000", "--force"]) == 0


def test_scenario_work_limit_names_the_duration(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setitem(LIMITS, "world_steps", 10)
    assert main(["scenario", "test2", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert "test2: duration" in err and "world steps x followers" in err and "--force" in err


def test_sweep_option_out_of_range_is_refused_at_load(tmp_path: Path) -> None:
    from rtsim.sweep import load_sweep

    spec = tmp_path / "s.toml"
    spec.write_text(
        '[sweep]\nkind = "simulate"\n[sweep.options]\nhorizon = 1e15\n[grid]\nn = "1..2"\n'
    )
    with pytest.raises(
        InputError,
        match=r"s.toml: sweep.options.horizon: 1e\+15 ms is "
        r"outside",
    ):
        load_sweep(spec)


def test_an_error_raised_inside_a_run_names_the_scenario_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import rtsim.coupling

    def fails(*args: object, **kwargs: object) -> None:
        raise InputError("FollowerEstimate: rho must be positive, got 0.0")

    monkeypatch.setattr(rtsim.coupling, "run_scenario", fails)
    assert main(["scenario", "test1", "--out", str(tmp_path / "o"), "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "rtsim: test1.toml: during the run (seed 0): FollowerEstimate: rho must be "
        "positive, got 0.0\n"
    )


_SIM_OPTIONS = ["--horizon", "--seed", "--overhead", "--followers", "--hough-radius", "--window"]


@settings(max_examples=60, deadline=None)
@given(option=st.sampled_from(_SIM_OPTIONS), exponent=st.integers(1, 300), below=st.booleans())
def test_a_simulate_option_out_of_range_exits_2_naming_it(
    option: str, exponent: int, below: bool
) -> None:
    import contextlib
    import io

    r = REGISTRY[f"option: {option}"]
    integer = option in ("--seed", "--followers")
    if below:
        value: float = r.lo - 10.0**exponent if r.lo <= 0 else r.lo / 10.0**exponent
    else:
        value = (
            r.hi + 10.0 ** min(exponent, 300) * max(abs(r.hi), 1.0)
            if r.hi * 10.0**exponent < 1e308
            else 1e308
        )
    if value == r.hi or (below and value == r.lo):
        return
    text = str(int(value)) if integer else repr(value)
    if integer and int(value) == value and r.admits(int(value)):
        return
    err = io.StringIO()
    argv = [
        "simulate",
        str(ROOT / "tasksets" / "barrel_robots.toml"),
        "--horizon",
        "100",
        f"{option}={text}",
    ]  # (= so that a negative value is not read as an option)
    with contextlib.redirect_stderr(err):
        code = main(argv)
    assert code == 2, (argv, err.getvalue())
    assert err.getvalue().count("\n") == 1 and option in err.getvalue(), err.getvalue()
