"""Invariants over long random-action rollouts, for every behaviour."""

import jax
import jax.numpy as jnp
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from dyncatch.sim.behaviors import scripted_behaviors
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import catch_error_m

from .helpers import random_rollout, world_xy

CFG = WorldCfg().with_scene("arena")


@settings(max_examples=8, deadline=None)
@given(
    seed=st.integers(0, 2**31 - 1),
    behavior=st.sampled_from(sorted(scripted_behaviors())),
    speed=st.floats(0.0, 1.8),
)
def test_random_rollouts_keep_every_invariant(seed, behavior, speed):
    cfg = CFG.with_behavior(behavior).with_speed(speed)
    states, infos, rewards, alive = random_rollout(jax.random.key(seed), cfg, 32, 400)
    robot, target = states.robot, states.target
    leaves = jax.tree.leaves((states.robot, states.target, states.sensor, infos, rewards))
    assert all(bool(jnp.all(jnp.isfinite(x))) for x in leaves if x.dtype != bool)

    # The walls of the arena scene stop both bodies, in world coordinates (the open plane's
    # invariants are in test_open_plane.py).
    assert cfg.scene.name == "arena"
    size = cfg.arena.size_m
    bodies = ((robot.xy_m, cfg.base.radius_m), (target.xy_m, cfg.target.radius_m))
    for xy, r in ((world_xy(states, p), r) for p, r in bodies):
        assert float(xy.min()) >= r - 1e-5
        assert float(xy.max()) <= size - r + 1e-5

    # Tracking with a lag never overshoots the limits, and gait noise is clipped to them.
    margin = 1e-5
    vx, vy = robot.vel_body_mps[..., 0], robot.vel_body_mps[..., 1]
    assert float(vx.max()) <= cfg.base.max_forward_mps + margin
    assert float(vx.min()) >= -cfg.base.max_backward_mps - margin
    assert float(jnp.abs(vy).max()) <= cfg.base.max_lateral_mps + margin
    assert float(jnp.abs(robot.yaw_rate_rps).max()) <= cfg.base.max_yaw_rate_rps + margin
    np.testing.assert_allclose(target.speed_mps, speed, rtol=1e-5, atol=1e-6)

    q = robot.arm_q_rad
    assert bool(jnp.all(q >= jnp.asarray(cfg.arm.joint_min_rad) - 1e-6))
    assert bool(jnp.all(q <= jnp.asarray(cfg.arm.joint_max_rad) + 1e-6))

    # Success is exactly the catch geometry, checked at 200 Hz; the end-of-step pose is one
    # of the checked poses, so the reported error can only be smaller.
    success, err = infos["success"], infos["catch_error_m"]
    assert bool(jnp.all(success == (err <= cfg.arm.catch_radius_m)))
    end_err = jax.vmap(jax.vmap(catch_error_m, in_axes=(0, 0, None)), in_axes=(0, 0, None))(
        robot.gripper_xyz_m, target, cfg
    )
    assert bool(jnp.all(err <= end_err + 1e-5))
    # A catch needs the target within the arm's activation distance.
    dist = infos["distance_m"]
    assert bool(jnp.all(~success | (dist <= cfg.arm.activation_distance_m + 0.1)))
