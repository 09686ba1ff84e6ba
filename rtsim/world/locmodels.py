"""Localization models: how the leader fixes each follower at a scan, as plug-ins
(``[localization] model``; entry-point group ``rtsim.localization_models``; docs/localization.md,
docs/howto/localization-model.md).

A model is a class with the `LocalizationModel` interface, registered in
`LOCALIZATION_MODELS`. It supplies both things its consumers read, so a new one cannot be
half-wired:

- its **measurement**: `LocalizationModel.sense` (the beams each follower returned, drawing
  its noise) and `LocalizationModel.locate` (each follower's fix and window outcome), which
  `World.scan` calls;
- its **uncertainty**: `LocalizationModel.fix_sd`, the standard deviation σ_fix of one fix
  coordinate at a range, which the predicted-centre localization bound reads
  (`rtsim.analysis.kinematics.msb_localization_predicted`).

Built-ins: ``gaussian`` (the true position plus N(0, position_noise²) per coordinate, accepted
inside the window; the fast stand-in) and ``hough`` (a laser scan, `rtsim.world.rangefinder`,
and a Hough transform in each window, `rtsim.world.hough`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from rtsim.analysis.kinematics import msb_localization_predicted
from rtsim.errors import InputError, ScenarioError
from rtsim.model.window import LASER_POINTS
from rtsim.registry import Registry
from rtsim.world._check import plugin
from rtsim.world.config import SensingParams, WorldConfig
from rtsim.world.ekf import EkfParams
from rtsim.world.follower import FollowerParams
from rtsim.world.hough import Accumulator, peak_fix, window_cells
from rtsim.world.laser import count_beams_xy
from rtsim.world.localization import locate_one
from rtsim.world.motionmodels import motion_model
from rtsim.world.rangefinder import Rangefinder

__all__ = [
    "LOCALIZATION_MODELS",
    "Fix",
    "GaussianModel",
    "HoughModel",
    "LocalizationModel",
    "localization_model",
    "predicted_bound_ms",
]

XY = tuple[float, float]
#: One follower's outcome at a scan: (fix in the leader's frame, in_window, lost, searched,
#: reacquired, lost to a neighbour's points).
Fix = tuple[XY, bool, bool, bool, bool, bool]


class LocalizationModel:
    """The interface of a localization model (module doc). One instance per world, made by
    `World` with ``(config, n, rng, normals, fast, draw)``: ``normals(m)`` draws the next
    ``m`` standard normals of the world's buffered stream as a list, ``draw(m)`` as an array
    (default: ``rng.standard_normal``); ``rng`` is the world's generator; ``fast``: the
    compiled backend."""

    #: the name a scenario writes (set by subclasses)
    name: ClassVar[str] = ""
    #: Hough cells the model's windows cost per scan (None: not counted)
    cells: int | None = None

    def __init__(
        self,
        config: WorldConfig,
        n: int,
        rng: np.random.Generator,
        normals: Callable[[int], list[float]],
        fast: bool,
        draw: Callable[[int], NDArray[np.float64]] | None = None,
    ) -> None:
        self.config = config
        self.n = n
        self.rng = rng
        self.normals = normals
        self.draw = rng.standard_normal if draw is None else draw
        self.fast = fast
        self.start()

    def start(self) -> None:
        """Set up the model's own state for this world (its sensor, its buffers)."""

    @classmethod
    def fix_sd(cls, sensing: SensingParams, rho: float) -> float:
        """σ_fix (cm) of one fix coordinate for a follower at range ``rho`` (cm) — what the
        predicted-centre bound assumes. Default: ``[sensing] position_noise``."""
        return sensing.position_noise

    def sense(self, truth_l: list[XY]) -> tuple[list[int], Any]:
        """Scan the followers at ``truth_l`` (leader frame): the beams each returned and the
        model's state for `locate` (its draws)."""
        raise NotImplementedError

    def locate(
        self,
        state: Any,
        truth_l: list[XY],
        pts: list[int],
        centre: list[XY],
        expected: Sequence[int] | None,
    ) -> tuple[list[Fix], list[int] | None]:
        """Every follower's `Fix` from the scan ``state`` with its window at ``centre``
        (``expected``: the beams the leader expects, ``search = "visible"``, a sequence
        counted on its first read, `rtsim.world.localization.ExpectedBeams`; None: search
        always), and the votes each window's peak had (None: not a voting model)."""
        raise NotImplementedError


class GaussianModel(LocalizationModel):
    """``gaussian``: the fix is the truth plus N(0, σ²) per coordinate, σ = `fix_sd` at the
    follower's true range; inside r_H of the window centre it counts, else the track is lost
    and searched for within r_reacq (`rtsim.world.localization.locate_one`)."""

    name = "gaussian"

    def sense(self, truth_l: list[XY]) -> tuple[list[int], Any]:
        pts = count_beams_xy(truth_l, self.config.follower.radius, self.config.sensing.max_range)
        return pts, self.normals(2 * self.n)  # = standard_normal((n, 2)), row-major

    def locate(
        self,
        state: Any,
        truth_l: list[XY],
        pts: list[int],
        centre: list[XY],
        expected: Sequence[int] | None,
    ) -> tuple[list[Fix], list[int] | None]:
        z: list[float] = state
        sens = self.config.sensing
        r_H, r_re, min_pts = self.config.thresholds.r_H, sens.r_reacq, sens.min_points
        sd = type(self).fix_sd
        out: list[Fix] = []
        for k in range(self.n):
            tx, ty = truth_l[k]
            pn = sd(sens, math.hypot(tx, ty))
            mx, my = tx + pn * z[2 * k], ty + pn * z[2 * k + 1]
            in_w, lost, reacq = locate_one((mx, my), centre[k], pts[k], r_H, r_re, min_pts)
            search = lost and (expected is None or expected[k] >= min_pts)
            out.append(((mx, my), in_w, lost, search, reacq and search, False))
        return out, None


class HoughModel(LocalizationModel):
    """``hough``: a laser scan with range noise (`rtsim.world.rangefinder`) and a Hough
    transform for a circle of radius r_F in each window (`rtsim.world.hough`); the peak is
    the fix when it has at least ``min_points`` votes, and a window without one searches the
    full scan within r_reacq. σ_fix: ``position_noise`` (the bound's assumption)."""

    name = "hough"

    def start(self) -> None:
        """The rangefinder and the accumulator (sized for r_H and r_reacq)."""
        config, n, fast = self.config, self.n, self.fast
        sens = config.sensing
        r_F = config.follower.radius
        self.rangefinder = Rangefinder(r_F, sens.max_range, sens.range_noise, fast)
        r_max = max(config.thresholds.r_H, sens.r_reacq)
        self.accumulator = Accumulator(n, r_F, r_max, fast)
        self.cells = n * window_cells(config.thresholds.r_H)

    def sense(self, truth_l: list[XY]) -> tuple[list[int], Any]:
        """The beams each follower returned and the scan (px, py, owner)."""
        xy = np.array(truth_l).T.copy()  # (contiguous rows, the kernel's one signature)
        z = self.draw(LASER_POINTS)
        beams = self.rangefinder.scan(xy[0], xy[1], z)
        return self.rangefinder.counts[: self.n].tolist(), beams

    def locate(
        self,
        state: Any,
        truth_l: list[XY],
        pts: list[int],
        centre: list[XY],
        expected: Sequence[int] | None,
    ) -> tuple[list[Fix], list[int] | None]:
        c = np.array(centre).T.copy()
        px, py, owner = state
        r_H = self.config.thresholds.r_H
        # the windows' records as tuples (fix_x, fix_y, votes, voters, owner, cells): one
        # conversion, not a numpy scalar per field
        rows = self.accumulator.locate(px, py, owner, c[0], c[1], r_H).tolist()
        min_pts = self.config.sensing.min_points
        out: list[Fix] = []
        for k, row in enumerate(rows):
            found, neighbour = peak_fix(row[2], row[4], k, min_pts)
            if found:  # the peak is the fix
                out.append(((row[0], row[1]), True, neighbour, False, False, neighbour))
            else:
                out.append(self._search(k, state, centre[k], expected))
        return out, [row[3] for row in rows]

    def _search(self, k: int, beams: Any, centre: XY, expected: Sequence[int] | None) -> Fix:
        """Follower index k's outcome when its window had no fix (fewer than ``min_points``
        votes at the peak, `locate`; else the peak is the fix, lost by a neighbour when
        another follower's points made it — the truth says so, the leader does not know):
        the track is lost, and the follower is searched for over the full scan (r_reacq) as
        with the gaussian model, unless the leader expects too few beams of it."""
        sens = self.config.sensing
        min_pts = sens.min_points
        if not (expected is None or expected[k] >= min_pts):
            return centre, False, True, False, False, False
        px, py, owner = beams
        found = self.accumulator.search(px, py, owner, centre[0], centre[1], sens.r_reacq)
        hit, neighbour = peak_fix(int(found["votes"]), int(found["owner"]), k, min_pts)
        if not hit:
            return centre, False, True, True, False, False
        fix = (float(found["fix_x"]), float(found["fix_y"]))
        return fix, False, True, True, True, neighbour


def _model_class(obj: Any, spec: str, where: str) -> type[LocalizationModel]:
    if isinstance(obj, type) and issubclass(obj, LocalizationModel):
        return obj
    raise InputError(f"{where} is not a LocalizationModel subclass")


#: The localization models by name (``[localization] model``; entry-point group
#: ``rtsim.localization_models``).
LOCALIZATION_MODELS: Registry[type[LocalizationModel]] = Registry(
    "localization model", "rtsim.localization_models", _model_class
)
LOCALIZATION_MODELS.register("gaussian", GaussianModel)
LOCALIZATION_MODELS.register("hough", HoughModel)


def localization_model(name: str, where: str = "localization.model") -> type[LocalizationModel]:
    """The localization model class ``name`` names; an unknown one is a `ScenarioError`."""
    return plugin(LOCALIZATION_MODELS, name, where)


def predicted_bound_ms(
    model: str,
    r_H: float,
    sensing: SensingParams,
    follower: FollowerParams,
    ekf: EkfParams,
    rho_max: float,
) -> float:
    """The decision's localization bound (ms) for a window centred at the predicted position
    (`rtsim.analysis.kinematics.msb_localization_predicted`, docs/localization.md): the
    localization model ``model``'s fix noise σ_fix at the formation's farthest desired range
    ``rho_max`` (`LocalizationModel.fix_sd`), the EKF's initial heading error, the actuation
    noise, at the followers' top speed, 3 standard deviations, the turn noise's drift the
    followers' motion model's (`rtsim.world.motionmodels.MotionModel.turn_error`); the
    leader knows its own motion (no error)."""
    fix_sd = localization_model(model).fix_sd(sensing, rho_max)
    if not math.isfinite(follower.max_speed):
        raise ScenarioError(
            "thresholds.localization: 'predicted' needs a finite follower.max_speed (the "
            "bound carries the heading error at it)"
        )
    return msb_localization_predicted(
        r_H,
        fix_sd=fix_sd,
        heading_sd=ekf.init_heading_sd,
        speed_sd=follower.speed_noise,
        turn_sd=follower.turn_noise,
        v_max=follower.max_speed,
        turn_error=motion_model(follower.motion_model, "follower.motion_model").turn_error,
    )
