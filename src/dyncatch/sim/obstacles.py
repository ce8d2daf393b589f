"""Obstacles on the floor: axis-aligned boxes and vertical cylinders, in a fixed-shape pytree.

One ``Obstacles`` holds K obstacles of one environment (K is fixed by the scene, so a batch
of them jits and vmaps like the plane); a box has half sides ``half_m`` and radius 0, a
cylinder half sides 0 and a radius. Centres are stored in the local frame (``sim.frame``)
and move with it. A layout with ``period_m`` > 0 (the woods) repeats over the whole plane
with that period: every query uses the copy of each obstacle nearest its query point, and
``shifted`` keeps the stored centres within half a period of the robot.

Everything here is analytic and vectorised over obstacles (and rays): signed distances and
push-out for collision, entry/exit distances along rays for the range scan, the camera's line
of sight and the target's free-direction rule. A layout with one obstacle per cell of a grid
(``grid_cells`` > 0: the woods) also answers "which obstacles can be near this point" from
the point's cell, without testing every obstacle (``own_cell``, ``cell_block``).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dyncatch.sim.geometry import fan

_INF = np.float32(np.inf)
"""A numpy constant: one made with jnp at import would start a JAX backend before
``utils.jax_setup.setup_jax`` sets XLA's flags."""
_PARALLEL = 1e-12
"""A ray direction component below this is parallel to the box's sides."""


@struct.dataclass
class Obstacles:
    centre_xy_m: jax.Array
    """Centres in the local frame, (K, 2)."""
    half_m: jax.Array
    """Half sides of a box along x and y, (K, 2); zeros for a cylinder."""
    radius_m: jax.Array
    """Radius of a cylinder, (K,); 0 for a box."""
    period_m: jax.Array
    """Side of the tile a periodic layout repeats on, (); 0 for none."""
    corner_xy_m: jax.Array
    """Where a gridded layout's cells start (a corner of its tile) in the local frame, (2,);
    zeros for a layout without a grid. Moves with the centres."""
    boxes: bool = struct.field(pytree_node=False, default=True)
    """Static: the layout may hold boxes. False (the woods) skips the boxes' ray test."""
    grid_cells: int = struct.field(pytree_node=False, default=0)
    """Static: n > 0 for a periodic layout with one obstacle per cell of an n x n grid over
    its tile, obstacle k in cell (k % n, k // n) counted from ``corner_xy_m``, each at least
    the layout's gap / 2 inside its cell's edges (``layouts.woods_layout``); 0 for none."""

    @property
    def is_box(self) -> jax.Array:
        """(K,) bool."""
        return jnp.any(self.half_m > 0.0, axis=-1)

    def shifted(self, d_m: jax.Array) -> Obstacles:
        """The same obstacles in a frame moved by ``d_m`` (2,); a periodic layout's centres
        are brought within half a period of the new frame's origin."""
        return self.replace(
            centre_xy_m=nearest_image(self.centre_xy_m - d_m, self.period_m),
            corner_xy_m=nearest_image(self.corner_xy_m - d_m, self.period_m),
        )


def no_obstacles() -> Obstacles:
    """The empty layout (K = 0) of a scene without obstacles."""
    z = jnp.zeros((0,), jnp.float32)
    return Obstacles(
        centre_xy_m=jnp.zeros((0, 2), jnp.float32),
        half_m=jnp.zeros((0, 2), jnp.float32),
        radius_m=z,
        period_m=jnp.zeros((), jnp.float32),
        corner_xy_m=jnp.zeros((2,), jnp.float32),
    )


def _dot2(a: jax.Array, b: jax.Array) -> jax.Array:
    """a . b over the last axis of size 2, broadcast (...): written out, because XLA:CPU
    compiles a product or sum over an axis of 2 to a batched matrix product or a reduction
    that the element-wise work around it cannot fuse with (docs/performance.md)."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]


def nearest_image(offset_m: jax.Array, period_m: jax.Array) -> jax.Array:
    """Offsets (..., 2) reduced to the nearest copy under the period (unchanged if 0)."""
    periodic = period_m > 0.0
    p = jnp.where(periodic, period_m, 1.0)
    return jnp.where(periodic, offset_m - p * jnp.round(offset_m / p), offset_m)


def relative(obs: Obstacles, xy_m: jax.Array) -> jax.Array:
    """Centre minus ``xy_m`` (2,) for every obstacle, nearest copy, (K, 2)."""
    return nearest_image(obs.centre_xy_m - xy_m, obs.period_m)


def signed_distance(obs: Obstacles, xy_m: jax.Array, inflate_m=0.0):
    """(K,) distance from ``xy_m`` (2,) to each obstacle's surface less ``inflate_m``
    (negative inside), and (K, 2) the outward unit normals at the nearest surface point."""
    q = -relative(obs, xy_m)  # the point relative to each centre
    h = obs.half_m
    v = q - jnp.clip(q, -h, h)
    dist2 = _dot2(v, v)
    outside = dist2 > 0.0
    dist = jnp.sqrt(jnp.where(outside, dist2, 1.0))
    # Inside a box's core (or at a cylinder's axis): leave by the nearest side.
    pen = jnp.abs(q) - h
    along_x = pen[:, 0] >= pen[:, 1]
    sign = jnp.where(q >= 0.0, 1.0, -1.0)
    n_in = jnp.where(along_x[:, None], sign * jnp.array([1.0, 0.0]), sign * jnp.array([0.0, 1.0]))
    normal = jnp.where(outside[:, None], v / dist[:, None], n_in)
    depth = jnp.where(outside, dist, jnp.max(pen, axis=-1))
    return depth - obs.radius_m - inflate_m, normal


def nearest(obs: Obstacles, xy_m: jax.Array) -> Obstacles:
    """The obstacle nearest ``xy_m`` (2,) by signed distance, as a layout of one (K = 1)."""
    sd, _ = signed_distance(obs, xy_m)
    # The first index of the smallest, as two plain reductions: XLA:CPU ran argmin's paired
    # (value, index) reduction at 0.75 ms per call for 4096 x 25 trunks, these at about
    # 0.1-0.2 ms (profiled, 2026-12-02).
    i = jnp.min(jnp.where(sd == jnp.min(sd), jnp.arange(sd.shape[0]), sd.shape[0] - 1))

    def take(x):
        return jax.lax.dynamic_slice_in_dim(x, i, 1)

    return obs.replace(
        centre_xy_m=take(obs.centre_xy_m), half_m=take(obs.half_m), radius_m=take(obs.radius_m)
    )


def _take(obs: Obstacles, index: jax.Array) -> Obstacles:
    """The obstacles at ``index`` (J,), as a layout of J without a grid."""
    return obs.replace(
        centre_xy_m=obs.centre_xy_m[index],
        half_m=obs.half_m[index],
        radius_m=obs.radius_m[index],
        grid_cells=0,
    )


def _wrap(cell: jax.Array, n: int) -> jax.Array:
    """Whole-number float cell indices brought into [0, n) (the tile repeats)."""
    return cell - n * jnp.floor(cell / n)


def _cell_of(obs: Obstacles, xy_m: jax.Array) -> tuple[jax.Array, jax.Array]:
    """The grid cell holding ``xy_m`` (2,) as (2,) float indices in [0, n), and the point's
    place inside that cell, (2,) in [0, 1)."""
    n = obs.grid_cells
    u = (xy_m - obs.corner_xy_m) / (obs.period_m / n)
    cell = jnp.floor(u)
    return _wrap(cell, n), u - cell


def _flat(obs: Obstacles, cell: jax.Array) -> jax.Array:
    """Obstacle index of (..., 2) float cell indices in [0, n)."""
    return (cell[..., 0] + obs.grid_cells * cell[..., 1]).astype(jnp.int32)


def own_cell(obs: Obstacles, xy_m: jax.Array) -> Obstacles:
    """The obstacle of the grid cell holding ``xy_m`` (2,), as a layout of one (K = 1).

    Every other obstacle's surface is at least the layout's gap / 2 from the point (each
    lies that far inside its own cell), so for a body that reaches less than that within a
    control step (``layouts.step_reach_m``, a config check) this one is the only obstacle it
    can touch: what ``nearest`` gives such a body, without testing every obstacle.
    """
    cell, _ = _cell_of(obs, xy_m)
    return _take(obs, _flat(obs, cell)[None])


def cell_block(obs: Obstacles, xy_m: jax.Array) -> Obstacles:
    """The obstacles of the 2 x 2 block of grid cells nearest ``xy_m`` (2,): its own cell and
    the neighbours on the sides of the cell it is nearer to, as a layout of four (K = 4).

    Every other obstacle's surface is at least (cell side + gap) / 2 from the point: a test
    that reaches less far than that (the flee rule's lookahead plus the target's radius, a
    config check in ``layouts.woods_checks``) gives the same answer on these four as on the
    whole layout. On a grid of one cell per side the block repeats that cell, which is as
    exact (each query takes an obstacle's nearest copy).
    """
    n = obs.grid_cells
    cell, place = _cell_of(obs, xy_m)
    step = jnp.where(place >= 0.5, 1.0, -1.0)
    other = _wrap(cell + step, n)
    xs = jnp.stack([cell[0], other[0], cell[0], other[0]])
    ys = jnp.stack([cell[1], cell[1], other[1], other[1]])
    return _take(obs, _flat(obs, jnp.stack([xs, ys], axis=-1)))


def push_out(obs: Obstacles, xy_m: jax.Array, radius_m) -> tuple[jax.Array, jax.Array]:
    """A body of ``radius_m`` at ``xy_m`` (2,) moved out of every obstacle along the normal
    (it slides along the surface): the new position (2,) and the normals of the obstacles it
    touched, zero elsewhere, (K, 2). Exact while no point is within ``radius_m`` of two
    obstacles at once, which the layouts' gaps guarantee."""
    sd, normal = signed_distance(obs, xy_m, radius_m)
    depth = jnp.maximum(-sd, 0.0)
    touched = jnp.where((depth > 0.0)[:, None], normal, 0.0)
    return xy_m + jnp.sum(depth[:, None] * normal, axis=0), touched


def ray_intervals(obs: Obstacles, origin_xy_m: jax.Array, dirs: jax.Array, inflate_m=0.0):
    """Where rays from ``origin_xy_m`` (2,) along unit ``dirs`` (N, 2) enter and leave each
    obstacle grown by ``inflate_m`` (a box by its half sides: square corners): (t_in, t_out),
    each (N, K) in metres along the ray (negative behind the origin); t_in = +inf, t_out =
    -inf where the line misses."""
    rel = relative(obs, origin_xy_m)  # (K, 2)
    tc_in, tc_out = _cylinder_intervals(obs, rel, dirs, inflate_m)
    if not obs.boxes:
        return tc_in, tc_out
    # Boxes: the slab test per axis.
    h = (obs.half_m + inflate_m)[None]  # (1, K, 2)
    u = dirs[:, None, :]  # (N, 1, 2)
    parallel = jnp.abs(u) < _PARALLEL
    inv = 1.0 / jnp.where(parallel, 1.0, u)
    t1, t2 = (rel - h) * inv, (rel + h) * inv
    inside = (jnp.abs(rel) <= h)[..., :]
    lo = jnp.where(parallel, jnp.where(inside, -_INF, _INF), jnp.minimum(t1, t2))
    hi = jnp.where(parallel, jnp.where(inside, _INF, -_INF), jnp.maximum(t1, t2))
    tb_in = jnp.maximum(lo[..., 0], lo[..., 1])
    tb_out = jnp.minimum(hi[..., 0], hi[..., 1])
    hit_b = tb_in <= tb_out
    tb_in, tb_out = jnp.where(hit_b, tb_in, _INF), jnp.where(hit_b, tb_out, -_INF)
    box = obs.is_box[None]
    return jnp.where(box, tb_in, tc_in), jnp.where(box, tb_out, tc_out)


def _cylinder_intervals(obs: Obstacles, rel: jax.Array, dirs: jax.Array, inflate_m):
    """(t_in, t_out) (N, K) of rays from the origin along ``dirs`` (N, 2) through cylinders
    at ``rel`` (K, 2) from it: |t u - rel| = r."""
    r = obs.radius_m + inflate_m
    b = _dot2(dirs[:, None, :], rel[None])  # (N, K)
    disc = b * b - (_dot2(rel, rel) - r * r)
    sq = jnp.sqrt(jnp.maximum(disc, 0.0))
    hit = disc >= 0.0
    return jnp.where(hit, b - sq, _INF), jnp.where(hit, b + sq, -_INF)


def ray_distances(obs: Obstacles, origin_xy_m: jax.Array, dirs: jax.Array) -> jax.Array:
    """Distance along each ray (N,) to the first obstacle surface, +inf where none; 0 from
    inside one."""
    t_in, t_out = ray_intervals(obs, origin_xy_m, dirs)
    t = jnp.where(t_out >= 0.0, jnp.maximum(t_in, 0.0), _INF)
    return jnp.min(t, axis=-1, initial=_INF)


def line_of_sight(obs: Obstacles, from_xy_m: jax.Array, to_xy_m: jax.Array) -> jax.Array:
    """() bool: no obstacle cuts the segment between the two points."""
    d = to_xy_m - from_xy_m
    length = jnp.sqrt(jnp.sum(d * d))
    u = d / jnp.maximum(length, 1e-9)
    t_in, t_out = ray_intervals(obs, from_xy_m, u[None])
    return ~jnp.any((t_in < length) & (t_out > 0.0))


def nearest_m(obs: Obstacles, xy_m: jax.Array, radius_m=0.0) -> jax.Array:
    """() distance from a body of ``radius_m`` at ``xy_m`` to the nearest obstacle, +inf if
    there is none (what eq. 10's weights g(d_rob,obst) read)."""
    sd, _ = signed_distance(obs, xy_m, radius_m)
    return jnp.min(sd, initial=_INF)


def free_heading(
    obs: Obstacles,
    xy_m: jax.Array,
    desired_rad: jax.Array,
    radius_m,
    lookahead_m,
    num_directions: int,
) -> jax.Array:
    """The free direction nearest ``desired_rad`` for a body of ``radius_m`` at ``xy_m``.

    Candidates are ``desired + k * 2 pi / num_directions`` for k = 0, 1, -1, 2, -2, ...
    (nearest first, left before right); one is free when no obstacle grown by the body's
    radius lies within ``lookahead_m`` along it (heading away from or along a surface it
    touches is free). If none is, the desired heading is kept.
    """
    k = np.arange(num_directions)
    offsets = np.where(k % 2 == 1, (k + 1) // 2, -(k // 2)) * (2.0 * np.pi / num_directions)
    cand = desired_rad + jnp.asarray(offsets, jnp.float32)
    dirs = fan(desired_rad, offsets)
    t_in, t_out = ray_intervals(obs, xy_m, dirs, radius_m)
    blocked = jnp.any((t_out > 1e-4) & (t_in < lookahead_m), axis=-1)
    first = jnp.argmax(~blocked)
    return jnp.where(jnp.any(~blocked), cand[first], desired_rad)


def reflect_heading(heading_rad: jax.Array, touched: jax.Array) -> jax.Array:
    """A heading mirrored off every surface it moves into (``touched`` normals (K, 2), zero
    where none), as the bounce target meets an obstacle."""
    u = jnp.stack([jnp.cos(heading_rad), jnp.sin(heading_rad)])
    into = jnp.minimum(_dot2(touched, u), 0.0)  # (K,)
    u = u - 2.0 * jnp.sum(into[:, None] * touched, axis=0)
    hit = jnp.any(into < 0.0)
    return jnp.where(hit, jnp.arctan2(u[1], u[0]), heading_rad)
