"""Hough windows, lost tracks, re-acquisition and its cost; observed bound violations."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.world import SensingParams, World, WorldConfig, chevron, hough_time, locate
from rtsim.world import rounded_rectangle as rr

E_CAL, E_TRANS, R_H, R_REACQ = 0.001, 0.1, 25.0, 100.0


def make_world(noise: float = 0.0) -> World:
    cfg = WorldConfig(
        rr(5000, 400, 200),
        25.0,
        chevron(2, 390),
        sensing=SensingParams(r_reacq=R_REACQ, position_noise=noise),
    )
    return World(cfg, np.random.default_rng(7))


def step(world: World, t: float):
    scan = world.scan(t)
    world.estimate(scan)
    world.command(1, t + 110.0)
    world.command(2, t + 113.0)
    return scan


def test_locate_by_hand() -> None:
    measured = np.array([[0.0, 10.0], [0.0, 30.0], [0.0, 90.0], [0.0, 150.0], [0.0, 0.0]])
    centre = np.zeros((5, 2))
    points = np.array([15, 15, 15, 15, 2])
    in_w, lost, reacq = locate(measured, centre, points, 25.0, 100.0, 3)
    assert in_w.tolist() == [True, False, False, False, False]
    assert lost.tolist() == [False, True, True, True, True]
    assert reacq.tolist() == [False, True, True, False, False]  # too far / too few beams


def test_normal_scans_stay_in_window_and_cost_eq1() -> None:
    world = make_world(noise=1.0)
    for w in range(10):
        scan = step(world, 240.0 * w)
        assert not scan.lost.any() and scan.in_window.all()
        # counted points: 2·arcsin(25/390)/0.5° ≈ 14.7 beams per follower
        assert all(14 <= p <= 15 for p in scan.points)
        expected = math.pi * R_H**2 * 2 * E_CAL + scan.total_points * E_TRANS
        assert hough_time(scan, E_CAL, E_TRANS, R_H, R_REACQ) == pytest.approx(expected)


def test_pushed_follower_is_lost_reacquired_and_charged() -> None:
    world = make_world(noise=0.0)
    t = 0.0
    for _ in range(5):
        step(world, t)
        t += 240.0
    world.advance(t)
    world.followers.y[1] += 40.0  # follower 2 jumps 40 cm: outside r_H, inside r_reacq
    scan = world.scan(t)
    assert scan.lost.tolist() == [False, True]
    assert scan.reacquired.tolist() == [False, True]
    assert scan.lost_followers == (2,)
    assert scan.violations["localization"].tolist() == [False, True]
    pts = scan.total_points
    expected = (
        math.pi * R_H**2 * 2 * E_CAL + pts * E_TRANS + math.pi * R_REACQ**2 * E_CAL + 361 * E_TRANS
    )
    assert hough_time(scan, E_CAL, E_TRANS, R_H, R_REACQ) == pytest.approx(expected)
    world.estimate(scan)
    # the estimate jumped to the fix, so the next window is centred on it again
    assert world.estimated_pose(2)[1] == pytest.approx(world.followers.y[1], abs=1e-6)
    world.command(1, t + 110.0)
    world.command(2, t + 113.0)
    assert not step(world, t + 240.0).lost.any()


def test_follower_beyond_reacquisition_radius_stays_lost() -> None:
    world = make_world()
    step(world, 0.0)
    world.advance(240.0)
    world.followers.x[0] -= 150.0
    scan = world.scan(240.0)
    assert scan.lost.tolist() == [True, False] and not scan.reacquired.any()
    before = world.filters[0].pose
    world.estimate(scan)
    # no fix: the estimate was only predicted (moved by the held command, not to the truth)
    assert abs(world.filters[0].pose[0] - before[0]) < 10.0


def test_observed_violations_against_hand_thresholds() -> None:
    world = make_world()
    thr = world.config.thresholds
    first = step(world, 0.0)
    assert not any(v.any() for v in first.violations.values())
    world.advance(240.0)
    # follower 1 moves radially outward by 5 cm: > T_rho·ρ_d = 3.9 cm, < r_H
    world.followers.x[0] -= 5.0 * math.cos(math.radians(15))
    world.followers.y[0] -= 5.0 * math.sin(math.radians(15))
    scan = world.scan(240.0)
    assert scan.changes["d_rho"][0] == pytest.approx(5.0, abs=0.2)
    assert scan.violations["separation"].tolist() == [True, False]
    assert not scan.violations["localization"].any()
    # travel in 240 ms at 25 cm/s: 6 cm < T_eps·ρ_d = 9.75 cm
    assert scan.changes["travel"] == pytest.approx([6.0, 6.0], abs=0.1)
    assert not scan.violations["path_diversion"].any()
    assert thr.T_eps * 390 == pytest.approx(9.75)
    world.estimate(scan)
    world.advance(2000.0)  # 1.76 s since the last scan: travel 44 cm
    scan = world.scan(2000.0)
    assert scan.violations["path_diversion"].all()
    # bearing: rotate follower 2 by 6° about the leader (> T_beta = 5°)
    world.estimate(scan)
    world.advance(2240.0)
    xl, yl, hl = world.leader_pose
    dx, dy = world.followers.x[1] - xl, world.followers.y[1] - yl
    a = math.radians(6)
    world.followers.x[1] = xl + math.cos(a) * dx - math.sin(a) * dy
    world.followers.y[1] = yl + math.sin(a) * dx + math.cos(a) * dy
    scan = world.scan(2240.0)
    assert math.degrees(scan.changes["d_beta"][1]) == pytest.approx(6.0, abs=0.3)
    assert scan.violations["bearing"].tolist() == [False, True]
