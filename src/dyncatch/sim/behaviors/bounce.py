"""Straight lines at the speed cap, mirrored by the walls."""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax

from dyncatch.sim.behaviors.base import Behavior, NoState
from dyncatch.sim.state import RobotState, TargetState

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg


def bounce_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, NoState]:
    """Keep the heading; the walls do the rest (``reflects_off_walls``)."""
    del robot, cfg, key
    return target.heading_rad, target.behavior_state


BOUNCE = Behavior(
    desired_heading=bounce_heading,
    reflects_off_walls=True,
    doc="straight lines, reflecting off walls",
)
