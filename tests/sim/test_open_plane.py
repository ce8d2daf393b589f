"""The open plane: nothing stops either body, the world can be moved rigidly without changing
anything the robot senses, and a catch 10 km out is judged exactly as one at the origin."""

from __future__ import annotations

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dyncatch.sim import env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SCENES, get_scene
from dyncatch.sim.state import EnvState

from .helpers import fixed_rollout, place, world_xy

OPEN = WorldCfg().with_scene("open_plane")
ARENA = WorldCfg().with_scene("arena")
STILL = jnp.zeros(3)


def test_registry():
    assert list(SCENES) == [
        "arena",
        "open_plane",
        "room_0",
        "room_4",
        "room_8",
        "woods_plane",
        "woods_rough",
        "woods_stairs",
    ]
    assert get_scene("arena").walls and not get_scene("open_plane").walls
    with pytest.raises(ValueError, match="'moon'.*arena, open_plane"):
        get_scene("moon")


def _flee(cfg: WorldCfg):
    """A 1.8 m/s reactive target fleeing a still robot for 20 s (1000 steps): world
    positions of the target (T, 2) and the distance it covered step by step (T - 1,)."""
    cfg = cfg.with_behavior("reactive").with_speed(1.8)
    # Beyond r_ev (3 m) and already heading away: pure flight, never a dodge, never a catch.
    start = cfg.target.evade_radius_m + 1.0
    s = jax.jit(env.reset)(jax.random.key(0), cfg)
    s = place(s, robot_xy=(8.0, 8.0), robot_yaw=0.0, target_xy=(8.0 + start, 8.0), heading=0.0)
    states, _, infos = fixed_rollout(s, STILL, cfg, int(20.0 * cfg.episode.control_hz))
    assert not bool(infos["success"].any())
    xy = np.asarray(world_xy(states, states.target.xy_m), np.float64)
    return xy, np.linalg.norm(np.diff(xy, axis=0), axis=-1)


def test_a_fleeing_target_runs_36_m_in_20_s_unobstructed():
    xy, steps = _flee(OPEN)
    # 1.8 m/s for 20 s: 36 m of path (the first step is not in the diff: 0.036 m less).
    np.testing.assert_allclose(steps.sum(), 36.0 - 1.8 * 0.02, atol=1e-2)
    # It flees along +x wobbling by gamma ~ U(-22.5, 22.5) deg about the flee direction, so
    # it gets at least cos(22.5 deg) of that from the robot, far past the square's side.
    assert np.linalg.norm(xy[-1] - [8.0, 8.0]) > 36.0 * math.cos(math.radians(22.5))
    assert xy[:, 0].max() > 30.0
    # The same chase in the arena ends at a wall.
    xy_arena, steps_arena = _flee(ARENA)
    assert xy_arena.max() <= ARENA.arena.size_m - ARENA.target.radius_m + 1e-5
    assert steps_arena.sum() < 20.0


def _drive(cfg: WorldCfg):
    """The robot from (1, 8) facing +x under a held 2 m/s forward command for 20 s: its world
    positions (T, 2)."""
    cfg = cfg.with_behavior("reactive").with_speed(0.0)
    s = jax.jit(env.reset)(jax.random.key(1), cfg)
    # The target far behind it, still: never in the way.
    s = place(s, robot_xy=(1.0, 8.0), robot_yaw=0.0, target_xy=(-20.0, 8.0))
    forward = jnp.array([cfg.base.max_forward_mps, 0.0, 0.0])
    states, _, _ = fixed_rollout(s, forward, cfg, int(20.0 * cfg.episode.control_hz))
    return np.asarray(world_xy(states, states.robot.xy_m), np.float64)


def test_nothing_clips_the_robot():
    assert OPEN.base.max_forward_mps == 2.0
    xy = _drive(OPEN)
    # 2 m/s for 20 s is 40 m, less the lag while it speeds up (2 m/s x 0.1 s), gait noise
    # clipped at the top speed and the heading's random walk: measured 38.44 m.
    travelled = np.linalg.norm(xy[-1] - [1.0, 8.0])
    assert 38.0 < travelled < 40.0
    assert xy[-1, 0] > 35.0  # far past where the arena's wall (x = 15.7 m) would stop it
    # The arena's wall stops it at its radius from the side.
    xy_arena = _drive(ARENA)
    r = ARENA.base.radius_m
    assert xy_arena[:, 0].max() <= ARENA.arena.size_m - r + 1e-5
    assert xy_arena[-1, 0] > ARENA.arena.size_m - r - 0.05


def _rotate(xy, c, s):
    return jnp.stack([c * xy[..., 0] - s * xy[..., 1], s * xy[..., 0] + c * xy[..., 1]], -1)


def rigid_motion(state: EnvState, angle_rad: float, shift_m) -> EnvState:
    """The same world moved rigidly: every world point p goes to R p + shift, every heading
    turns by ``angle_rad``. Stored positions are relative to the robot, so they turn about
    it, and the frame's origin moves to R origin + shift."""
    c, s = jnp.cos(angle_rad), jnp.sin(angle_rad)

    def rot(xy):
        return _rotate(xy, c, s)

    def pose(p):
        return jnp.concatenate([rot(p[:2]), p[2:] + angle_rad])

    r, t, sen = state.robot, state.target, state.sensor
    # The behaviour state's points (fields ending in xy_m, as sim.frame moves them) turn too.
    b = t.behavior_state
    points = {
        f: rot(getattr(b, f)) for f in (f.name for f in dataclasses.fields(b)) if f.endswith("xy_m")
    }
    turned = b.replace(**points) if points else b
    return state.replace(
        robot=r.replace(
            xy_m=rot(r.xy_m),
            yaw_rad=r.yaw_rad + angle_rad,
            gripper_xyz_m=jnp.concatenate([rot(r.gripper_xyz_m[:2]), r.gripper_xyz_m[2:]]),
        ),
        target=t.replace(
            xy_m=rot(t.xy_m), heading_rad=t.heading_rad + angle_rad, behavior_state=turned
        ),
        sensor=sen.replace(
            obs_xy_m=rot(sen.obs_xy_m),
            prev_obs_xy_m=rot(sen.prev_obs_xy_m),
            pending_xy_m=rot(sen.pending_xy_m),
            robot_pose=pose(sen.robot_pose),
            prev_robot_pose=pose(sen.prev_robot_pose),
            pending_robot_pose=pose(sen.pending_robot_pose),
        ),
        origin_xy_m=rot(state.origin_xy_m) + jnp.asarray(shift_m, jnp.float32),
    )


_STEPS = 150  # 3 s: six camera frames


@jax.jit
def _episode(state: EnvState, actions: jax.Array, cfg: WorldCfg):
    """(obs.flat (T, D), reward (T,), done (T,), info) under ``actions`` (T, 3)."""

    def body(s, a):
        s, obs, reward, done, info = env.step(s, a, cfg)
        return s, (obs.flat, reward, done, info)

    return jax.lax.scan(body, state, actions)[1]


# The bounce target reflects off the square of ArenaCfg, fixed in the world, which a motion
# of the state does not carry along: it is not invariant (moved 1 km away it is mirrored back
# into the square at once). The circle's centre is a point of its behaviour state, which
# moves with the rest, so the circle is. With sensor noise (0 by default) the same key draws
# the noise in world axes, so only its distribution would be invariant.
# Derandomized: the same examples every run. A random search found the counterexample below,
# which fails on the code before this test's last change too (4414ebe); until it is fixed, a
# random draw of it would fail unrelated submissions.
@settings(max_examples=10, deadline=None, derandomize=True)
@given(
    seed=st.integers(0, 2**31 - 1),
    behavior=st.sampled_from(["reactive", "random_reactive", "circle"]),
    angle=st.floats(-math.pi, math.pi),
    shift=st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3)),
)
def test_a_rigid_motion_of_the_world_changes_nothing_the_robot_senses(seed, behavior, angle, shift):
    cfg = OPEN.with_behavior(behavior).with_speed(1.2)
    k_reset, k_act = jax.random.split(jax.random.key(seed))
    s = env.reset(k_reset, cfg)
    moved = rigid_motion(s, angle, shift)
    actions = jax.random.uniform(
        k_act, (_STEPS, 3), minval=jnp.array([-1.0, -1.0, -2.0]), maxval=jnp.array([2.0, 1.0, 2.0])
    )
    obs, reward, done, info = _episode(s, actions, cfg)
    obs2, reward2, done2, info2 = _episode(moved, actions, cfg)
    np.testing.assert_allclose(obs2, obs, atol=2e-4)
    np.testing.assert_allclose(reward2, reward, atol=1e-5)
    np.testing.assert_array_equal(done2, done)
    np.testing.assert_array_equal(info2["success"], info["success"])
    np.testing.assert_allclose(info2["catch_error_m"], info["catch_error_m"], atol=2e-4)
    np.testing.assert_allclose(info2["distance_m"], info["distance_m"], atol=2e-4)
    # The initial observation too (the one reset hands a policy).
    np.testing.assert_allclose(env.observe(moved, cfg).flat, env.observe(s, cfg).flat, atol=1e-5)


@pytest.mark.xfail(
    strict=True,
    reason="known defect: turned by 1 rad, the catch error departs by 1.6 mm (0.46 m away) "
    "in the two steps after the arm activates; the observation and outcome agree",
)
def test_a_rigid_motion_found_by_search_changes_nothing_the_robot_senses():
    test_a_rigid_motion_of_the_world_changes_nothing_the_robot_senses.hypothesis.inner_test(
        seed=1_726_642_570, behavior="circle", angle=1.0, shift=(0.0, 0.0)
    )


def test_a_catch_10_km_out_is_judged_exactly_as_at_the_origin():
    # A still target 1 m ahead of the robot, which walks up to it at 0.5 m/s: a catch.
    cfg = OPEN.with_behavior("reactive").with_speed(0.0)
    s = jax.jit(env.reset)(jax.random.key(2), cfg)
    near = place(s, robot_xy=(0.0, 0.0), robot_yaw=0.3, target_xy=(math.cos(0.3), math.sin(0.3)))
    far = near.replace(origin_xy_m=near.origin_xy_m + jnp.array([1e4, 1e4], jnp.float32))
    walk = jnp.tile(jnp.array([0.5, 0.0, 0.0]), (200, 1))
    obs, reward, done, info = _episode(near, walk, cfg)
    assert bool(info["success"].any())  # the geometry does end in a catch
    obs_far, reward_far, done_far, info_far = _episode(far, walk, cfg)
    # Bit for bit: every quantity is computed relative to the robot. In world coordinates
    # float32 would space points 1 mm apart at 10 km, a fiftieth of the catch radius.
    np.testing.assert_array_equal(obs_far, obs)
    np.testing.assert_array_equal(reward_far, reward)
    np.testing.assert_array_equal(done_far, done)
    np.testing.assert_array_equal(info_far["success"], info["success"])
    np.testing.assert_array_equal(info_far["catch_error_m"], info["catch_error_m"])
