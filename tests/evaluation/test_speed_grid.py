"""Table I's speed grid in one batched call plays the episodes that one call per speed
plays: same keys, same outcomes."""

import jax
import numpy as np

from dyncatch.evaluation.episodes import run_episodes, run_episodes_at_speeds
from dyncatch.evaluation.grid import evaluate_speeds
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.config import WorldCfg

WORLD = WorldCfg().with_behavior("reactive")
WORLD = WORLD.replace(episode=WORLD.episode.replace(duration_s=3.0))
SPEEDS = (0.4, 1.8)


def test_each_row_is_the_single_speed_run():
    policy = BASELINES["pursuit"](WORLD)
    keys = jax.random.split(jax.random.key(3), len(SPEEDS))
    both = jax.device_get(run_episodes_at_speeds(policy, keys, WORLD, SPEEDS, 16))
    assert both["success"].shape == (len(SPEEDS), 16)
    for i, v in enumerate(SPEEDS):
        one = jax.device_get(run_episodes(policy, keys[i], WORLD.with_speed(v), 16))
        np.testing.assert_array_equal(both["success"][i], one["success"])
        np.testing.assert_allclose(both["catch_time_s"][i], one["catch_time_s"], atol=1e-6)
        np.testing.assert_allclose(both["return"][i], one["return"], rtol=1e-5, atol=1e-5)
    # The speeds differ: a slow target is caught sooner than a fast one.
    assert both["catch_time_s"][0].mean() < both["catch_time_s"][1].mean()


def test_the_grid_rows_name_their_speed():
    # 16 episodes: the batched call compiled above serves it.
    rows = evaluate_speeds(BASELINES["pursuit"](WORLD), WORLD, "reactive", SPEEDS, 16, 0, "p")
    assert [r["speed_mps"] for r in rows] == list(SPEEDS)
    assert all(r["episodes"] == 16 and r["behavior"] == "reactive" for r in rows)
