"""Labels are finite differences of the true trajectory; frames without a sighting are dropped."""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.predictor.config import CollectCfg
from dyncatch.predictor.data import (
    budget_count,
    collect,
    episode_key,
    frame_plan,
    plan_action,
    steps_per_env,
)
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import reset, step
from dyncatch.sim.sensing import in_view

CFG = CollectCfg(envs_per_chunk=8)
WORLD = WorldCfg().with_behavior("reactive")


def reference_episode(key, world: WorldCfg, cfg: CollectCfg):
    """A plain Python loop over control steps, recording the true world trajectory of the
    target and of the robot step by step."""
    world = cfg.interaction_world(world)
    k_reset, k_first, k_frames = jax.random.split(key, 3)
    always = dataclasses.replace(cfg, replan_prob=1.0)
    plan = frame_plan(k_first, (jnp.zeros((), bool), jnp.zeros(3)), world, always)
    one = jax.jit(lambda s, p, c: step(s, plan_action(s, p, c, world), world)[0])
    state = reset(k_reset, world)

    def world_xy(s):
        return np.asarray(s.target.xy_m + s.origin_xy_m), np.asarray(s.robot.xy_m + s.origin_xy_m)

    xy, robot_xy, seen = [world_xy(state)[0]], [world_xy(state)[1]], []
    frames = steps_per_env(world) // 25
    for k in range(frames):
        seen.append(bool(in_view(state.robot, state.target.xy_m, world)))
        plan = frame_plan(jax.random.fold_in(k_frames, k), plan, world, cfg)
        for _ in range(25):
            state = one(state, *plan)
            xy.append(world_xy(state)[0])
            robot_xy.append(world_xy(state)[1])
    return np.stack(xy), np.stack(robot_xy), np.array(seen)


@pytest.fixture(scope="module")
def collected():
    return collect(jax.random.key(3), WORLD, CFG, 8 * 125)


def test_budget_counts_whole_episodes(collected):
    samples, used = collected
    assert used == 8 * 125  # 2.5 s episodes at 50 Hz
    assert budget_count(samples, WORLD, CFG, 4 * 125) == int(np.sum(samples.env_index < 4))


@pytest.mark.parametrize("env", [0, 3, 6])
def test_labels_are_finite_differences_of_the_true_trajectory(collected, env):
    samples, _ = collected
    xy, robot_xy, seen = reference_episode(episode_key(jax.random.key(3), env), WORLD, CFG)
    captures = xy[::25]  # true world positions at the camera frames, (frames + 1, 2)
    # The sightings relative to the robot at their captures (the history is stored in the
    # simulator's robot-centred frame, so only such differences are comparable).
    rel = captures - robot_xy[::25]
    true_label = (captures[1:] - captures[:-1]) / 0.5
    keep = seen & np.concatenate([[False], seen[:-1]])  # frames t-1 and t both saw it
    mine = samples.env_index == env
    h = jax.tree.map(lambda a: a[mine], samples.history)
    np.testing.assert_allclose(samples.label_mps[mine], true_label[keep], atol=1e-3)
    np.testing.assert_allclose(h.target_xy_m - h.robot_pose[:, :2], rel[:-1][keep], atol=1e-4)
    np.testing.assert_allclose(
        h.prev_target_xy_m - h.prev_robot_pose[:, :2], rel[:-2][keep[1:]], atol=1e-4
    )


def test_frames_without_a_sighting_are_excluded(collected):
    samples, _ = collected
    total_frames, kept = 0, 0
    for env in range(8):
        _, _, seen = reference_episode(episode_key(jax.random.key(3), env), WORLD, CFG)
        total_frames += len(seen)
        kept += int(np.sum(seen[1:] & seen[:-1]))
    assert len(samples.label_mps) == kept
    assert kept < total_frames  # some frames missed the target, so the filter did something
