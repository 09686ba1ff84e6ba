"""Scenario files: the paper's two tests load; bad values give one-line ScenarioErrors."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from rtsim.config.scenario import load_scenario
from rtsim.errors import ScenarioError

ROOT = Path(__file__).resolve().parents[2]
SCEN = ROOT / "experiments" / "scenarios"

BASE = """
name = "t"
taskset = "barrel_robots"
[leader]
speed = 25
path = [ {straight = 600}, {turn = "left", radius = 200, angle_deg = 180},
         {straight = 600}, {turn = "left", radius = 200, angle_deg = 180} ]
[formation]
followers = 2
separation = 390
bearing_offset_deg = 15
"""


def write(tmp_path: Path, text: str, name: str = "bad.toml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    ("name", "v", "r_t", "rho"), [("test1", 25, 200, 390), ("test2", 30, 120, 325)]
)
def test_paper_scenarios_load(name: str, v: float, r_t: float, rho: float) -> None:
    s = load_scenario(SCEN / f"{name}.toml")
    w = s.world
    assert s.name == name and s.n == 2
    assert w.leader_speed == v
    assert w.formation.rho_d == (rho, rho)
    assert sorted(round(math.degrees(b), 9) for b in w.formation.beta_d) == [165, 195]
    turns = [seg for seg in w.path.segments if seg.kind == "turn"]
    assert turns and all(seg.radius == r_t for seg in turns)
    assert s.until == "lap" and s.duration == 0  # to the end of the lap, followers included
    assert w.thresholds.T_beta == pytest.approx(math.radians(5))
    ts = s.load_taskset()
    assert ts.window is not None and ts.window.n == 2 and ts.window.r_H == 25
    # every value the paper does not give has a reason
    for key in (
        "follower.max_speed",
        "follower.control_offset",
        "thresholds.T_rho",
        "thresholds.T_eps",
        "thresholds.T_beta_deg",
        "sensing.r_reacq",
        "sensing.position_noise",
        "adjust.cap",
        "adjust.floor",
    ):
        assert s.assumptions[key].strip()


def test_minimal_file_defaults(tmp_path: Path) -> None:
    s = load_scenario(write(tmp_path, BASE, "ok.toml"))
    lap = 1200 + 2 * math.pi * 200
    assert s.world.path.lap_length == pytest.approx(lap)
    assert s.duration == 0 and s.until == "lap"  # no duration: to the end of the lap
    # the recommended model (issue 34): the localization bound follows the predicted centre
    assert s.world.follower.radius == 25 and s.world.thresholds.localization == "predicted"
    assert s.adjust.cap == math.inf and s.adjust.floor == 0 and s.adjust.predictor == "commands"


def test_slots_shape_and_degrees(tmp_path: Path) -> None:
    text = BASE.replace(
        """followers = 2
separation = 390
bearing_offset_deg = 15
""",
        """[[formation.slot]]
rho_d = 300
beta_d_deg = 200
[[formation.slot]]
rho_d = 500
beta = 3.0
""",
    ).replace(
        """path = [ {straight = 600}, {turn = "left", radius = 200, angle_deg = 180},
         {straight = 600}, {turn = "left", radius = 200, angle_deg = 180} ]""",
        """shape = {kind = "rounded_rectangle", length = 500, width = 0, radius = 100}
start = {x = 10, y = -5, heading_deg = 90}""",
    )
    text = text.replace("beta = 3.0", "beta_d = 3.0")
    s = load_scenario(write(tmp_path, text, "ok.toml"))
    assert s.world.formation.rho_d == (300, 500)
    assert s.world.formation.beta_d == pytest.approx((math.radians(200), 3.0))
    assert s.world.path.start == pytest.approx((10, -5, math.pi / 2))
    assert s.world.path.lap_length == pytest.approx(1000 + 2 * math.pi * 100)


@pytest.mark.parametrize(
    ("old", "new", "match"),
    [
        (
            "radius = 200, angle_deg = 180},\n",
            "radius = -200, angle_deg = 180},\n",
            r"^.*bad\.toml: leader\.path\[2\]: radius: must be positive, got -200$",
        ),
        ("speed = 25", "speed = 0", r"^.*bad\.toml: leader\.speed: must be positive, got 0$"),
        (
            '{turn = "left", radius = 200, angle_deg = 180},\n',
            '{turn = "left", radius = 200, angle_deg = 0},\n',
            r"^.*bad\.toml: leader\.path\[2\]: angle_deg: must be positive",
        ),
        (
            "bearing_offset_deg = 15",
            "bearing_offset_deg = 0.5",
            r"^.*bad\.toml: formation: followers 1 and 2 are .* \(on top of each other\)$",
        ),
        (
            "separation = 390",
            "separation = 30",
            r"^.*bad\.toml: formation\.slot\[1\] is 30 cm from the leader",
        ),
        (
            "{straight = 600}, {turn",
            "{straight = 500}, {turn",
            r"^.*bad\.toml: leader\.path: path does not close",
        ),
        (
            "speed = 25",
            "speed = 25\nsped = 3",
            r"^.*bad\.toml: leader: unknown key 'sped' \(did you mean 'speed'\?\)$",
        ),
        (
            "[formation]",
            "[formaton]\nx = 1\n[formation]",
            r"^.*bad\.toml: unknown key 'formaton' \(did you mean 'formation'\?\)$",
        ),
        (
            "followers = 2",
            "followers = 2.5",
            r"^.*bad\.toml: formation\.followers: must be an integer",
        ),
        (
            'taskset = "barrel_robots"',
            'taskset = "nowhere.toml"',
            r"^.*bad\.toml: taskset: file not found: .*nowhere\.toml$",
        ),
        (
            "speed = 25",
            'speed = 25\nshape = {kind = "rounded_rectangle", length = 1, width = 1, radius = 1}',
            r"^.*bad\.toml: leader: give exactly one of 'path' or 'shape'$",
        ),
        (
            "{straight = 600}, {turn",
            '{straight = 600, turn = "left"}, {turn',
            r"^.*bad\.toml: leader\.path\[1\]: a segment is either straight or turn",
        ),
        (
            '{turn = "left", radius = 200, angle_deg = 180},\n',
            '{turn = "up", radius = 200, angle_deg = 180},\n',
            r"^.*bad\.toml: leader\.path\[2\]: turn: must be 'left' or 'right'",
        ),
    ],
)
def test_bad_values_one_line(tmp_path: Path, old: str, new: str, match: str) -> None:
    assert old in BASE
    with pytest.raises(ScenarioError, match=match) as info:
        load_scenario(write(tmp_path, BASE.replace(old, new, 1)))
    assert "\n" not in str(info.value)


@pytest.mark.parametrize(
    ("extra", "match"),
    [
        ("[follower]\nradius = -25\n", r"^.*bad\.toml: follower\.radius: must be positive"),
        (
            "[follower]\nmax_acel = 3\n",
            r"^.*bad\.toml: follower: unknown key 'max_acel' \(did you mean 'max_accel'\?\)$",
        ),
        ("[sensing]\nr_H = 0\n", r"^.*bad\.toml: sensing\.r_H: must be positive, got 0$"),
        ("[sensing]\nr_reacq = 10\n", r"^.*bad\.toml: sensing\.r_reacq: 10 must be >= r_H"),
        ("[sensing]\nposition_noise = -1\n", r"sensing\.position_noise: must be non-negative"),
        ("[thresholds]\nT_rho = 0\n", r"^.*bad\.toml: thresholds\.T_rho: must be positive"),
        (
            "[thresholds]\nT_beta = 0.1\nT_beta_deg = 5\n",
            r"^.*bad\.toml: thresholds: give T_beta or T_beta_deg, not both$",
        ),
        (
            '[thresholds]\nlocalization = "round"\n',
            r"thresholds\.localization: must be one of radial, full, predicted, got 'round'",
        ),
        ('[ekf]\nbackend = "gpu"\n', r"^.*bad\.toml: ekf\.backend: must be 'filterpy' or 'fast'"),
        ("[adjust]\ncap = -1\n", r"^.*bad\.toml: adjust\.cap: must be positive"),
        ("[adjust]\nfloor = 40\n", r"^.*bad\.toml: adjust\.floor: 40 cm/s is above"),
        (
            '[adjust]\npredictor = "hybird"\n',
            r"^.*bad\.toml: adjust\.predictor: must be one of paper, formation, hybrid, "
            r"commands or 'package\.module:Name', got "
            r"'hybird' \(did you mean 'hybrid'\?\)$",
        ),
        ("[adjust]\npredictor = 3\n", r"^.*bad\.toml: adjust\.predictor: must be one of"),
        (
            '[adjust]\npredictr = "hybrid"\n',
            r"^.*bad\.toml: adjust: unknown key 'predictr' \(did you mean 'predictor'\?\)$",
        ),
        (
            '[adjust]\nmodel = "hybrid"\n',
            r"^.*bad\.toml: adjust: unknown key 'model' \(renamed; did you mean 'predictor'\?\)$",
        ),
        (
            '[adjust]\npredictor = "estimate"\n',
            r"^.*bad\.toml: adjust\.predictor: .*'estimate' was renamed; did you mean 'paper'\?",
        ),
        ("[assumptions]\nx = 3\n", r"^.*bad\.toml: assumptions\.x: must be a non-empty string"),
        ("[world]\nstep_ms = 0\n", r"^.*bad\.toml: world\.step_ms: must be positive"),
    ],
)
def test_bad_sections_one_line(tmp_path: Path, extra: str, match: str) -> None:
    with pytest.raises(ScenarioError, match=match) as info:
        load_scenario(write(tmp_path, BASE + extra))
    assert "\n" not in str(info.value)


def test_duration_and_malformed(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match=r"^.*bad\.toml: duration: must be positive"):
        load_scenario(write(tmp_path, "duration = -3\n" + BASE))
    with pytest.raises(ScenarioError, match=r"^.*bad\.toml: malformed TOML"):
        load_scenario(write(tmp_path, BASE + "[[["))
    with pytest.raises(ScenarioError, match=r"^.*bad\.toml: formation: missing \(required\)$"):
        load_scenario(write(tmp_path, BASE.split("[formation]")[0]))
    with pytest.raises(ScenarioError, match="missing.toml: no such scenario file$"):
        load_scenario(tmp_path / "missing.toml")


def test_relative_taskset_path(tmp_path: Path) -> None:
    (tmp_path / "sets").mkdir()
    src = (ROOT / "tasksets" / "barrel_robots.toml").read_text()
    (tmp_path / "sets" / "mine.toml").write_text(src)
    s = load_scenario(
        write(tmp_path, BASE.replace('"barrel_robots"', '"sets/mine.toml"'), "ok.toml")
    )
    assert Path(s.taskset) == tmp_path / "sets" / "mine.toml"
    assert s.load_taskset().window.n == 2


def test_packaged_scenarios_equal_the_experiment_files(tmp_path, monkeypatch) -> None:
    """The paper's scenarios ship with rtsim (by name) and equal experiments/scenarios/."""
    from pathlib import Path

    from rtsim.config.scenario import PACKAGED_SCENARIOS, load_scenario, scenario_bytes

    root = Path(__file__).resolve().parents[2]
    monkeypatch.chdir(tmp_path)  # no file called test1 here: the name means the packaged one
    for name in PACKAGED_SCENARIOS:
        raw, _ = scenario_bytes(name)
        assert raw == (root / "experiments" / "scenarios" / f"{name}.toml").read_bytes()
        assert load_scenario(name).name == name
