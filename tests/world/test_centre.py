"""Where the Hough window is centred (previous / predicted), which lost followers are searched
for (always / visible), and why each track was lost — against hand-computed geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world import SensingParams, World, WorldConfig, hough_time
from rtsim.world import rounded_rectangle as rr
from rtsim.world.config import LocalizationParams
from rtsim.world.ekf import EkfParams
from rtsim.world.follower import FollowerParams
from rtsim.world.formation import Formation, in_line
from rtsim.world.localization import lost_cause

E_CAL, E_TRANS, R_H, R_REACQ = 0.001, 0.1, 25.0, 100.0
QUIET = dict(
    follower=FollowerParams(speed_noise=0.0, turn_noise=0.0),
    sensing=SensingParams(r_reacq=R_REACQ, position_noise=0.0),
    ekf=EkfParams(init_position_sd=0.0, init_heading_sd=0.0),
)


def world(
    centre: str,
    formation: Formation,
    start_s: float,
    search: str = "always",
    radius: float = 120.0,
    speed: float = 30.0,
) -> World:
    cfg = WorldConfig(
        rr(800, 400, radius),
        speed,
        formation,
        start_s=start_s,
        localization=LocalizationParams(centre, search),
        **QUIET,
    )  # type: ignore[arg-type]
    return World(cfg, np.random.default_rng(3))


def to_frame(leader: tuple[float, float, float], x: float, y: float) -> tuple[float, float]:
    xl, yl, h = leader
    return (
        math.cos(h) * (x - xl) + math.sin(h) * (y - yl),
        -math.sin(h) * (x - xl) + math.cos(h) * (y - yl),
    )


def test_config_rejects_unknown_choices() -> None:
    from rtsim.errors import ScenarioError

    with pytest.raises(ScenarioError, match="localization.centre"):
        LocalizationParams("truth")
    with pytest.raises(ScenarioError, match="localization.search"):
        LocalizationParams("previous", "never")


def test_predicted_equals_previous_on_a_straight_at_one_speed() -> None:
    """Leader and follower drive straight at the same constant speed: the follower's place
    in the leader's frame does not move, so both centres coincide (and with the truth)."""
    form = in_line(2, 300)
    centres = {}
    for c in ("previous", "predicted"):
        w = world(c, form, start_s=350.0)  # followers 300 cm behind, all on the first straight
        w.estimate(w.scan(0.0))
        scan = w.scan(240.0)
        assert w.leader.segment()[0] == "straight"
        assert not scan.lost.any()
        centres[c] = scan.centre
        np.testing.assert_allclose(scan.centre, scan.truth, atol=1e-9)
    np.testing.assert_allclose(centres["predicted"], centres["previous"], atol=1e-9)


def test_predicted_keeps_a_far_follower_through_a_turn_entry() -> None:
    """The leader enters a 120 cm left turn at 30 cm/s; a follower 400 cm behind drives
    straight on. Over a 1 s window the leader's frame turns by 0.25 rad and the follower's
    previous position moves ~ρ·Δψ across it: far outside r_H = 25 cm. The predicted centre
    follows both motions."""
    form = in_line(1, 400, 0.0)
    v, radius, w_ms = 30.0, 120.0, 1000.0
    runs = {}
    for c in ("previous", "predicted"):
        wd = world(c, form, start_s=800.0, radius=radius, speed=v)  # the turn starts here
        x0, y0, th0 = wd.followers.pose(0)
        v_f = wd.followers.v[0]
        rel0 = to_frame(wd.leader.pose, x0, y0)
        wd.estimate(wd.scan(0.0))
        scan = wd.scan(w_ms)
        runs[c] = scan
    # hand-computed: the leader on its circle, the follower straight on at v_f
    psi = v * w_ms / 1000.0 / radius
    # the turn starts at x = 800
    leader = (800.0 + radius * math.sin(psi), radius * (1.0 - math.cos(psi)), psi)
    follower = (x0 + v_f * math.cos(th0), y0 + v_f * math.sin(th0))
    rel1 = to_frame(leader, *follower)
    moved = math.hypot(rel1[0] - rel0[0], rel1[1] - rel0[1])
    assert psi == pytest.approx(0.25)
    assert moved > 3 * R_H  # ≈ ρ·Δψ = 100 cm across the leader's frame
    prev, pred = runs["previous"], runs["predicted"]
    np.testing.assert_allclose(prev.truth[0], rel1, atol=1e-6)
    np.testing.assert_allclose(prev.centre[0], rel0, atol=1e-6)
    assert prev.lost.tolist() == [True] and prev.cause == ("outside_window",)
    np.testing.assert_allclose(pred.centre[0], rel1, atol=1e-6)
    assert pred.lost.tolist() == [False] and pred.cause == ("",)


def test_no_search_is_charged_for_a_follower_hidden_from_the_laser() -> None:
    """Follower 2 stands exactly behind follower 1 on the laser's ray: it returns no beam.
    With search = "always" its lost track costs a full-scan search; with "visible" the leader,
    which predicts it hidden, charges none; follower 1 (seen) costs nothing either way."""
    form = Formation((200.0, 400.0), (math.pi, math.pi), "l-psi")
    cost = {}
    for search in ("always", "visible"):
        wd = world("previous", form, start_s=500.0, search=search)
        scan = wd.scan(0.0)
        assert scan.points.tolist()[1] == 0 and scan.points.tolist()[0] >= 3
        assert scan.lost.tolist() == [False, True]
        assert scan.cause == ("", "occluded")
        assert scan.lost_by_cause() == {
            "outside_window": 0,
            "occluded": 1,
            "out_of_range": 0,
            "neighbour": 0,
        }
        cost[search] = hough_time(scan, E_CAL, E_TRANS, R_H, R_REACQ)
        assert scan.n_searched == (1 if search == "always" else 0)
        assert not scan.reacquired.any()
    search_cost = math.pi * R_REACQ**2 * E_CAL + 361 * E_TRANS
    assert cost["always"] - cost["visible"] == pytest.approx(search_cost)


def test_lost_causes_by_hand() -> None:
    # visible but outside the window; hidden (beams reach it alone); ahead of the laser's
    # half-plane (x > r_F: no backward beam reaches it); beyond the laser's range
    assert lost_cause(True, (-300.0, 0.0), 25.0, math.inf, 3) == "outside_window"
    assert lost_cause(False, (-300.0, 0.0), 25.0, math.inf, 3) == "occluded"
    assert lost_cause(False, (300.0, 10.0), 25.0, math.inf, 3) == "out_of_range"
    assert lost_cause(False, (-300.0, 0.0), 25.0, 200.0, 3) == "out_of_range"


def test_coupled_run_records_lost_tracks_by_cause() -> None:
    """Four followers in a frozen Test 2's in-line formation lose tracks in its first turn: the
    causes sum to tracks_lost, per window and in summary.json."""
    from pathlib import Path

    from rtsim.coupling.scenario_run import run_scenario

    pin2 = Path(__file__).parents[1] / "data" / "policy_pin" / "pin2.toml"  # a frozen Test 2
    res = run_scenario(
        pin2, overrides={"formation.followers": 4}, duration_s=45.0, record_jobs=False
    )
    df, s = res.windows, res.summary
    causes = df[
        ["tracks_lost_outside_window", "tracks_lost_occluded", "tracks_lost_out_of_range"]
    ].sum(axis=1)
    assert (causes == df["tracks_lost"]).all()
    assert s["tracks_lost"] > 0
    assert sum(s["tracks_lost_by_cause"].values()) == s["tracks_lost"]
    assert set(s["tracks_lost_by_cause"]) == {
        "outside_window",
        "occluded",
        "out_of_range",
        "neighbour",
    }
    assert s["searches"] == s["tracks_lost"]  # search = "always" searches every lost track
    assert s["reacquisitions"] == int(df["reacquisitions"].sum()) <= s["searches"]


def test_predicted_localization_bound_by_hand() -> None:
    """k(2√2σ_fix + (Vσ_θ + σ_v)w + ½Vσ_ω w²) = r_H solved for w: with σ_fix = 1 cm,
    σ_θ = 2°, σ_v = 0.5 cm/s, σ_ω = 0.3°/s, V = 150 cm/s, k = 3 and r_H = 25 cm."""
    from rtsim.analysis.kinematics import msb_localization_predicted

    a = 0.5 * 150 * math.radians(0.3)
    b = 150 * math.radians(2.0) + 0.5
    c = 25 / 3 - 2 * math.sqrt(2)
    w = (-b + math.sqrt(b * b + 4 * a * c)) / (2 * a)
    got = msb_localization_predicted(
        25.0,
        fix_sd=1.0,
        heading_sd=math.radians(2.0),
        speed_sd=0.5,
        turn_sd=math.radians(0.3),
        v_max=150.0,
    )
    assert got == pytest.approx(1000 * w) and 900 < got < 910
    # the residual at that w is exactly r_H
    assert 3 * (2 * math.sqrt(2) + b * w + a * w * w) == pytest.approx(25.0)
    assert (
        msb_localization_predicted(
            8.0, fix_sd=1.0, heading_sd=0.0, speed_sd=0.0, turn_sd=0.0, v_max=150.0
        )
        == 0.0
    )


def test_shipped_choices_leave_two_followers_unchanged() -> None:
    """Test 2 with two followers: the predicted centre, the visible-only search and the fan
    change nothing (no track is lost, and the fan's pair is the line's); the predicted
    localization bound changes only its own column (it never binds). With the gaussian
    stand-in: with the Hough model the windows' counted points follow the centre."""
    from rtsim.coupling.recorder import LOCALIZATION_COLUMNS, sensing_columns
    from rtsim.coupling.scenario_run import run_scenario

    # the gaussian stand-in: a Hough window's points that vote, and so its time, depend on
    # where it is centred, so with model = "hough" the two runs' timing parts by design
    gauss = {"localization.model": "gaussian"}
    old = {
        **gauss,
        "localization.centre": "previous",
        "localization.search": "always",
        "formation.layout": "line",
        "thresholds.localization": "radial",
    }
    new = run_scenario("test2", duration_s=40.0, record_jobs=False, overrides=gauss).windows
    was = run_scenario("test2", duration_s=40.0, record_jobs=False, overrides=old).windows
    drop = [
        *LOCALIZATION_COLUMNS,
        *sensing_columns(2),
        "f1_msb_localization_pred",
        "f2_msb_localization_pred",
    ]
    assert new.drop(columns=drop).equals(was.drop(columns=drop))
    assert (new["f1_msb_localization_pred"] > 900).all()
    assert not new["binding"].str.startswith("localization").any()


def test_predicted_bound_in_the_follower_bounds() -> None:
    """With localization = "predicted" every follower's localization bound is the constant
    predicted_ms, for scalars and arrays alike; the other three bounds are unchanged."""
    from rtsim.analysis.kinematics import Thresholds, follower_msbs

    pred = Thresholds(25.0, 0.005, 0.025, 0.1, "predicted", predicted_ms=903.0)
    radial = Thresholds(25.0, 0.005, 0.025, 0.1)
    args = (25.0, 0.05, 27.0, 390.0, math.radians(195), 0.02, 390.0)
    a, b = follower_msbs(*args, pred), follower_msbs(*args, radial)
    assert a["localization"] == 903.0 and b["localization"] != 903.0
    assert {k: a[k] for k in a if k != "localization"} == {
        k: b[k] for k in b if k != "localization"
    }
    rho = np.array([380.0, 390.0, 400.0])
    arr = follower_msbs(25.0, 0.05, 27.0, rho, math.radians(195), 0.02, 390.0, pred)
    assert arr["localization"].tolist() == [903.0] * 3
