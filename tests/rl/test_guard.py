"""The non-finite guard: training stops at the first NaN and keeps the last good checkpoint."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.guard import NonFiniteError, non_finite_parts, non_finite_parts_by_seed
from dyncatch.rl.runner import TrainRunCfg, TrainRunner
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.tree_io import load_tree

PPO = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=1, hidden_sizes=(16,))


def test_non_finite_parts_names_parameters_and_metrics():
    params = {"w": jnp.ones(3), "b": jnp.array([0.0, jnp.nan])}
    norm = {"mean": jnp.zeros(2)}
    assert non_finite_parts(params, norm, {"loss": 1.0, "kl": float("inf"), "e": ""}) == [
        "parameters",
        "kl",
    ]
    assert non_finite_parts({"w": jnp.ones(3)}, norm, {"loss": 0.5}) == []


def test_non_finite_parts_by_seed_equals_the_check_of_each_seed():
    params = {"w": jnp.ones((3, 4)), "b": jnp.zeros((3, 2)).at[1, 0].set(jnp.inf)}
    norm = {"mean": jnp.zeros((3, 2)).at[2, 1].set(jnp.nan)}
    metrics = [{"loss": 1.0}, {"loss": 0.5}, {"loss": float("nan"), "e": ""}]
    group = non_finite_parts_by_seed(params, norm, metrics)
    one_by_one = [
        non_finite_parts(
            jax.tree.map(lambda x, i=i: x[i], params), jax.tree.map(lambda x, i=i: x[i], norm), m
        )
        for i, m in enumerate(metrics)
    ]
    assert group == one_by_one == [[], ["parameters"], ["observation normaliser", "loss"]]


def _five_iterations(out, seeds: int = 1) -> TrainRunCfg:
    """Five tiny iterations, a checkpoint after each, CSV logs in ``out``."""
    return TrainRunCfg(
        method="rl",
        total_steps=5 * PPO.batch_size,
        checkpoint_every=1,
        eval_every=0,
        logger=("csv",),
        out=out,
        ppo=PPO,
        world=WorldCfg().with_behavior("bounce"),
        seeds=seeds,
    )


def test_training_stops_at_the_first_nan_and_keeps_the_last_good_checkpoint(tmp_path):
    runner = TrainRunner(_five_iterations(tmp_path))
    iterate = runner._iterate

    def poisoned(ts):  # the third iteration's update turns one weight into NaN
        ts, m = iterate(ts)
        if int(ts.iteration) == 3:
            params = jax.tree.map(lambda x: x.at[..., 0].set(jnp.nan), ts.params)
            ts = ts.replace(params=params)
        return ts, m

    runner._iterate = poisoned
    with pytest.raises(NonFiniteError, match=r"iteration 3: non-finite parameters.*iteration 2"):
        runner.learn()
    template = jax.eval_shape(runner._init, jax.random.key(0))
    ts, _ = load_tree(runner.checkpoint, template)
    assert int(ts.iteration) == 2
    assert all(np.isfinite(x).all() for x in jax.tree.leaves(ts.params))
    rows = (tmp_path / "metrics.csv").read_text().splitlines()
    assert [r.split(",")[0] for r in rows[1:]] == ["1", "2"]  # the bad row is not logged


def test_a_seed_group_stops_at_one_seeds_nan_and_names_its_checkpoint(tmp_path):
    from dyncatch.rl.runner import seed_cfgs
    from dyncatch.rl.seeds import SeedGroupRunner

    group = SeedGroupRunner(seed_cfgs(_five_iterations(tmp_path, seeds=2)))
    viterate = group._viterate

    def poisoned(ts):  # the third iteration's update turns one weight of seed 1 into NaN
        ts, m = viterate(ts)
        hit = ts.iteration[1] == 3
        params = jax.tree.map(
            lambda x: x.at[1, ..., 0].set(jnp.where(hit, jnp.nan, x[1, ..., 0])), ts.params
        )
        return ts.replace(params=params), m

    group._viterate = poisoned
    with pytest.raises(
        NonFiniteError, match=r"iteration 3: non-finite parameters; .*seed1.*iteration 2"
    ):
        group.learn()
    rows = (tmp_path / "seed1" / "metrics.csv").read_text().splitlines()
    assert [r.split(",")[0] for r in rows[1:]] == ["1", "2"]
