"""The world's frozen configuration: path, leader speed, formation, followers, sensing, EKF,
thresholds and integration step (built by [`rtsim.config.scenario`][rtsim.config.scenario] or
by hand)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from rtsim.analysis.kinematics import R_H_DEFAULT, Thresholds
from rtsim.errors import ScenarioError
from rtsim.io.limits import Range
from rtsim.world import compiled
from rtsim.world._check import NOISE, in_ranges, positive, spec
from rtsim.world.ekf import EkfParams
from rtsim.world.follower import FollowerParams
from rtsim.world.formation import Formation
from rtsim.world.ideal import START_ON
from rtsim.world.path import LeaderPath

__all__ = [
    "CENTRES",
    "LocalizationParams",
    "RadioParams",
    "SEARCHES",
    "SensingParams",
    "WorldConfig",
    "DEFAULT_THRESHOLDS",
    "WORLD_BACKENDS",
]

#: ``[world] backend``: ``python`` (the reference: plain floats), ``compiled`` (the same
#: arithmetic compiled with numba, bit for bit; `rtsim.world.compiled`), ``filterpy``
#: (the Python world with filterpy's EKF; ``[ekf] backend = "filterpy"`` is its older name).
WORLD_BACKENDS: tuple[str, ...] = ("python", "compiled", "filterpy")

#: T_ρ = 0.01, T_ε = 0.025 (an earlier prototype of this world), T_β = 5°, r_H = r_F = 25 cm.
DEFAULT_THRESHOLDS = Thresholds(r_H=R_H_DEFAULT, T_rho=0.01, T_eps=0.025, T_beta=math.radians(5.0))


@dataclass(frozen=True)
class SensingParams:
    """Laser and Hough parameters (r_H lives in the thresholds).

    r_reacq: re-acquisition search radius (cm, ≥ r_H); position_noise: standard deviation
    of each coordinate of a position fix (cm); min_points: beams a follower must return to
    be found; max_range: laser range (cm); range_noise: standard deviation of each beam's
    range reading (cm; the ``hough`` localization model's scan, `rtsim.world.rangefinder`).
    ``position_noise`` is the ``gaussian`` model's only noise.
    """

    r_reacq: float = spec(
        100.0, Range("", 0, 1e5, "cm", "a search radius within 1 km", lo_open=True)
    )
    position_noise: float = spec(1.0, Range("", 0, 1e4, "cm", NOISE))
    min_points: int = spec(3, Range("", 1, 361, "points", "at most the 361 beams", integer=True))
    max_range: float = spec(
        8000.0, Range("", 0, 1e7, "cm", "inf: unlimited", lo_open=True, inf=True)
    )
    range_noise: float = spec(
        1.0, Range("", 0, 1e3, "cm", "a beam's range noise (σ), localization hough")
    )

    def __post_init__(self) -> None:
        in_ranges(self, "sensing")


#: Where the Hough window is centred (`rtsim.world.localization`).
CENTRES: tuple[str, ...] = ("previous", "predicted")
#: When a lost follower is searched for (`rtsim.world.localization`).
SEARCHES: tuple[str, ...] = ("always", "visible")


@dataclass(frozen=True)
class LocalizationParams:
    """How the leader looks for each follower in a scan (`rtsim.world.localization`).

    centre: ``"previous"`` — the window is centred at the follower's previous position
    relative to the leader (the leader's estimate at the previous scan, in the leader's frame
    at that scan; the paper's Fig 5); ``"predicted"`` — at the estimate carried over the
    window with the command the follower holds, in the leader's frame at the new scan (the
    leader knows its own motion). search: ``"always"`` — every lost follower costs a
    full-scan search; ``"visible"`` — only those the leader expects, from its own prediction
    of every follower, to return at least ``min_points`` beams. model: the name of a
    localization model (`rtsim.world.locmodels.LOCALIZATION_MODELS`), resolved when a
    `World` is built (a scenario file's is checked when it is read).
    """

    centre: str = "previous"
    search: str = "always"
    model: str = "gaussian"

    def __post_init__(self) -> None:
        for key, allowed in (
            ("centre", CENTRES),
            ("search", SEARCHES),
        ):
            value = getattr(self, key)
            if value not in allowed:
                raise ScenarioError(
                    f"localization.{key}: must be one of "
                    f"{', '.join(repr(a) for a in allowed)}, got {value!r}"
                )
        if not isinstance(self.model, str) or not self.model:
            raise ScenarioError(f"localization.model: must be a model's name, got {self.model!r}")


@dataclass(frozen=True)
class RadioParams:
    """The leader's radio link to its followers (``[radio]``, docs/localization.md).

    The round trip Δt of each window (send to the last reply) is drawn uniformly between
    ``min_ms`` and the task set's ``delta_t`` (its maximum, the paper's measured 67 ms);
    ``min_ms`` None: always ``delta_t`` (a constant). ``loss``: the probability that one
    follower's command is lost; the follower keeps its previous command, and the leader,
    missing its reply, knows it (its estimate keeps the previous command too).
    """

    min_ms: float | None = spec(
        None,
        Range(
            "",
            0,
            1e9,
            "ms",
            "the shortest round trip, at most the task set's delta_t",
            lo_open=True,
        ),
    )
    loss: float = spec(0.0, Range("", 0, 1, "", "a probability per command", hi_open=True))

    def __post_init__(self) -> None:
        in_ranges(self, "radio")

    @property
    def varies(self) -> bool:
        """Whether the link draws anything (a spread round trip or a loss probability)."""
        return self.min_ms is not None or self.loss > 0


#: the reason of the leader's ramp limits' range (``[leader] accel_max``, ``decel_max``)
_RAMP = "at most 100 g; inf: the speed steps"
_ROBOT = "a ground robot at most 10 m/s"


def _leader(key: str, lo: float, hi: float, unit: str, why: str, **kw: bool) -> Range:
    """The range of a ``[leader]`` key, named by its file key (``leader.<key>``) in errors
    and read by the scenario file's table (`spec`)."""
    return Range(f"leader.{key}", lo, hi, unit, why, **kw)


@dataclass(frozen=True)
class WorldConfig:
    """Everything the [`World`][rtsim.world.world.World] needs.

    ``leader_speed`` is V_Ld (cm/s); ``start_s`` the leader's initial arc length (cm);
    ``step_ms`` the largest integration step while a follower's speed is ramping (a held
    command with a settled speed is integrated in one exact arc); ``leader_accel_max`` and
    ``leader_decel_max`` (cm/s², ``inf`` = a step) the leader's speed ramp
    ([`Leader`][rtsim.world.leader.Leader]). The followers' controller is
    ``formation.model`` (``"l-psi"`` or ``"follow-the-leader"``); ``localization`` where the
    Hough windows are centred and when a lost follower is searched for. ``backend``: one of
    `WORLD_BACKENDS`, None = `resolved_backend`'s default. ``radio``: the leader's radio link
    (its round trip and losses, drawn by the coupled run).
    """

    path: LeaderPath
    leader_speed: float = field(
        metadata={"range": _leader("speed", 0, 1000, "cm/s", _ROBOT, lo_open=True)}
    )
    formation: Formation
    follower: FollowerParams = field(default_factory=FollowerParams)
    sensing: SensingParams = field(default_factory=SensingParams)
    ekf: EkfParams = field(default_factory=EkfParams)
    thresholds: Thresholds = DEFAULT_THRESHOLDS
    step_ms: float = spec(10.0, Range("", 1e-3, 1e4, "ms", "1 µs to 10 s per integration step"))
    start_s: float = spec(
        0.0,
        _leader(
            "start_s",
            0,
            1e7,
            "cm",
            "a position along the path (within one lap, checked against the path's length)",
        ),
    )
    leader_accel_max: float = spec(
        math.inf, _leader("accel_max", 0, 1e5, "cm/s²", _RAMP, lo_open=True, inf=True)
    )
    leader_decel_max: float = spec(
        math.inf, _leader("decel_max", 0, 1e5, "cm/s²", _RAMP, lo_open=True, inf=True)
    )
    localization: LocalizationParams = field(default_factory=LocalizationParams)
    backend: str | None = None
    radio: RadioParams = field(default_factory=RadioParams)
    #: how the group starts (`rtsim.world.ideal.START_ON`): ``given`` (at ``start_s``,
    #: as a `WorldConfig` built by hand) or ``straight`` (settled on a straight: a
    #: scenario file's default, which moves ``start_s``; the run starts the leader at
    #: the speed the bounds allow there, `rtsim.control.oracle.start_speed`)
    start_on: str = "given"
    #: the leader's speed at t = 0 (cm/s, in (0, V_Ld]; None: V_Ld)
    start_speed: float | None = None

    def __post_init__(self) -> None:
        if self.backend is not None and self.backend not in WORLD_BACKENDS:
            raise ScenarioError(
                f"world.backend: must be one of {', '.join(WORLD_BACKENDS)}, got {self.backend!r}"
            )
        if self.ekf.backend == "filterpy" and self.backend not in (None, "filterpy"):
            raise ScenarioError(
                f"world.backend: {self.backend!r} contradicts ekf.backend = "
                f"'filterpy' (an alias of world.backend = 'filterpy')"
            )
        in_ranges(self, "world")  # (step_ms, the [leader] keys under their file names)
        if self.start_on not in START_ON:
            raise ScenarioError(
                f"leader.start_on: must be one of {', '.join(START_ON)}, got {self.start_on!r}"
            )
        if self.start_speed is not None:
            v0 = positive("leader.start_speed", self.start_speed)
            if v0 > self.leader_speed:
                raise ScenarioError(
                    f"leader.start_speed: {v0:g} cm/s is above leader.speed {self.leader_speed:g}"
                )
            object.__setattr__(self, "start_speed", v0)
        self.formation.check_spacing(self.follower.radius)
        if self.sensing.r_reacq < self.thresholds.r_H:
            raise ScenarioError(
                f"sensing.r_reacq: {self.sensing.r_reacq:g} must be >= r_H "
                f"({self.thresholds.r_H:g})"
            )

    @property
    def n(self) -> int:
        return self.formation.n

    def resolved_backend(self) -> str:
        """The backend a run uses: ``backend`` when set; else ``filterpy`` when
        ``ekf.backend`` says so (its older name), else ``compiled`` where numba can be
        imported and ``python`` where it cannot. An explicit ``compiled`` without numba is
        an error."""
        if self.backend is None:
            if self.ekf.backend == "filterpy":
                return "filterpy"
            return "compiled" if compiled.available() else "python"
        if self.backend == "compiled" and not compiled.available():
            raise ScenarioError(
                "world.backend: 'compiled' needs numba, which cannot be "
                "imported here (install it, or use backend = 'python')"
            )
        return self.backend
