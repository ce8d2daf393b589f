"""The evader's opponents: a weighted mix of scripted and trained pursuers inside the jitted
step, equal to each opponent alone at weight 1; trained runs as --against; errors that
name the flag."""

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.policies.intercept import intercept_policy
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.predictor.checkpoint import save as save_predictor
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.model import Predictor
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.evader import evader_env, split_arrays, stack_groups
from dyncatch.rl.evader_train import (
    EvaderTrainCfg,
    evader_iterate,
    load_pursuer,
    train_evader,
)
from dyncatch.rl.policy import load_run
from dyncatch.rl.runner import TrainRunCfg, TrainRunner
from dyncatch.rl.train import make_train
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT
from dyncatch.sim.config import WorldCfg
from tests.sim.test_vec import PRODUCTION_CODEGEN

TINY = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=1, hidden_sizes=(16,))
WORLD = WorldCfg().with_speed(1.6)


def _one_iteration_run(out, method: str = "rl", predictor=None, seed: int = 0):
    """A one-iteration pursuer run of ``method`` in the default world."""
    cfg = TrainRunCfg(
        method=method,
        total_steps=TINY.batch_size,
        seed=seed,
        out=out,
        predictor=predictor,
        eval_every=0,
        logger=("csv",),
        ppo=TINY,
        world=WorldCfg(),
    )
    TrainRunner(cfg).learn()
    return out


@pytest.fixture(scope="module")
def pursuer_run(tmp_path_factory):
    return _one_iteration_run(tmp_path_factory.mktemp("pursuer"))


@pytest.fixture(scope="module")
def second_seed(tmp_path_factory):
    return _one_iteration_run(tmp_path_factory.mktemp("seed1"), seed=1)


def _rollout(env, key, steps: int = 40):
    """Robot and target positions over ``steps`` steps of a fixed turn pattern, (T, 2) each."""
    s = env.reset(key)

    def body(s, i):
        turn = 0.5 * jnp.sin(0.3 * i)[None]
        s, _, _, _, _ = env.step(s, turn)
        w = s.world
        return s, (w.robot.xy_m + w.origin_xy_m, w.target.xy_m + w.origin_xy_m)

    return jax.lax.scan(body, s, jnp.arange(steps))[1]


def _same_episodes(mixed, alone, seeds=(0, 1, 2)):
    # Each rollout compiled once for every seed (a key is data, not part of the program).
    run_mixed = jax.jit(lambda k: _rollout(mixed, k))
    run_alone = jax.jit(lambda k: _rollout(alone, k))
    for seed in seeds:
        key = jax.random.key(seed)
        a, b = run_mixed(key), run_alone(key)
        for x, y in zip(a, b, strict=True):
            np.testing.assert_allclose(np.asarray(x), np.asarray(y), atol=1e-5)


class TestMixAtWeightOne:
    """All the weight on one opponent: the episodes of that opponent alone."""

    def test_scripted(self):
        pursuers = [pursuit_policy(WORLD), intercept_policy(WORLD)]
        for i in (0, 1):
            weights = tuple(float(j == i) for j in (0, 1))
            _same_episodes(
                evader_env(WORLD, pursuers, weights=weights), evader_env(WORLD, pursuers[i])
            )

    def test_trained_among_scripted(self, pursuer_run):
        trained = load_run(pursuer_run).policy
        mixed = evader_env(WORLD, [pursuit_policy(WORLD), trained], weights=(0.0, 1.0))
        alone = evader_env(WORLD, trained)
        _same_episodes(mixed, alone)
        # ... and the trained pursuer does play: not the scripted one's episodes.
        scripted = evader_env(WORLD, pursuit_policy(WORLD))
        a = jax.jit(lambda k: _rollout(alone, k))(jax.random.key(0))[0]
        b = jax.jit(lambda k: _rollout(scripted, k))(jax.random.key(0))[0]
        assert float(jnp.abs(a - b).max()) > 0.05


def test_seeds_of_one_method_run_stacked(pursuer_run, second_seed):
    """Two seeds of rl run as one stacked network (the scripted pursuers alone): each seed
    alone at weight 1, and its own carry and command."""
    seeds = [load_run(pursuer_run).policy, load_run(second_seed).policy]
    both = [seeds[0], pursuit_policy(WORLD), seeds[1], intercept_policy(WORLD)]
    assert stack_groups(evader_env(WORLD, both).pursuers) == [[0, 2], [1], [3]]
    for i in (0, 2):
        weights = tuple(float(j == i) for j in range(4))
        _same_episodes(evader_env(WORLD, both, weights=weights), evader_env(WORLD, both[i]), (0,))


class TestWeightsAsArguments:
    """The evader's trainer passes the pursuers' weights to its jitted iteration as arguments
    (``rl.evader.split_arrays``), so that one program serves every pursuer of one structure,
    changing no number."""

    def test_two_seeds_share_one_program(self, pursuer_run, second_seed):
        (w0, s0), (w1, s1) = (
            split_arrays(evader_env(WORLD, load_run(run).policy))
            for run in (pursuer_run, second_seed)
        )
        assert s0 == s1 and hash(s0) == hash(s1)  # the static argument: one jit cache entry
        assert len(w0) == len(w1) > 0
        assert any(not np.array_equal(a, b) for a, b in zip(w0, w1, strict=True))
        other = split_arrays(evader_env(WORLD.with_speed(1.2), load_run(pursuer_run).policy))
        assert other[1] != s0  # the world is part of the program

    def test_episodes_equal_the_weights_compiled_in_bit_for_bit(self, pursuer_run):
        env = evader_env(WORLD, load_run(pursuer_run).policy)
        weights, skeleton = split_arrays(env)
        # The closed-over rollout is TestMixAtWeightOne's program (the persistent compilation
        # cache serves it); a key is data.
        closed = jax.jit(lambda k: _rollout(env, k))
        passed = jax.jit(lambda w, k: _rollout(skeleton.fill(w), k))
        for seed in (0, 1):
            key = jax.random.key(seed)
            for x, y in zip(closed(key), passed(weights, key), strict=True):
                np.testing.assert_array_equal(np.asarray(x), np.asarray(y))

    @pytest.mark.extended
    def test_an_iteration_equals_the_closed_over_one_bit_for_bit(self, pursuer_run):
        """With the library's code generation (``make test``'s older fusion emitters round
        the PPO update of the two programs differently, by about 1e-8, not the episodes)."""
        env = evader_env(WORLD, load_run(pursuer_run).policy)
        weights, skeleton = split_arrays(env)
        init, iterate, _ = make_train(env, TINY)
        ts = jax.jit(init)(jax.random.key(0))
        closed = jax.jit(iterate).lower(ts).compile(compiler_options=PRODUCTION_CODEGEN)(ts)
        lowered = evader_iterate.lower(weights, ts, skeleton=skeleton, ppo=TINY)
        passed = lowered.compile(compiler_options=PRODUCTION_CODEGEN)(weights, ts)
        for x, y in zip(jax.tree.leaves(closed[1]), jax.tree.leaves(passed[1]), strict=True):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
        for x, y in zip(
            jax.tree.leaves(closed[0].params), jax.tree.leaves(passed[0].params), strict=True
        ):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_predictor_and_ground_truth_runs_mix(tmp_path):
    """sp_rl (its predictor loaded from the checkpoint's header) and gt_rl (the target's true
    velocity, read from the evader's world) in one mix: each alone at weight 1."""
    pred = Predictor.for_world(PredictorCfg(kind="self_aware", hidden=(8,)), WorldCfg())
    save_predictor(tmp_path / "p.safetensors", pred, pred.init(jax.random.key(0)))
    sp = load_run(_one_iteration_run(tmp_path / "sp", "sp_rl", tmp_path / "p.safetensors"))
    gt = load_run(_one_iteration_run(tmp_path / "gt", "gt_rl"))
    both = [sp.policy, gt.policy]
    _same_episodes(evader_env(WORLD, both, weights=(1.0, 0.0)), evader_env(WORLD, sp.policy), (0,))
    _same_episodes(evader_env(WORLD, both, weights=(0.0, 1.0)), evader_env(WORLD, gt.policy), (0,))


def test_the_drawn_opponent_follows_the_weights():
    # 8000 resets; the count of opponent 1 is binomial(8000, 0.25): within 4.5 standard
    # errors (0.022) with probability > 1 - 1e-5; uniform drawing would give 0.5.
    env = evader_env(WORLD, [pursuit_policy(WORLD), intercept_policy(WORLD)], weights=(3.0, 1.0))
    keys = jax.random.split(jax.random.key(5), 8000)
    index = np.asarray(jax.jit(jax.vmap(env.reset))(keys).pursuer_index)
    se = np.sqrt(0.25 * 0.75 / index.size)
    assert abs(index.mean() - 0.25) <= 4.5 * se


def test_an_evader_trains_against_a_trained_run_and_a_baseline(pursuer_run, tmp_path):
    cfg = EvaderTrainCfg(
        against=("pursuit", str(pursuer_run)),
        against_weights=(1.0, 3.0),
        total_steps=TINY.batch_size,
        out=tmp_path / "ev",
        ppo=TINY,
        world=WORLD,
    )
    metrics = train_evader(cfg)
    assert np.isfinite(metrics["reward_per_step"])
    assert (tmp_path / "ev" / EVADER_CHECKPOINT).exists()


class TestRefused:
    def test_a_pursuer_of_another_world(self, pursuer_run):
        other = WORLD.replace(sensor=WORLD.sensor.replace(rate_hz=5.0))
        with pytest.raises(ValueError, match=r"sensor\.rate_hz.*--world"):
            load_pursuer(str(pursuer_run), other)

    def test_weights_that_do_not_fit(self, tmp_path):
        base = EvaderTrainCfg(against=("pursuit", "intercept"), out=tmp_path / "x", ppo=TINY)
        with pytest.raises(ValueError, match="--against-weights has 1 values for 2"):
            train_evader(dataclasses.replace(base, against_weights=(1.0,)))
        with pytest.raises(ValueError, match="--against-weights must be non-negative"):
            train_evader(dataclasses.replace(base, against_weights=(1.0, -1.0)))
        with pytest.raises(ValueError, match="give 2 non-negative weights"):
            evader_env(WORLD, [pursuit_policy(WORLD)] * 2, weights=(0.0, 0.0))

    def test_an_unknown_opponent(self, tmp_path):
        cfg = EvaderTrainCfg(against=(str(tmp_path / "nowhere"),), out=tmp_path / "x")
        with pytest.raises(ValueError, match="--against .*run folders"):
            train_evader(cfg)
