"""Motion models: how the robots move under a held command, as plug-ins (``[follower]
motion_model``; entry-point group ``rtsim.motion_models``; docs/howto/motion-model.md).

A `MotionModel` is four kernel sources (`rtsim.world.jit.kernel`), one per consumer, so a
model cannot be half-wired (building one checks that every part is there):

- ``advance`` — the world's followers (the truth) and the controller's rollout: a held
  command integrated to a time, ``(x, y, θ, v, ω, v_c, ω_c, a, odometer, t0, t, step_ms) →
  (x, y, θ, v, ω, odometer)`` (`rtsim.world.motion.follower_advance`);
- ``step`` — the leader's belief: one held command piece from the expected state,
  ``(x, y, θ, v, ω, v_c, ω_c, a, dt) → (x, y, θ, v, ω, mean speed)``
  (`rtsim.world.motion.ramp_arc`);
- ``process`` — the EKF predict: the pose increments, the Jacobian's two non-zeros and the
  process noise of a held command, then the speed and turn rate after it,
  ``(θ, v, ω, v_c, ω_c, a, dt, σ_v², σ_ω², q_p², q_θ²) → (Δx, Δy, Δθ, F02, F12, q00, q01,
  q02, q11, q12, q22, v, ω)`` (`rtsim.world.ekf.command_process`);
- ``leader`` — the leader's speed ramp along its path, ``(v0, v_target, accel, decel, dt) →
  (v, arc length)`` (`rtsim.world.motion.leader_travel`);
- ``turn_error`` — the bounds: how far a turn-rate error turns the robot over a window,
  ``(σ_ω, t) → (σ_θ, σ_∫θ)`` (`rtsim.analysis.kinematics.TurnError`; a plain function,
  default the unicycle's, `rtsim.analysis.kinematics.unicycle_turn_error`, which bounds
  any model whose turn rate is a non-negative average of its commands, such as a lag).

(v, ω) is a robot's actual speed and turn rate (the unicycle's turn rate is its command's;
a model with turn dynamics carries it), a its acceleration limit ``max_accel``. The
``python`` backend calls the parts as Python, the ``compiled`` backend compiles them; the
kernels that call a unicycle part (the EKF's `rtsim.world.ekf.ekf_command`, the rollout)
are built for another model with its parts in their place (`rtsim.world.jit.build` and
`rtsim.world.jit.specialise` with `MotionModel.subs`): one source for both backends.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable
from dataclasses import dataclass, fields
from functools import cached_property
from typing import Any

from rtsim.analysis.kinematics import TurnError, unicycle_turn_error
from rtsim.errors import InputError
from rtsim.registry import Registry
from rtsim.world._check import plugin
from rtsim.world.ekf import command_process
from rtsim.world.jit import Subs, is_kernel
from rtsim.world.motion import follower_advance, leader_travel, ramp_arc

__all__ = ["MOTION_MODELS", "MotionModel", "UNICYCLE", "motion_model"]

Kernel = Callable[..., Any]

#: what each part serves (named in the error when one is missing)
PARTS = {
    "advance": "the world's followers and the rollout: a held command integrated to a time",
    "step": "the leader's belief: one held command piece",
    "process": "the EKF predict: pose increments, Jacobian and process noise",
    "leader": "the leader's speed ramp along its path",
}


def _missing(*args: Any) -> Any:
    """A part not given (`MotionModel` refuses it)."""
    raise NotImplementedError


@dataclass(frozen=True)
class MotionModel:
    """A motion model (module docstring): ``name``, its four parts, each a kernel source
    with the unicycle's arguments, and its ``turn_error`` for the bounds. Building one with
    a part missing, not a kernel source or with other arguments is an `InputError` naming
    the part."""

    name: str
    advance: Kernel = _missing
    step: Kernel = _missing
    process: Kernel = _missing
    leader: Kernel = _missing
    turn_error: TurnError = unicycle_turn_error

    def __post_init__(self) -> None:
        if not callable(self.turn_error):
            raise InputError(
                f"motion model {self.name!r}: turn_error (the bounds: the heading error a "
                f"turn-rate error makes over a window) is not a function"
            )
        for part, what in PARTS.items():
            fn = getattr(self, part)
            where = f"motion model {self.name!r}: {part} ({what})"
            if fn is _missing:
                raise InputError(f"{where} is missing")
            if not is_kernel(fn):
                raise InputError(
                    f"{where} is not a kernel source (mark it @rtsim.world.jit.kernel)"
                )
            want = _ARITY.get(part)
            got = len(inspect.signature(fn).parameters)
            if want is not None and got != want:
                raise InputError(f"{where} takes {got} arguments, not {want}")

    @cached_property
    def subs(self) -> Subs:
        """The substitutions that build a unicycle kernel for this model (`rtsim.world.jit`):
        each unicycle part this model replaces, paired with its own (found once per model:
        its parts are frozen; a world reads them five times)."""
        return tuple(
            (getattr(UNICYCLE, p), getattr(self, p))
            for p in PARTS
            if getattr(self, p) is not getattr(UNICYCLE, p)
        )


_ARITY: dict[str, int] = {}
#: The unicycle (docs/model/world.md): exact arcs, a speed ramp, an immediate turn rate.
UNICYCLE = MotionModel(
    "unicycle",
    advance=follower_advance,
    step=ramp_arc,
    process=command_process,
    leader=leader_travel,
)
_ARITY.update(
    (f.name, len(inspect.signature(getattr(UNICYCLE, f.name)).parameters))
    for f in fields(MotionModel)
    if f.name in PARTS
)


def _model(obj: Any, spec: str, where: str) -> MotionModel:
    if isinstance(obj, MotionModel):
        return obj
    raise InputError(f"{where} is not a MotionModel")


class _Models(Registry[MotionModel]):
    def register(self, name: str, value: MotionModel) -> MotionModel:
        """Register a `MotionModel` (anything else is an `InputError`)."""
        return super().register(name, _model(value, name, f"motion model {name!r}"))


#: The motion models by name (``[follower] motion_model``; entry-point group
#: ``rtsim.motion_models``).
MOTION_MODELS: Registry[MotionModel] = _Models("motion model", "rtsim.motion_models", _model)
MOTION_MODELS.register("unicycle", UNICYCLE)


def motion_model(name: str, where: str = "follower.motion_model") -> MotionModel:
    """The motion model ``name`` names; an unknown one is a `ScenarioError`."""
    return plugin(MOTION_MODELS, name, where)
