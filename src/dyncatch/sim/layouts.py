"""Obstacle layouts of the scenes, drawn per episode: ``(key, world) -> Obstacles`` in world
coordinates (the frame at reset). Placement is by grid cells, not by rejection, so it is
branch-free and the gaps between obstacles hold by construction."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp

from dyncatch.sim.obstacles import Obstacles

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg


def _in_cells(u, cell_lo, cell_m, gap_m, extent):
    """Centres (K, 2) at uniforms ``u`` (K, 2) in cells with lower corners ``cell_lo`` (K, 2)
    and side ``cell_m``, keeping a body of half extents ``extent`` (K, 2) ``gap_m / 2``
    inside."""
    lo = cell_lo + 0.5 * gap_m + extent
    hi = cell_lo + cell_m - 0.5 * gap_m - extent
    return lo + u * (hi - lo)


def room_layout(key: jax.Array, cfg: WorldCfg, count: int) -> Obstacles:
    """``count`` boxes and cylinders in distinct random cells of the room's grid."""
    rc = cfg.room
    n = rc.grid_cells
    k_cell, k_draw = jax.random.split(key)
    # The cells of the ``count`` largest of n^2 uniforms: a uniform random subset, cheaper
    # than a permutation (a sort) in the auto-reset that runs every step.
    _, cells = jax.lax.top_k(jax.random.uniform(k_cell, (n * n,)), count)
    ij = jnp.stack([cells % n, cells // n], axis=-1).astype(jnp.float32)
    start = rc.wall_clearance_m - 0.5 * rc.gap_m
    cell_m = (cfg.arena.size_m - 2.0 * start) / n
    # One draw for everything else: kind, two half sides, radius, position in the cell.
    u = jax.random.uniform(k_draw, (count, 6))
    is_box = u[:, 0] < rc.box_probability
    half = rc.box_half_min_m + u[:, 1:3] * (rc.box_half_max_m - rc.box_half_min_m)
    radius = rc.cylinder_radius_min_m + u[:, 3] * (
        rc.cylinder_radius_max_m - rc.cylinder_radius_min_m
    )
    half = jnp.where(is_box[:, None], half, 0.0)
    radius = jnp.where(is_box, 0.0, radius)
    extent = jnp.where(is_box[:, None], half, radius[:, None])
    centre = _in_cells(u[:, 4:6], start + ij * cell_m, cell_m, rc.gap_m, extent)
    return Obstacles(centre, half, radius, jnp.zeros((), jnp.float32), jnp.zeros(2, jnp.float32))


def woods_layout(key: jax.Array, cfg: WorldCfg) -> Obstacles:
    """One trunk per cell of a ``tile_cells`` x ``tile_cells`` tile, repeated over the plane
    (a grid layout: trunk k in cell (k % n, k // n) of the tile starting at the origin)."""
    wc = cfg.woods
    n = wc.tile_cells
    cells = jnp.arange(n * n)
    ij = jnp.stack([cells % n, cells // n], axis=-1).astype(jnp.float32)
    u = jax.random.uniform(key, (n * n, 3))
    radius = wc.trunk_radius_min_m + u[:, 0] * (wc.trunk_radius_max_m - wc.trunk_radius_min_m)
    centre = _in_cells(u[:, 1:], ij * wc.spacing_m, wc.spacing_m, wc.gap_m, radius[:, None])
    period = jnp.asarray(wc.tile_m, jnp.float32)
    half = jnp.zeros((n * n, 2), jnp.float32)
    corner = jnp.zeros(2, jnp.float32)
    return Obstacles(centre, half, radius, period, corner, boxes=False, grid_cells=n)


def step_reach_m(cfg: WorldCfg) -> float:
    """The farthest an obstacle's surface can be from a body's centre at the start of a
    control step and still be touched during it: the footprint radius plus the top speed
    times the step, the larger of the robot's and the target's (0.36 + 2.24 x 0.02 m by
    default). Gaps between obstacles wider than twice this leave one obstacle in reach, so
    the step tests each body against its nearest one (``sim.env``)."""
    b, t, dt_s = cfg.base, cfg.target, cfg.episode.dt_s
    robot_mps = math.hypot(max(b.max_forward_mps, b.max_backward_mps), b.max_lateral_mps)
    return max(b.radius_m + robot_mps * dt_s, t.radius_m + t.speed_max_mps * dt_s)


def _gap_check(gap_m: float, field: str, cfg: WorldCfg) -> tuple[bool, str, str]:
    reach = step_reach_m(cfg)
    return (
        gap_m > 2 * reach,
        field,
        f"must exceed {2 * reach:.3f} m, twice a body's footprint radius plus the farthest it "
        "moves in a control step: the step tests each body against its nearest obstacle only",
    )


def room_checks(cfg: WorldCfg, count: int) -> list[tuple[bool, str, str]]:
    """The room's constants can hold ``count`` obstacles with their gaps."""
    r, body = cfg.room, cfg.base.radius_m
    start = r.wall_clearance_m - 0.5 * r.gap_m
    cell = (cfg.arena.size_m - 2 * start) / max(r.grid_cells, 1)
    widest = 2 * max(r.box_half_max_m, r.cylinder_radius_max_m)
    return [
        (
            r.grid_cells >= 1 and count <= r.grid_cells**2,
            "room.grid_cells",
            f"the grid needs a cell for each of the {count} obstacles",
        ),
        _gap_check(r.gap_m, "room.gap_m", cfg),
        (
            r.wall_clearance_m > 2 * body,
            "room.wall_clearance_m",
            f"must exceed the robot's footprint diameter {2 * body:.2f} m (it could be wedged)",
        ),
        (
            0 < r.box_half_min_m <= r.box_half_max_m
            and 0 < r.cylinder_radius_min_m <= r.cylinder_radius_max_m,
            "room.box_half_*/cylinder_radius_*",
            "need 0 < min <= max",
        ),
        (
            cell - r.gap_m >= widest,
            "room.grid_cells",
            f"a {cell:.2f} m cell less the {r.gap_m} m gap cannot hold a {widest:.2f} m "
            "obstacle; use fewer cells, a smaller gap or smaller obstacles",
        ),
        (0 <= r.box_probability <= 1, "room.box_probability", "must lie in [0, 1]"),
    ]


def woods_checks(cfg: WorldCfg) -> list[tuple[bool, str, str]]:
    """The woods' constants keep trunks apart and the tile wide enough for every reach."""
    w = cfg.woods
    reach = max(cfg.scene.scan_range_m, cfg.sensor.range_m) + w.trunk_radius_max_m
    return [
        _gap_check(w.gap_m, "woods.gap_m", cfg),
        (
            0 < w.trunk_radius_min_m <= w.trunk_radius_max_m,
            "woods.trunk_radius_*",
            "need 0 < min <= max",
        ),
        (
            w.spacing_m - w.gap_m >= 2 * w.trunk_radius_max_m,
            "woods.spacing_m",
            "a cell less the gap must hold the widest trunk",
        ),
        (
            cfg.avoid.lookahead_m + cfg.target.radius_m < 0.5 * (w.spacing_m + w.gap_m),
            "avoid.lookahead_m",
            f"plus the target's radius must stay below {0.5 * (w.spacing_m + w.gap_m):.2f} m, "
            "half of woods.spacing_m + woods.gap_m: the flee rule tests the trunks of the 2 x 2 "
            "cells nearest the target only (obstacles.cell_block)",
        ),
        (
            w.tile_cells * w.spacing_m >= 2 * reach,
            "woods.tile_cells",
            f"the tile must be at least {2 * reach:.1f} m (twice the scan or camera range plus "
            "a trunk) so that every tree in reach is seen once",
        ),
    ]
