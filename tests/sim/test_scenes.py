"""Rooms and woods (issue 13): layouts, the scan and the camera among obstacles, collision
under random actions in every scene, the target's rules, terrain on the gait, per-scene
defaults and validation."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dyncatch.sim import env
from dyncatch.sim.api import JaxCatchEnv, obs_dim
from dyncatch.sim.base import add_gait_noise, base_substep
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.frame import in_scene_frame, recentre
from dyncatch.sim.layouts import step_reach_m
from dyncatch.sim.obstacles import Obstacles, signed_distance
from dyncatch.sim.scan import robot_clearance_m
from dyncatch.sim.scene_cfg import TerrainCfg, WoodsCfg
from dyncatch.sim.scenes import SCENES, get_scene
from dyncatch.sim.state import Obs
from dyncatch.sim.terrain import terrain_command
from dyncatch.sim.validate import ConfigError, validate_world

from .helpers import fixed_rollout, obstacles, place, random_rollout, world_xy

NEW_SCENES = ["room_0", "room_4", "room_8", "woods_plane", "woods_rough", "woods_stairs"]
STILL = jnp.zeros(3)


def _withobstacles(state, obstacles_world: Obstacles):
    """``state`` with its obstacles replaced by world-placed ones (robot-centred frame)."""
    return recentre(in_scene_frame(state).replace(obstacles=obstacles_world))


def _start(cfg, obstacles_world, **where):
    s = jax.jit(env.reset)(jax.random.key(0), cfg)
    return place(_withobstacles(s, obstacles_world), **where)


def test_every_scene_is_registered():
    assert set(NEW_SCENES) < set(SCENES)
    for name in NEW_SCENES:
        scene = get_scene(name)
        assert scene.walls == name.startswith("room") and scene.layout is not None
        assert (scene.duration_s, scene.scan_rays) == (40.0, 32)  # the paper's 40 s
    assert get_scene("woods_plane").terrain is None
    # Each woods' ground reads its own field of the world: two made-up values tell them apart.
    world = WorldCfg().replace(rough=TerrainCfg(speed_scale=0.1), stairs=TerrainCfg(lag_scale=3))
    assert get_scene("woods_rough").terrain(world) == TerrainCfg(speed_scale=0.1)
    assert get_scene("woods_stairs").terrain(world) == TerrainCfg(lag_scale=3)


def test_for_scene_sets_the_scenes_length_and_rays_and_back():
    woods = WorldCfg().for_scene("woods_plane")
    assert (woods.episode.duration_s, woods.scene.scan_rays) == (40.0, 32)
    back = woods.for_scene("open_plane")
    assert (back.episode.duration_s, back.scene.scan_rays) == (20.0, 8)


def test_room_obstacles_keep_their_gaps_from_each_other_and_the_walls():
    cfg = WorldCfg().for_scene("room_8")
    keys = jax.random.split(jax.random.key(2), 64)
    obs = jax.vmap(get_scene("room_8").layout, in_axes=(0, None))(keys, cfg)
    c, ext = (
        np.asarray(obs.centre_xy_m),
        np.asarray(jnp.where(obs.is_box[..., None], obs.half_m, obs.radius_m[..., None])),
    )
    lo, hi = c - ext, c + ext
    size, rc = cfg.arena.size_m, cfg.room
    assert lo.min() >= rc.wall_clearance_m - 1e-5 and hi.max() <= size - rc.wall_clearance_m + 1e-5
    # Bounding boxes of any two obstacles are at least gap_m apart along some axis.
    i, j = np.triu_indices(8, 1)
    gap = np.maximum(lo[:, j] - hi[:, i], lo[:, i] - hi[:, j]).max(-1)
    assert gap.min() >= rc.gap_m - 1e-5
    assert 0 < float(obs.is_box.mean()) < 1  # both kinds occur


class TestSensing:
    # A cylinder r 0.5 three metres ahead of a robot at (8, 8) and a 2 m x 1 m box two
    # metres to its left; the room's walls are 8 m away on every side.
    OBST = obstacles(boxes=[(8.0, 10.0, 1.0, 0.5)], cylinders=[(11.0, 8.0, 0.5)])

    @pytest.mark.parametrize(
        ("scene", "expected"),
        [
            ("room_0", [2.5, 10, 1.5, 10, 8.0, 10, 8.0, 10]),  # diagonals: walls at 11.3 m
            ("woods_plane", [2.5, 10, 1.5, 10, 10, 10, 10, 10]),  # no walls
            ("open_plane", [10] * 8),  # nothing at all, whatever the state holds
        ],
    )
    def test_the_scan_reads_hand_placedobstacles(self, scene, expected):
        cfg = WorldCfg().with_scene(scene)
        s = _start(cfg, self.OBST, robot_xy=(8.0, 8.0), robot_yaw=0.0)
        np.testing.assert_allclose(env.observe(s, cfg).scan_m, expected, rtol=1e-5)
        # Turned left by 90 deg, the first ray reads the box.
        s = place(s, robot_yaw=math.pi / 2)
        assert abs(float(env.observe(s, cfg).scan_m[0]) - expected[2]) < 1e-4

    def test_the_clearance_eq_10_will_read(self):
        cfg = WorldCfg().with_scene("room_0")
        s = _start(cfg, self.OBST, robot_xy=(8.0, 8.0), robot_yaw=0.0)
        r = cfg.base.radius_m
        # The box's face is 1.5 m from the base centre, the cylinder 2.5 m, the walls 8 m.
        np.testing.assert_allclose(robot_clearance_m(s, cfg), 1.5 - r, rtol=1e-5)
        s = place(s, robot_xy=(8.0, 1.0))  # now a wall is nearest
        np.testing.assert_allclose(robot_clearance_m(s, cfg), 1.0 - r, rtol=1e-5)
        open_ = WorldCfg()
        assert (
            float(robot_clearance_m(jax.jit(env.reset)(jax.random.key(0), open_), open_)) == np.inf
        )

    @pytest.mark.parametrize("scene", ["room_0", "woods_plane"])
    def test_a_target_behind_an_obstacle_is_not_seen(self, scene):
        cfg = WorldCfg().with_scene(scene).with_behavior("reactive").with_speed(0.0)
        where = dict(robot_xy=(4.0, 8.0), robot_yaw=0.0, target_xy=(9.0, 8.0))
        tree = obstacles(cylinders=[(6.5, 8.0, 0.5)])
        # 25 still steps: the camera's next frame (step 25) is captured and delivered.
        _, hidden, _ = fixed_rollout(_start(cfg, tree, **where), STILL, cfg, 25)
        assert float(hidden.visible[-1]) == 0.0
        # The same with the tree taken out of the way (40 m off: same shapes, no recompile).
        gone = tree.replace(centre_xy_m=tree.centre_xy_m + 40.0)
        states, seen, _ = fixed_rollout(_start(cfg, gone, **where), STILL, cfg, 25)
        assert float(seen.visible[-1]) == 1.0
        np.testing.assert_allclose(world_xy(states, states.sensor.obs_xy_m)[-1], [9.0, 8.0])


# Every new scene, each with a behaviour (all four covered), so that each compiles once.
PAIRS = [
    ("room_0", "circle"),
    ("room_4", "bounce"),
    ("room_8", "reactive"),
    ("woods_plane", "random_reactive"),
    ("woods_rough", "bounce"),
    ("woods_stairs", "reactive"),
]


def _sd(states, xy, radius):
    """Signed distance of a body to every obstacle, (T, B, K)."""
    f = jax.vmap(jax.vmap(lambda o, p: signed_distance(o, p, radius)[0]))
    return f(states.obstacles, xy)


@pytest.mark.parametrize(("scene", "behavior"), PAIRS)
@settings(max_examples=2, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), speed=st.floats(0.5, 1.8))
def test_random_actions_never_push_a_body_into_an_obstacle_or_wall(scene, behavior, seed, speed):
    cfg = WorldCfg().for_scene(scene).with_behavior(behavior).with_speed(speed)
    states, infos, rewards, _ = random_rollout(jax.random.key(seed), cfg, 16, 300)
    k = {"room_0": 0, "room_4": 4, "room_8": 8}.get(scene, 25)
    assert states.obstacles.centre_xy_m.shape == (300, 16, k, 2)
    finite, bodies, centres, scan = _what_the_collision_test_reads(states, infos, rewards, cfg)
    assert bool(finite)
    for (sd, w), r in zip(bodies, (cfg.base.radius_m, cfg.target.radius_m), strict=True):
        assert np.asarray(sd).min(initial=np.inf) >= -1e-4
        if get_scene(scene).walls:
            w = np.asarray(w)
            assert w.min() >= r - 1e-4 and w.max() <= cfg.arena.size_m - r + 1e-4
    if get_scene(scene).walls:  # the rooms' obstacles stay where they are in the world
        c = np.asarray(centres)
        np.testing.assert_allclose(c, np.broadcast_to(c[:, :1], c.shape), atol=1e-3)
    scan = np.asarray(scan)
    assert scan.shape == (300, 16, 32) and scan.min() >= 0 and scan.max() <= 10.0


@jax.jit
def _what_the_collision_test_reads(states, infos, rewards, cfg):
    """In one program (eagerly, each operation compiled on its own): whether every float is
    finite; each body's signed distance to every obstacle and its world position; the
    obstacles' world centres; the scan of every state."""
    leaves = jax.tree.leaves((states, infos, rewards))
    finite = jnp.all(jnp.stack([jnp.all(jnp.isfinite(x)) for x in leaves if x.dtype != bool]))
    bodies = [
        (_sd(states, xy, r), world_xy(states, xy))
        for xy, r in (
            (states.robot.xy_m, cfg.base.radius_m),
            (states.target.xy_m, cfg.target.radius_m),
        )
    ]
    centres = world_xy(states, jnp.moveaxis(states.obstacles.centre_xy_m, 2, 0))
    scan = jax.vmap(jax.vmap(env.observe, in_axes=(0, None)), in_axes=(0, None))(states, cfg)
    return finite, bodies, centres, scan.scan_m


def _flee_past_a_tree(lookahead_m: float):
    """A 1.5 m/s reactive target (no random gamma) fleeing a still robot straight at a tree:
    world positions (T, 2) and its least gap to the tree's surface."""
    cfg = WorldCfg().with_scene("woods_plane").with_behavior("reactive").with_speed(1.5)
    cfg = cfg.replace(
        target=cfg.target.replace(gamma_max_rad=0.0),
        avoid=cfg.avoid.replace(lookahead_m=lookahead_m),
    )
    tree = obstacles(cylinders=[(9.5, 8.0, 0.3)])
    s = _start(cfg, tree, robot_xy=(4.0, 8.0), robot_yaw=0.0, target_xy=(8.0, 8.0), heading=0.0)
    states, _, _ = fixed_rollout(s, STILL, cfg, 150)
    gap = jax.vmap(lambda o, p: signed_distance(o, p, 0.1)[0])(states.obstacles, states.target.xy_m)
    return np.asarray(world_xy(states, states.target.xy_m)), float(gap.min())


def test_a_fleeing_target_steers_around_a_tree():
    xy, gap = _flee_past_a_tree(1.0)
    # It never touches it: a free direction clears the tree grown by the target's radius,
    # so it may graze but never press (measured 0.014 m at the closest).
    assert gap > 1e-3
    assert xy[-1, 0] > 10.5  # and gets past it
    # Without looking ahead it runs into the tree (and slides around it).
    _, gap_blind = _flee_past_a_tree(0.0)
    assert gap_blind < 1e-3


def test_the_bounce_target_reflects_off_a_box():
    cfg = WorldCfg().with_scene("room_0").with_behavior("bounce").with_speed(1.0)
    box = obstacles(boxes=[(6.0, 8.0, 0.5, 1.0)])
    s = _start(cfg, box, robot_xy=(14.0, 2.0), target_xy=(4.0, 8.0), heading=0.0)
    # 1 m/s: at the face (x = 5.5 less its radius) after 1.4 s, back at x = 3.8 at 3 s.
    states, _, _ = fixed_rollout(s, STILL, cfg, 150)
    x = np.asarray(world_xy(states, states.target.xy_m))[:, 0]
    assert x.max() <= 5.5 - cfg.target.radius_m + 1e-4
    assert math.cos(float(states.target.heading_rad[-1])) < -0.99  # heading back along -x
    assert x[-1] < 4.0


class TestTerrain:
    @staticmethod
    def _drive(terrain, yaw, steps=400, cmd=(2.0, 0.0, 0.0)):
        """Base velocities in the world (steps, 2) under a held command, no noise."""
        cfg = WorldCfg()
        s = jax.jit(env.reset)(jax.random.key(0), cfg).robot.replace(yaw_rad=jnp.float32(yaw))

        def body(r, _):
            r = base_substep(
                r, jnp.asarray(cmd), cfg.base, cfg.arena, jnp.zeros(2), 0.005, False, None, terrain
            )
            r = r.replace(yaw_rad=jnp.float32(yaw))  # hold the heading (yaw rate aside)
            vel = jnp.stack([jnp.cos(yaw), jnp.sin(yaw)]) * r.vel_body_mps[0]
            return r, (vel, r.vel_body_mps)

        return jax.lax.scan(body, s, None, length=steps)[1]

    def test_rough_ground_lowers_the_top_speed_and_slows_tracking(self):
        cfg = WorldCfg()
        _, flat = self._drive(None, 0.0)
        _, rough = self._drive(cfg.rough, 0.0)
        np.testing.assert_allclose(flat[-1, 0], 2.0, rtol=1e-4)
        np.testing.assert_allclose(rough[-1, 0], 2.0 * cfg.rough.speed_scale, rtol=1e-4)
        # Slower tracking: a 0.2 m/s step (below every acceleration limit) is followed as
        # 0.2 (1 - (1 - dt / lag)^n); 20 sub-steps of 5 ms with lag 0.1 s and 0.15 s.
        _, flat = self._drive(None, 0.0, 20, (0.2, 0.0, 0.0))
        _, rough = self._drive(cfg.rough, 0.0, 20, (0.2, 0.0, 0.0))
        np.testing.assert_allclose(flat[-1, 0], 0.2 * (1 - 0.95**20), rtol=1e-4)
        np.testing.assert_allclose(rough[-1, 0], 0.2 * (1 - (1 - 0.005 / 0.15) ** 20), rtol=1e-4)

    def test_stairs_slow_climbing_across_the_steps_more_than_walking_along_them(self):
        st = WorldCfg().stairs
        _, across = self._drive(st, 0.0)  # facing +x: across the steps
        _, along = self._drive(st, math.pi / 2)
        np.testing.assert_allclose(
            across[-1, 0], 2.0 * st.speed_scale * st.climb_speed_scale, rtol=1e-4
        )
        np.testing.assert_allclose(along[-1, 0], 2.0 * st.speed_scale, rtol=1e-4)

    def test_more_gait_noise(self):
        cfg = WorldCfg()
        r = jax.jit(env.reset)(jax.random.key(0), cfg).robot
        flat = add_gait_noise(r, jnp.ones(3), cfg.base)
        rough = add_gait_noise(r, jnp.ones(3), cfg.base, cfg.rough)
        np.testing.assert_allclose(flat.vel_body_mps, [0.05, 0.05], rtol=1e-6)
        np.testing.assert_allclose(rough.vel_body_mps, [0.10, 0.10], rtol=1e-6)


def test_scene_defaults_and_the_observation_size():
    w = WorldCfg().for_scene("room_8")
    assert (w.episode.duration_s, w.scene.scan_rays) == (40.0, 32)
    assert WorldCfg().with_scene("room_8").scene.scan_rays == 8  # --scene alone keeps the scan
    assert WorldCfg().for_scene("open_plane") == WorldCfg()
    assert obs_dim(w) == 5 + 32 == sum(n for _, n in Obs.layout(32, staleness=False))
    e = JaxCatchEnv(w)
    assert e.observation_spec.shape == (37,)
    assert env.observe(jax.jit(env.reset)(jax.random.key(0), w), w).flat.shape == (37,)


@pytest.mark.parametrize(
    ("scene", "change", "field"),
    [
        ("room_4", lambda w: w.replace(room=w.room.replace(gap_m=0.5)), "room.gap_m"),
        ("room_8", lambda w: w.replace(room=w.room.replace(grid_cells=2)), "room.grid_cells"),
        ("woods_plane", lambda w: w.replace(woods=w.woods.replace(tile_cells=3)), "woods.tile"),
        ("woods_plane", lambda w: w.replace(avoid=w.avoid.replace(lookahead_m=3.0)), "avoid.look"),
        ("woods_stairs", lambda w: w.replace(stairs=w.stairs.replace(speed_scale=1.5)), "stairs"),
        ("woods_rough", lambda w: w.replace(rough=w.rough.replace(lag_scale=0.5)), "rough.lag"),
    ],
)
def test_validation_names_the_bad_scene_constant(scene, change, field):
    w = WorldCfg().for_scene(scene)
    assert validate_world(w) is w
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        validate_world(change(w))
    # A constant of another scene is not checked here.
    validate_world(change(w).with_scene("open_plane"))


@settings(max_examples=30, deadline=None)
@given(
    yaw=st.floats(-math.pi, math.pi),
    cmd=st.tuples(st.floats(-1.0, 2.0), st.floats(-1.0, 1.0), st.floats(-2.0, 2.0)),
)
def test_terrain_commands_stay_within_the_scaled_limits(yaw, cmd):
    # The stairs' climb factor turns the velocity vector; the result is clipped again, so
    # no body component passes its (scaled) limit and the observation bounds hold.
    w = WorldCfg()
    st_ = w.stairs
    out = np.asarray(terrain_command(jnp.asarray(cmd, jnp.float32), jnp.float32(yaw), w.base, st_))
    hi = np.array([2.0 * st_.speed_scale, st_.speed_scale, 2.0 * st_.yaw_rate_scale])
    lo = -np.array([st_.speed_scale, st_.speed_scale, 2.0 * st_.yaw_rate_scale])
    assert np.all(out <= hi + 1e-6) and np.all(out >= lo - 1e-6)


def _every_obstacle(obstacles, robot_xy, target_xy):
    return obstacles, obstacles


def _line_of_sight_everywhere(obstacles, robot, target, step, cfg):
    return env._line_of_sight(obstacles, robot, target)


@pytest.mark.parametrize(("scene", "behavior"), [("room_8", "bounce"), ("woods_plane", "reactive")])
def test_the_steps_shortcuts_through_the_obstacles_equal_testing_all(scene, behavior):
    # The step tests each body against the one obstacle nearest it at the step's start (the
    # gaps exceed twice a body's reach in a step); in the woods, the trunk of its own cell,
    # the flee rule against the trunks of the 2 x 2 cells nearest the target, and the
    # camera's line of sight only at its frames. Against all obstacles everywhere, one step
    # from each of 6,400 states along random rollouts gives the same states, contacts
    # included. One step each: over many steps float rounding grows where the arm's IK is
    # ill-conditioned.
    cfg = WorldCfg().for_scene(scene).with_behavior(behavior).with_speed(1.8)
    states, *_ = random_rollout(jax.random.key(5), cfg, 32, 200)
    flat = jax.tree.map(lambda x: x.reshape(x.shape[0] * x.shape[1], *x.shape[2:]), states)
    action = jax.random.uniform(jax.random.key(6), (flat.step.shape[0], 3), minval=-2, maxval=2)

    def one_step():
        jax.clear_caches()  # vmap keeps the step's trace: retrace it as patched now
        return jax.jit(jax.vmap(lambda s, a: env.step(s, a, cfg)))(flat, action)

    nearest_only = one_step()
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(env, "_reachable_obstacles", _every_obstacle)
        mp.setattr(env, "_flee_obstacles", lambda obstacles, xy_m: obstacles)
        mp.setattr(env, "_line_of_sight_at_frames", _line_of_sight_everywhere)
        every = one_step()
    jax.clear_caches()
    for a, b in zip(jax.tree.leaves(nearest_only), jax.tree.leaves(every), strict=True):
        if jax.dtypes.issubdtype(a.dtype, jax.dtypes.prng_key):
            a, b = jax.random.key_data(a), jax.random.key_data(b)
        # rtol 1e-4: a scan ray grazing a trunk magnifies float rounding of the new position
        # (measured 1.1e-5 once in 204,800 ranges); a wrongly chosen obstacle moves a body
        # or a range by centimetres to metres.
        np.testing.assert_allclose(np.asarray(a), np.asarray(b), rtol=1e-4, atol=1e-5)
    # Contacts happened in those steps, and not only with the layout's first obstacle.
    after, contacts = nearest_only[0], set()
    bodies = ((after.robot.xy_m, cfg.base.radius_m), (after.target.xy_m, cfg.target.radius_m))
    for xy, r in bodies:
        sd = jax.vmap(lambda o, p, r=r: signed_distance(o, p, r)[0])(after.obstacles, xy)
        sd = np.asarray(sd)
        touching = sd.min(-1) < 0.01
        contacts |= set(sd[touching].argmin(-1).tolist())
    assert len(contacts) >= 3, contacts


def test_the_flee_rule_sees_a_trunk_in_the_next_cell():
    # A target near its cell's edge, fleeing straight at the trunk just across it: the flee
    # rule must turn it (the trunk is within its lookahead), as it does testing every trunk,
    # and not as it would testing its own cell's trunk only.
    cfg = WorldCfg().for_scene("woods_plane").with_behavior("reactive").with_speed(1.8)
    cfg = cfg.replace(target=cfg.target.replace(gamma_max_rad=0.0))  # straight away from it
    w, r_t = cfg.woods, cfg.target.radius_m
    n, side = w.tile_cells, w.spacing_m
    ij = np.stack(np.meshgrid(np.arange(n), np.arange(n), indexing="xy"), -1).reshape(-1, 2)
    centres = (ij + 0.5) * side
    k = 2 + n * 2  # the trunk of cell (2, 2), moved near its cell's left edge
    centres[k, 0] = 2 * side + 0.5 * w.gap_m + 0.2 + 0.05
    trees = obstacles(cylinders=[(x, y, 0.2) for x, y in centres], period_m=n * side)
    trees = trees.replace(grid_cells=n)
    target_x = 2 * side - 0.05  # just inside the cell to the left
    assert centres[k, 0] - 0.2 - r_t - target_x < 0.8 * cfg.avoid.lookahead_m
    y = centres[k, 1]
    s = _start(cfg, trees, robot_xy=(target_x - 4.0, y), robot_yaw=0.0, target_xy=(target_x, y))
    s = s.replace(target=s.target.replace(heading_rad=jnp.zeros(())))

    def heading(flee_obstacles):
        with pytest.MonkeyPatch.context() as mp:
            mp.setattr(env, "_flee_obstacles", flee_obstacles)
            jax.clear_caches()
            return float(jax.jit(lambda st: env.step(st, STILL, cfg))(s)[0].target.heading_rad)

    block = heading(env._flee_obstacles)
    every = heading(lambda o, xy_m: o)
    own = heading(lambda o, xy_m: env.own_cell(o, xy_m))
    jax.clear_caches()
    assert block == every
    assert abs(block) > 0.1 and own == 0.0


def test_a_gap_that_leaves_two_obstacles_in_reach_is_refused():
    room = WorldCfg().for_scene("room_8")
    reach = step_reach_m(room)
    assert reach == pytest.approx(0.358 + 0.02 * math.hypot(2.0, 1.0), abs=1e-3)
    for world, field in (
        (room.replace(room=room.room.replace(gap_m=0.75)), "room.gap_m"),
        (room.replace(base=room.base.replace(max_forward_mps=10.0)), "room.gap_m"),
        (WorldCfg().for_scene("woods_stairs").replace(woods=WoodsCfg(gap_m=0.8)), "woods.gap_m"),
    ):
        with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
            validate_world(world)
    validate_world(room.replace(room=room.room.replace(gap_m=0.85)))
