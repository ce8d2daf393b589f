"""Obstacle geometry against hand-worked distances: ray casts, signed distances, push-out,
the free-direction rule, reflection and the periodic copies of the woods."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.layouts import woods_layout
from dyncatch.sim.obstacles import (
    cell_block,
    free_heading,
    line_of_sight,
    nearest,
    nearest_m,
    own_cell,
    push_out,
    ray_distances,
    reflect_heading,
    signed_distance,
)

from .helpers import obstacles


def _dirs(*deg):
    a = np.radians(deg)
    return jnp.asarray(np.stack([np.cos(a), np.sin(a)], -1), jnp.float32)


# A cylinder of radius 0.5 at (5, 0), a 2 m x 1 m box centred at (0, 3), a cylinder of
# radius 1 at (4, 4) on the diagonal.
SCENE = obstacles(boxes=[(0.0, 3.0, 1.0, 0.5)], cylinders=[(5.0, 0.0, 0.5), (4.0, 4.0, 1.0)])


class TestRayCast:
    def test_distances_equal_the_hand_worked_ones(self):
        d = ray_distances(SCENE, jnp.zeros(2), _dirs(0, 90, 45, 180, -90))
        expected = [
            5.0 - 0.5,  # straight at the cylinder's centre
            3.0 - 0.5,  # the box's lower face
            4.0 * math.sqrt(2.0) - 1.0,  # the diagonal cylinder
            math.inf,  # nothing behind
            math.inf,
        ]
        np.testing.assert_allclose(d, expected, rtol=1e-6)

    def test_a_grazing_ray_and_an_off_centre_chord(self):
        # From (0, 0.3) along +x the cylinder at (5, 0) r 0.5 is entered at
        # x = 5 - sqrt(0.25 - 0.09) = 4.6.
        d = ray_distances(SCENE, jnp.array([0.0, 0.3]), _dirs(0))
        np.testing.assert_allclose(d, [5.0 - 0.4], rtol=1e-6)
        # A ray parallel to the box's side, at its edge x = 1: it touches the face y = 2.5.
        d = ray_distances(SCENE, jnp.array([1.0, 0.0]), _dirs(90))
        np.testing.assert_allclose(d, [2.5], rtol=1e-6)
        d = ray_distances(SCENE, jnp.array([1.01, 0.0]), _dirs(90))
        assert float(d[0]) == math.inf

    def test_a_box_corner_from_a_slanted_ray(self):
        box = obstacles(boxes=[(3.0, 3.0, 1.0, 1.0)])
        # Along the diagonal the corner (2, 2) is hit at 2 sqrt(2).
        np.testing.assert_allclose(ray_distances(box, jnp.zeros(2), _dirs(45)), [2 * 2**0.5])
        # At atan(1/3) the ray meets the face x = 2 at y = 2/3, below the box: a miss; at
        # atan(2.5 / 2) it meets x = 2 at y = 2.5, inside: distance hypot(2, 2.5).
        assert (
            float(ray_distances(box, jnp.zeros(2), _dirs(math.degrees(math.atan(1 / 3))))[0])
            == math.inf
        )
        a = math.degrees(math.atan2(2.5, 2.0))
        np.testing.assert_allclose(
            ray_distances(box, jnp.zeros(2), _dirs(a)), [math.hypot(2.0, 2.5)], rtol=1e-6
        )


class TestDistanceAndContact:
    def test_signed_distance_outside_and_inside(self):
        p = jnp.array([5.0, 2.0])
        sd, normal = signed_distance(SCENE, p)
        # Box: nearest point (1, 2.5); cylinder at (5, 0): 2 - 0.5; at (4, 4): sqrt(5) - 1.
        np.testing.assert_allclose(sd, [math.hypot(4.0, 0.5), 1.5, math.sqrt(5.0) - 1.0], rtol=1e-6)
        np.testing.assert_allclose(normal[1], [0.0, 1.0], atol=1e-6)
        # Inside the box, 0.1 m below its top face: -0.1, leaving upward.
        sd, normal = signed_distance(SCENE, jnp.array([0.2, 3.4]))
        np.testing.assert_allclose(sd[0], -0.1, atol=1e-6)
        np.testing.assert_allclose(normal[0], [0.0, 1.0])
        # The nearest is the diagonal cylinder, sqrt(5) - 1 from its surface.
        near = nearest_m(SCENE, jnp.array([5.0, 2.0]), 0.3)
        np.testing.assert_allclose(near, math.sqrt(5.0) - 1.0 - 0.3, rtol=1e-6)

    def test_push_out_slides_a_body_onto_the_surface(self):
        # A body of radius 0.3 at (4.5, 0.4) overlaps the cylinder at (5, 0) r 0.5: it goes
        # out along the radius to distance 0.8 from the centre.
        xy, touched = push_out(SCENE, jnp.array([4.5, 0.4]), 0.3)
        v = np.array([-0.5, 0.4])
        np.testing.assert_allclose(xy, [5.0, 0.0] + 0.8 * v / np.linalg.norm(v), rtol=1e-6)
        np.testing.assert_allclose(touched[1], v / np.linalg.norm(v), rtol=1e-6)
        assert not bool(jnp.any(touched[0])) and not bool(jnp.any(touched[2]))
        # A body clear of everything is not moved.
        far = jnp.array([-3.0, -3.0])
        np.testing.assert_array_equal(push_out(SCENE, far, 0.3)[0], far)

    def test_line_of_sight(self):
        assert not bool(line_of_sight(SCENE, jnp.zeros(2), jnp.array([8.0, 0.0])))
        assert bool(line_of_sight(SCENE, jnp.zeros(2), jnp.array([4.0, 0.0])))  # in front
        assert bool(line_of_sight(SCENE, jnp.zeros(2), jnp.array([8.0, -2.0])))


class TestTargetRules:
    def test_free_heading_turns_by_the_smallest_step_that_clears(self):
        # A cylinder of radius 0.3 one metre ahead, grown by the target's 0.1: a ray at
        # angle a clears it if sin(a) > 0.4 / 1.0, so 22.5 deg (0.383) is blocked and 45 deg
        # the nearest free direction; left comes before right.
        tree = obstacles(cylinders=[(1.0, 0.0, 0.3)])
        h = free_heading(tree, jnp.zeros(2), jnp.zeros(()), 0.1, 1.5, 16)
        np.testing.assert_allclose(h, math.radians(45.0), atol=1e-6)
        # Out of the lookahead the desired heading is kept.
        h = free_heading(tree, jnp.zeros(2), jnp.zeros(()), 0.1, 0.5, 16)
        assert float(h) == 0.0
        # Nothing is free from inside a ring of trees: the desired heading is kept.
        ring = obstacles(
            cylinders=[(math.cos(a), math.sin(a), 0.45) for a in np.arange(8) * np.pi / 4]
        )
        assert float(
            free_heading(ring, jnp.zeros(2), jnp.full((), 0.3), 0.1, 1.5, 16)
        ) == np.float32(0.3)

    def test_reflection_mirrors_the_heading_about_the_normal(self):
        touched = jnp.array([[-1.0, 0.0]])  # a surface facing -x
        h = reflect_heading(jnp.array(math.radians(30.0)), touched)
        np.testing.assert_allclose(h, math.radians(150.0), atol=1e-6)
        # Moving away from it already: unchanged.
        h = reflect_heading(jnp.array(math.radians(120.0)), touched)
        np.testing.assert_allclose(h, math.radians(120.0), atol=1e-6)


def test_periodic_copies_are_seen_from_anywhere():
    # A tree at the origin of a 25 m tile is also at (25, 0), (-25, 0), ...
    tree = obstacles(cylinders=[(0.0, 0.0, 0.5)], period_m=25.0)
    np.testing.assert_allclose(ray_distances(tree, jnp.array([21.0, 0.0]), _dirs(0)), [3.5])
    np.testing.assert_allclose(ray_distances(tree, jnp.array([1e4 + 3.0, 0.0]), _dirs(180)), [2.5])
    # Moving the frame 10 km keeps the stored centre within half a tile of the new origin.
    moved = tree.shifted(jnp.array([1e4 + 3.0, -7.0]))
    assert bool(jnp.all(jnp.abs(moved.centre_xy_m) <= 12.5))
    np.testing.assert_allclose(moved.centre_xy_m, [[-3.0, 7.0]], atol=1e-3)


def test_a_cylinders_only_layout_skips_the_box_test_with_the_same_result():
    trees = obstacles(cylinders=[(5.0, 0.0, 0.5), (4.0, 4.0, 1.0), (-3.0, 1.0, 0.2)])
    dirs = _dirs(*np.arange(0, 360, 7.5))
    both = ray_distances(trees, jnp.array([0.3, -0.2]), dirs)
    only = ray_distances(trees.replace(boxes=False), jnp.array([0.3, -0.2]), dirs)
    np.testing.assert_array_equal(only, both)
    assert np.isfinite(np.asarray(both)).sum() >= 3


def _woods_points(seed: int, count: int = 4000):
    """A woods layout seen from a frame moved by a random offset (so the grid's corner is
    not at the origin), and random points over two tiles in that frame."""
    cfg = WorldCfg().for_scene("woods_plane")
    k_layout, k_shift, k_points = jax.random.split(jax.random.key(seed), 3)
    trees = woods_layout(k_layout, cfg).shifted(jax.random.uniform(k_shift, (2,), maxval=1e3))
    tile = cfg.woods.tile_m
    points = jax.random.uniform(k_points, (count, 2), minval=-tile, maxval=tile)
    return cfg, trees, points


def _surface_m(trees, points):
    """(P, K) distance from each point to each trunk's surface."""
    return jax.vmap(lambda p: signed_distance(trees, p)[0])(points)


@pytest.mark.parametrize("seed", [0, 1])
def test_a_points_own_cell_holds_every_trunk_within_half_the_gap(seed):
    # What the step's push-outs rely on (sim.env): a body within the gap / 2 of a trunk
    # finds that trunk, and only it, as its own cell's, as nearest would.
    cfg, trees, points = _woods_points(seed)
    sd = np.asarray(_surface_m(trees, points))
    mine = jax.vmap(lambda p: own_cell(trees, p))(points)
    mine_sd = np.asarray(jax.vmap(lambda o, p: signed_distance(o, p)[0])(mine, points))[:, 0]
    near = sd.min(-1) < 0.5 * cfg.woods.gap_m
    assert near.sum() > 50
    np.testing.assert_array_equal(mine_sd[near], sd[near].min(-1))
    # Everywhere, no other trunk is within gap / 2 of the point.
    other = np.where(np.isclose(sd, mine_sd[:, None]), np.inf, sd)
    assert other.min() >= 0.5 * cfg.woods.gap_m - 1e-4
    # And the nearest obstacle agrees wherever one is that close.
    nearest_sd = jax.vmap(lambda p: signed_distance(nearest(trees, p), p)[0][0])(points)
    np.testing.assert_array_equal(np.asarray(nearest_sd)[near], mine_sd[near])


@pytest.mark.parametrize("seed", [0, 1])
def test_the_2x2_cell_block_holds_every_trunk_the_flee_rule_can_meet(seed):
    cfg, trees, points = _woods_points(seed)
    sd = np.asarray(_surface_m(trees, points))
    block = jax.vmap(lambda p: cell_block(trees, p))(points)
    block_sd = np.asarray(jax.vmap(lambda o, p: signed_distance(o, p)[0])(block, points))
    bound = 0.5 * (cfg.woods.spacing_m + cfg.woods.gap_m)
    # Every trunk within (spacing + gap) / 2 of the point is in its block ...
    for row, found in zip(sd, block_sd, strict=True):
        close = np.sort(row[row < bound])
        assert np.all(np.isin(close, found)), (close, found)
    # ... and the rule turns the same way on the block as on the whole layout.
    headings = jax.random.uniform(jax.random.key(seed + 7), (points.shape[0],), maxval=6.3)
    a, r = cfg.avoid, cfg.target.radius_m

    def rule(obs, p, h):
        return free_heading(obs, p, h, r, a.lookahead_m, a.directions)

    on_block = jax.vmap(rule)(block, points, headings)
    on_all = jax.vmap(rule, in_axes=(None, 0, 0))(trees, points, headings)
    turned = np.asarray(on_all) != np.asarray(headings)
    assert turned.sum() > 20
    np.testing.assert_array_equal(np.asarray(on_block), np.asarray(on_all))
