"""The world-side readings change exactly what they say: w2 per step or per second, eq. 8
as a terminal event or a state indicator, the limit on turning at speed, and the ground-speed
limit (``trot_envelope``)."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim import env
from dyncatch.sim.base import clip_command, command_high, command_low
from dyncatch.sim.config import BaseCfg, RewardCfg, WorldCfg

from .helpers import place

STILL = jnp.zeros(3)


def _episode(reward: RewardCfg, steps: int = 60):
    """A still target 0.6 m ahead of a still robot (the arm reaches and catches it)."""
    cfg = WorldCfg(reward=reward).with_behavior("bounce").with_speed(0.0)
    s = env.reset(jax.random.key(3), cfg)
    s = place(s, robot_xy=(8.0, 8.0), robot_yaw=0.0, target_xy=(8.6, 8.0))
    step = jax.jit(env.step)
    rows = []
    for _ in range(steps):
        s, _, r, done, info = step(s, STILL, cfg)
        rows.append((float(r), bool(done), bool(info["success"]), dict(info)))
    return rows


def test_success_and_visibility_readings_by_hand():
    per_s = _episode(RewardCfg())
    per_step = _episode(RewardCfg(visibility_per="per_step"))
    every = _episode(RewardCfg(success_per="every_step"))
    k = next(i for i, row in enumerate(per_s) if row[2])  # the catch step
    assert k < 40
    # Terminal (default): the catch ends the episode and pays w3 = 5 once.
    assert per_s[k][1] and not any(row[1] for row in per_s[:k])
    info = per_s[k][3]
    assert per_s[k][0] == pytest.approx(
        float(info["reward/pursuit"]) + 0.2 * 0.02 * float(info["reward/visibility"]) + 5.0,
        abs=1e-5,
    )
    # w2 per step: the same episode, each step paying 0.2 - 0.004 = 0.196 more where visible.
    for a, b in zip(per_s[: k + 1], per_step[: k + 1], strict=True):
        assert b[2] == a[2] and b[1] == a[1]
        assert b[0] - a[0] == pytest.approx(0.196 * float(a[3]["reward/visibility"]), abs=1e-5)
    # Eq. 8 as a state indicator: the catch does not end the episode, and every step the arm
    # holds the still target pays w3 again.
    assert not any(row[1] for row in every)
    held = [row for row in every[k:] if row[2]]
    assert len(held) > 10
    for r, _, _, info in held:
        expected = float(info["reward/pursuit"]) + 0.004 * float(info["reward/visibility"]) + 5
        assert r == pytest.approx(expected, abs=1e-5)


def test_catch_time_does_not_depend_on_the_success_reading():
    cfg = WorldCfg().with_behavior("reactive").with_speed(1.0)
    every = cfg.replace(reward=cfg.reward.replace(success_per="every_step"))
    a = run_episodes(pursuit_policy(cfg), jax.random.key(5), cfg, 64)
    b = run_episodes(pursuit_policy(every), jax.random.key(5), every, 64)
    assert 0.3 < float(a["success"].mean())  # some catches, so the comparison means something
    np.testing.assert_array_equal(a["success"], b["success"])
    np.testing.assert_allclose(a["catch_time_s"], b["catch_time_s"])


@pytest.mark.parametrize(("limit", "expected"), [(3.0, 1.5), (float("inf"), 2.0)])
def test_turning_at_speed_is_limited_by_the_lateral_acceleration(limit, expected):
    cfg = WorldCfg().with_behavior("circle")
    cfg = cfg.replace(
        base=cfg.base.replace(
            max_lateral_accel_mps2=limit, gait_noise_mps=0.0, gait_noise_yaw_rps=0.0
        )
    )
    s = env.reset(jax.random.key(0), cfg)
    step = jax.jit(env.step)
    for _ in range(100):  # 2 s of full speed ahead, full left turn
        s, *_ = step(s, jnp.array([2.0, 0.0, 2.0]), cfg)
    speed = float(jnp.linalg.norm(s.robot.vel_body_mps))
    assert speed == pytest.approx(2.0, abs=1e-3)
    # |v| x |yaw rate| <= 3 m/s^2: 1.5 rad/s at 2 m/s; no limit: the 2 rad/s command.
    assert float(s.robot.yaw_rate_rps) == pytest.approx(expected, abs=1e-3)


def test_a_command_is_held_to_the_ground_speed_along_its_direction():
    """``max_speed_mps`` scales (vx, vy) back along its direction after the box; the yaw rate
    and commands within it are untouched, and at the default inf the box alone, bit for bit."""
    commands = jnp.array([[2.0, 1.0, 1.5], [-1.0, -1.0, -2.0], [0.5, 0.2, 0.3], [3.0, 0.0, 0.0]])
    box = BaseCfg()
    np.testing.assert_array_equal(
        clip_command(commands, box), jnp.clip(commands, command_low(box), command_high(box))
    )
    capped = clip_command(commands, box.replace(max_speed_mps=1.2))
    clipped = jnp.clip(commands, command_low(box), command_high(box))
    speed = np.linalg.norm(np.asarray(clipped[:, :2]), axis=1)
    np.testing.assert_allclose(
        np.linalg.norm(np.asarray(capped[:, :2]), axis=1), np.minimum(speed, 1.2), rtol=1e-6
    )
    # Along the box-clipped direction: the cross product with it is zero.
    cross = capped[:, 0] * clipped[:, 1] - capped[:, 1] * clipped[:, 0]
    np.testing.assert_allclose(cross, 0.0, atol=1e-6)
    np.testing.assert_array_equal(capped[:, 2], clipped[:, 2])
    np.testing.assert_array_equal(capped[2], clipped[2])  # 0.54 m/s: within the cap


def test_the_base_settles_at_the_ground_speed_on_the_boxs_corner():
    cfg = WorldCfg().with_behavior("circle")
    quiet = cfg.base.replace(gait_noise_mps=0.0, gait_noise_yaw_rps=0.0)
    step = jax.jit(env.step)
    for cap, expected in ((1.93, 1.93), (float("inf"), math.hypot(2.0, 1.0))):
        world = cfg.replace(base=quiet.replace(max_speed_mps=cap))
        s = env.reset(jax.random.key(0), world)
        for _ in range(100):  # 2 s at the box's corner, forward and left
            s, *_ = step(s, jnp.array([2.0, 1.0, 0.0]), world)
        assert float(jnp.linalg.norm(s.robot.vel_body_mps)) == pytest.approx(expected, abs=1e-3)
