"""The oracle lap (rtsim.control.oracle) against derivations by hand (issue 33)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rtsim.analysis.kinematics import Thresholds
from rtsim.control.oracle import lap_oracle, oracle_profile
from rtsim.world.config import WorldConfig
from rtsim.world.formation import Formation
from rtsim.world.ideal import ideal_lap
from rtsim.world.path import LeaderPath, Turn

W_SCH = 237.4  # ms


def _circle(radius: float, rho: float, lateral: float) -> tuple[LeaderPath, Formation]:
    path = LeaderPath([Turn("left", radius, 2 * math.pi)])
    beta = math.pi - math.asin(lateral / rho)  # lateral < 0: right of the trace
    return path, Formation((rho,), (beta,), "follow-the-leader")


def test_on_a_circle_the_follower_keeps_its_place_and_its_speed_ratio() -> None:
    """A follower 50 cm right of a left circle of radius 400 cm (its outer side) drives the
    circle of radius 450 cm at the leader's angular rate: V_F/V_L = 450/400, at ρ_d from the
    leader, its bearing constant."""
    path, form = _circle(400.0, 200.0, -50.0)
    lap = ideal_lap(path, form)
    xy = lap.xy[0]
    assert np.hypot(*(xy - lap.leader[:, :2]).T) == pytest.approx(200.0, abs=0.02)
    assert np.hypot(xy[:, 0], xy[:, 1] - 400.0) == pytest.approx(450.0, abs=0.02)
    assert lap.ratio[0] == pytest.approx(450.0 / 400.0, rel=1e-3)
    assert np.ptp(lap.bearing[0]) < 1e-3


def test_oracle_on_a_circle_is_length_over_the_path_diversion_speed() -> None:
    """Eq 21 at w_sch with V_F = 1.125 V_L caps the leader at T_eps rho_d / (w_sch 1.125)
    everywhere (bearing constant, below V_Ld = 30): the lap is 2 pi 400 / that speed."""
    path, form = _circle(400.0, 200.0, -50.0)
    thr = Thresholds(r_H=25.0, T_rho=0.01, T_eps=0.025, T_beta=math.radians(5))
    cfg = WorldConfig(
        path, 30.0, form, thresholds=thr, leader_accel_max=20.0, leader_decel_max=50.0
    )
    cap = 0.025 * 200.0 / (W_SCH / 1000.0 * 450.0 / 400.0)
    assert cap < 30.0
    assert lap_oracle(cfg, W_SCH) == pytest.approx(2 * math.pi * 400.0 / cap, rel=2e-4)


def test_oracle_profile_ramps_within_the_limits() -> None:
    """A step cap 30 -> 10 -> 30 cm/s on [1000, 1500] cm of a 3000 cm lap with a_max = 20,
    d_max = 50 cm/s^2: braking (30^2 - 10^2)/(2*50) = 8 cm before 1000 in (30 - 10)/50 s,
    500 cm at 10 cm/s, speeding up over (30^2 - 10^2)/(2*20) = 20 cm in (30 - 10)/20 s, the
    rest at 30 cm/s."""
    ds = 0.5
    s = np.arange(0.0, 3000.0 + ds / 2, ds)
    cap = np.where((s >= 1000.0) & (s <= 1500.0), 10.0, 30.0)
    v = oracle_profile(cap, ds, 30.0, 20.0, 50.0)
    t = float(np.sum(2 * ds / (v[:-1] + v[1:])))
    by_hand = (1000 - 8) / 30 + 20 / 50 + 500 / 10 + 20 / 20 + (3000 - 1520) / 30
    assert t == pytest.approx(by_hand, abs=0.05)
    assert np.all(np.diff(v**2) <= 2 * 20 * ds + 1e-9)
    assert np.all(np.diff(v**2) >= -2 * 50 * ds - 1e-9)


def test_l_psi_has_no_oracle() -> None:
    path, form = _circle(400.0, 200.0, -50.0)
    cfg = WorldConfig(path, 30.0, Formation(form.rho_d, form.beta_d))
    assert lap_oracle(cfg, W_SCH) is None
