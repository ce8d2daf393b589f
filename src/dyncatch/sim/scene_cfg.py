"""Constants of the rooms, the woods and their terrains (docs/scenes.md gives every source).

Kept apart from ``config`` so that the scene layouts can use them without importing it; each
class is a field of ``WorldCfg`` (``--world.room.*``, ``--world.woods.*``,
``--world.rough.*``, ``--world.stairs.*``, ``--world.avoid.*``).
"""

from __future__ import annotations

from flax import struct

from dyncatch.sim.fields import static


@struct.dataclass
class RoomCfg:
    """Obstacles of the rooms (``room_0``, ``room_4``, ``room_8``), placed anew each episode.

    The room is the square of ``ArenaCfg`` (its sides are walls). Its interior, less
    ``wall_clearance_m``, is cut into ``grid_cells`` x ``grid_cells`` cells; each obstacle takes
    a different cell at random and lies inside it at least ``gap_m / 2`` from the cell's edges,
    so obstacles are ``gap_m`` apart and ``wall_clearance_m`` from the walls.
    """

    grid_cells: int = static(4)
    """Cells per side of the placement grid (at most grid_cells^2 obstacles)."""
    wall_clearance_m: float = 1.0
    """Smallest gap between an obstacle and a wall."""
    gap_m: float = 1.0
    """Smallest gap between two obstacles; wider than twice a body's reach in a control step
    (0.81 m: the robot's 0.72 m footprint plus its top speed for 0.02 s each side,
    ``layouts.step_reach_m``), so the robot is never wedged between two and a body can reach
    only its nearest obstacle within a step."""
    box_probability: float = 0.5
    """Chance that an obstacle is a box (else a cylinder)."""
    box_half_min_m: float = 0.25
    """Smallest half side of a box (sides drawn per axis: 0.5 m to 1.5 m boxes)."""
    box_half_max_m: float = 0.75
    """Largest half side of a box."""
    cylinder_radius_min_m: float = 0.15
    """Smallest cylinder radius."""
    cylinder_radius_max_m: float = 0.40
    """Largest cylinder radius."""


@struct.dataclass
class WoodsCfg:
    """Trees of the woods: one trunk per ``spacing_m`` square cell, jittered inside it, on a
    tile of ``tile_cells`` x ``tile_cells`` cells repeated over the whole plane."""

    spacing_m: float = 5.0
    """Side of the cell holding one tree: density 1 / spacing^2 = 0.04 trees/m^2
    (400 stems per hectare)."""
    tile_cells: int = static(5)
    """Cells per side of the repeated tile (25 trees on a 25 m tile)."""
    gap_m: float = 1.0
    """Smallest gap between two trunks, as ``RoomCfg.gap_m``."""
    trunk_radius_min_m: float = 0.10
    """Smallest trunk radius."""
    trunk_radius_max_m: float = 0.25
    """Largest trunk radius."""

    @property
    def tile_m(self):
        """Side of the repeated tile."""
        return self.tile_cells * self.spacing_m


@struct.dataclass
class AvoidCfg:
    """How a target that slides along obstacles (every behaviour but bounce) keeps off them:
    it heads for the free direction nearest its behaviour's heading."""

    lookahead_m: float = 1.0
    """A direction is free when no obstacle, grown by the target's radius, lies within this
    distance along it (0.55 s at the top speed of 1.8 m/s)."""
    directions: int = static(16)
    """Candidate directions, evenly spread around the desired heading (every 22.5 deg)."""


@struct.dataclass
class TerrainCfg:
    """What a terrain does to the gait, as factors on the flat-ground ``BaseCfg`` values (1:
    no change). The target, an animal, is not slowed."""

    speed_scale: float = 1.0
    """Factor on the linear command limits (forward, backward, lateral)."""
    yaw_rate_scale: float = 1.0
    """Factor on the yaw-rate command limit."""
    climb_speed_scale: float = 1.0
    """Further factor on the commanded velocity's world-x component: stairs' steps run along
    world y, so this is the speed across them (climbing); along them it is 1."""
    noise_scale: float = 1.0
    """Factor on the gait noise (``gait_noise_mps``, ``gait_noise_yaw_rps``)."""
    lag_scale: float = 1.0
    """Factor on the tracking lag ``lag_s``."""


ROUGH = TerrainCfg(speed_scale=0.6, yaw_rate_scale=0.75, noise_scale=2.0, lag_scale=1.5)
"""Default of ``WorldCfg.rough`` (docs/scenes.md: the reasons)."""
STAIRS = TerrainCfg(
    speed_scale=0.8, yaw_rate_scale=0.75, climb_speed_scale=0.5, noise_scale=2.0, lag_scale=2.0
)
"""Default of ``WorldCfg.stairs``."""
