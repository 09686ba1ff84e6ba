"""A :class:`~rtsim.control.rollout.RolloutState` read off a world at a decision (shared by
the rollout's tests)."""

from __future__ import annotations

from typing import Any

from rtsim.control.rollout import RolloutState


def world_state(
    world: Any,
    t_d: float,
    next_scan: float,
    offsets: tuple[float, ...],
    w: float,
    pending: tuple[tuple[float, ...], ...] | None = None,
) -> RolloutState:
    """The state of ``world`` at ``t_d`` with the followers' truth as the leader's knowledge
    (a noise-free world makes them one), its own law and group class."""
    fol, ld = world.followers, world.leader
    return RolloutState(
        path=world.config.path,
        law=world.follow_law,
        params=world.config.follower,
        step_ms=world.config.step_ms,
        t_now=t_d,
        leader_s=ld.s,
        leader_speed=ld.speed,
        v_ld=ld.desired_speed,
        accel_max=ld.accel_max,
        decel_max=ld.decel_max,
        poses=tuple(fol.pose(k) for k in range(world.n)),
        speeds=tuple(fol.v),
        held=tuple((fol.cmd_v[k], fol.cmd_w[k]) for k in range(world.n)),
        pending=((),) * world.n if pending is None else pending,
        next_scan=next_scan,
        send_offsets=offsets,
        thresholds=world.config.thresholds,
        rho_d=tuple(world.config.formation.rho_d),
        w_sch=w,
        group=type(fol),
        beta_d=tuple(world.config.formation.beta_d),
    )
