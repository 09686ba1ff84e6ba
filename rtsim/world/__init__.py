"""The robot-group world: leader path and speed ramps, follow-the-leader or l-ψ followers,
laser, Hough localization, EKFs.

Plain numpy and filterpy, no simulation engine: the owner of time steps it (docs/model/world.md).
"""

from rtsim.world.config import DEFAULT_THRESHOLDS, SensingParams, WorldConfig
from rtsim.world.ekf import EkfParams, FollowerEKF
from rtsim.world.follower import FollowerGroup, FollowerParams, lpsi_command
from rtsim.world.formation import Formation, chevron
from rtsim.world.laser import BEAM_BEARINGS, beam_owners, count_beams, max_points
from rtsim.world.leader import Leader
from rtsim.world.localization import hough_time, locate
from rtsim.world.path import LeaderPath, Straight, Turn, rounded_rectangle
from rtsim.world.world import Scan, World

__all__ = [
    "BEAM_BEARINGS",
    "DEFAULT_THRESHOLDS",
    "EkfParams",
    "FollowerEKF",
    "FollowerGroup",
    "FollowerParams",
    "Formation",
    "Leader",
    "LeaderPath",
    "Scan",
    "SensingParams",
    "Straight",
    "Turn",
    "World",
    "WorldConfig",
    "beam_owners",
    "chevron",
    "count_beams",
    "hough_time",
    "locate",
    "lpsi_command",
    "max_points",
    "rounded_rectangle",
]
