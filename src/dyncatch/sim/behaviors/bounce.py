"""Straight lines at the speed cap, mirrored by the walls."""

from __future__ import annotations

import jax

from dyncatch.sim.behaviors.base import Behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import RobotState, TargetState


def bounce_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, jax.Array]:
    del robot, cfg, key
    return target.heading_rad, target.memory


BOUNCE = Behavior(
    desired_heading=bounce_heading,
    reflects_off_walls=True,
    doc="straight lines, reflecting off walls",
)
