"""The recommended model is the default, the paper's one key away, and ``duration`` means what
it says (issue 34, items 1 and 2)."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from rtsim.config.scenario import PRESETS, load_scenario
from rtsim.coupling.duration import LAP_CAP_FACTOR, run_length, run_note

ROOT = Path(__file__).resolve().parents[2]
PIN = ROOT / "tests" / "data" / "policy_pin"

#: what a newcomer writes from the docs: a leader and a formation, nothing else
MINIMAL = """
[leader]
speed = 30
shape = { kind = "rounded_rectangle", length = 800, width = 400, radius = 120 }
[formation]
followers = 2
separation = 325
"""


def _choices(s: object) -> dict[str, object]:
    """The model's choices of a loaded scenario (every categorical key the file can set)."""
    w = s.world  # type: ignore[attr-defined]
    a = s.adjust  # type: ignore[attr-defined]
    return {
        "formation.model": w.formation.model,
        "adjust.policy": a.policy,
        "adjust.predictor": a.predictor,
        "adjust.decide": a.decide,
        "adjust.lower_bound": a.lower_bound,
        "localization.centre": w.localization.centre,
        "localization.search": w.localization.search,
        "localization.model": w.localization.model,
        "thresholds.localization": w.thresholds.localization,
        "ekf.backend": w.ekf.backend,
        "world.backend": w.backend,
        "scheduler": s.scheduler,  # type: ignore[attr-defined]
        "until": s.until,  # type: ignore[attr-defined]
    }


def _write(tmp_path: Path, text: str, name: str = "mine.toml") -> Path:
    p = tmp_path / name
    p.write_text(text, encoding="utf-8")
    return p


def test_a_minimal_scenario_resolves_to_test2s_choices(tmp_path: Path) -> None:
    mine = load_scenario(_write(tmp_path, MINIMAL))
    shipped = load_scenario("test2")
    assert _choices(mine) == _choices(shipped)
    # the values the recommended preset names, as test2 writes them
    assert _choices(mine)["adjust.policy"] == "plan"
    assert _choices(mine)["adjust.predictor"] == "commands"
    assert _choices(mine)["formation.model"] == "follow-the-leader"
    assert (_choices(mine)["localization.centre"], _choices(mine)["localization.search"]) == (
        "predicted",
        "visible",
    )


def test_the_default_layout_is_the_fan(tmp_path: Path) -> None:
    # four followers: the fan keeps every follower at rho_d; the line puts ranks behind
    four = MINIMAL.replace("followers = 2", "followers = 4")
    fan = load_scenario(_write(tmp_path, four)).world.formation
    line = load_scenario(_write(tmp_path, four + 'layout = "line"\n', "line.toml")).world.formation
    assert fan.rho_d == (325.0,) * 4
    assert fan != line and max(line.rho_d) > 325.0


def test_slots_take_no_layout(tmp_path: Path) -> None:
    text = MINIMAL.replace(
        "followers = 2\nseparation = 325\n",
        "[[formation.slot]]\nrho_d = 300\nbeta_d_deg = 180\n",
    )
    assert load_scenario(_write(tmp_path, text)).world.formation.rho_d == (300.0,)


def test_the_paper_preset_is_one_key_away(tmp_path: Path) -> None:
    paper = load_scenario(_write(tmp_path, 'preset = "paper"\n' + MINIMAL))
    got = _choices(paper)
    for dotted, value in PRESETS["paper"].items():
        if dotted != "formation.layout":  # not kept on the built formation
            assert got[dotted] == value, dotted
    assert got["thresholds.localization"] == "radial"  # Eq 19 follows the previous centre
    # a key the file gives wins over its preset
    text = 'preset = "paper"\n' + MINIMAL + '[adjust]\npredictor = "hybrid"\n'
    assert load_scenario(_write(tmp_path, text, "p2.toml")).adjust.predictor == "hybrid"
    # and the preset can be set from outside, like any key
    assert load_scenario(_write(tmp_path, MINIMAL), {"preset": "paper"}).adjust.policy == "adjust"


def test_an_unknown_preset_is_refused(tmp_path: Path) -> None:
    from rtsim.errors import ScenarioError

    want = r"preset: must be 'recommended' or 'paper', got 'papr' \(did you mean 'paper'\?\)$"
    with pytest.raises(ScenarioError, match=want):
        load_scenario(_write(tmp_path, 'preset = "papr"\n' + MINIMAL))


@pytest.mark.parametrize("pin", ["pin1", "pin2"])
def test_the_pins_name_the_settings_they_were_recorded_with(pin: str) -> None:
    got = _choices(load_scenario(PIN / f"{pin}.toml"))
    assert got["adjust.policy"] == "adjust" and got["adjust.predictor"] == "hybrid"
    assert (got["localization.centre"], got["localization.search"]) == ("previous", "always")
    assert 'layout = "line"' in (PIN / f"{pin}.toml").read_text(encoding="utf-8")


# ------------------------------------------------------------------ duration (item 2)
def test_a_files_duration_is_exact(tmp_path: Path) -> None:
    s = load_scenario(_write(tmp_path, "duration = 60\n" + MINIMAL))
    assert s.until is None
    length = run_length(s.world, None, s.duration)
    assert (length.horizon_ms, length.stop_s) == (60_000.0, None)


def test_until_lap_runs_to_the_followers_lap_under_a_cap(tmp_path: Path) -> None:
    s = load_scenario(_write(tmp_path, 'until = "lap"\n' + MINIMAL))
    length = run_length(s.world, None, s.duration)
    stop = s.world.path.lap_length + 325.0  # the lap plus rho_d
    assert length.stop_s == pytest.approx(stop)
    assert length.horizon_ms == pytest.approx(LAP_CAP_FACTOR * stop / 30.0 * 1000.0)


def test_a_duration_anywhere_replaces_until() -> None:
    s = load_scenario("test2", {"duration": 30})
    assert (s.duration, s.until) == (30.0, None)
    back = load_scenario(_write_tmp_duration(), {"until": "lap"})
    assert (back.duration, back.until) == (0.0, "lap")


def _write_tmp_duration() -> Path:
    import tempfile

    d = Path(tempfile.mkdtemp())
    return _write(d, "duration = 60\n" + MINIMAL)


def test_the_note_says_what_a_lap_run_did() -> None:
    assert run_note({"duration_s": 30.0, "lap_time_s": None}, to_lap=False) is None
    note = run_note({"duration_s": 138.1, "lap_time_s": 122.7, "laps": 1.1}, to_lap=True)
    assert note is not None and "\n" not in note
    assert note.startswith('until = "lap": ran 138.1 s') and "15.4 s more" in note
    capped = run_note({"duration_s": 315.0, "lap_time_s": None, "laps": 0.8}, to_lap=True)
    assert capped is not None and "cap of 3 lap times" in capped and "0.80 laps" in capped


def test_set_duration_runs_that_long(tmp_path: Path) -> None:
    """``--set duration=30`` on test2 (which says ``until = "lap"``) runs 30 s, no note."""
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "rtsim", "scenario", "test2", "--set", "duration=30"]
    r = subprocess.run(
        [*cmd, "--no-figures", "--json", "--out", str(out)],
        capture_output=True,
        text=True,
        check=False,
        cwd=tmp_path,
    )
    assert r.returncode == 0, r.stderr
    import json

    summary = json.loads(r.stdout)
    assert summary["duration_s"] == pytest.approx(30.0, abs=1e-9)
    assert "until" not in r.stderr
    assert math.isclose(summary["duration_s"], 30.0)
