"""Recurrent PPO (``rnn_rl``): whole-sequence minibatches and their GAE against plain loops,
the replay of the rollout against a step-by-step loop, the hidden state reset where an
episode ends, and the update re-evaluating the rollout's own policy exactly."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.gae import gae
from dyncatch.rl.methods import get_method, method_obs
from dyncatch.rl.policy import RECURRENT, learner
from dyncatch.rl.recurrent import (
    MemoryPolicy,
    RecurrentActorCritic,
    replay,
    reset_memory,
    zero_memory,
)
from dyncatch.rl.recurrent_train import make_recurrent_train, sequence_minibatches
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg

T, B, D, H = 9, 6, 5, 4


class TestSequenceMinibatches:
    def test_each_minibatch_is_whole_sequences_of_a_permutation_of_environments(self):
        # Every entry names its own (t, b): obs[t, b] = (t, b); memory0[b] = b.
        t, b = np.meshgrid(np.arange(T), np.arange(B), indexing="ij")
        batch = {"obs": jnp.stack([t, b], -1).astype(jnp.float32), "dones": jnp.asarray(t == 3)}
        memory0 = zero_memory(H, (B,))._replace(actor=jnp.arange(B)[:, None] * jnp.ones(H))
        key = jax.random.key(3)
        seqs, start = sequence_minibatches(batch, memory0, key, 3)
        assert seqs["obs"].shape == (3, T, 2, 2) and start.actor.shape == (3, 2, H)
        # The plain reference: the permutation's groups of 2 environments, every time step.
        perm = np.asarray(jax.random.permutation(key, B))
        for i in range(3):
            envs = perm[2 * i : 2 * i + 2]
            np.testing.assert_array_equal(seqs["obs"][i], np.asarray(batch["obs"])[:, envs])
            np.testing.assert_array_equal(seqs["dones"][i], np.asarray(batch["dones"])[:, envs])
            np.testing.assert_array_equal(start.actor[i][:, 0], envs)
            # Each column is one environment's window, t = 0 .. T-1 in order.
            np.testing.assert_array_equal(seqs["obs"][i][:, :, 0], t[:, :2])
        assert sorted(np.asarray(seqs["obs"][:, 0, :, 1]).ravel()) == list(range(B))

    def test_a_minibatch_sequence_keeps_its_environments_gae(self):
        """The advantages travel with their sequences: each minibatch column equals a plain
        GAE loop over that environment's rewards, values and episode ends."""
        k = jax.random.split(jax.random.key(0), 4)
        g, lam = 0.97, 0.9
        r, v = jax.random.normal(k[0], (T, B)), jax.random.normal(k[1], (T, B))
        d = jax.random.bernoulli(k[2], 0.2, (T, B))
        last = jax.random.normal(k[3], (B,))
        adv, _ = gae(r, v, d, last, g, lam)
        memory0 = zero_memory(H, (B,))._replace(actor=jnp.arange(B)[:, None] * jnp.ones(H))
        batch = {"advantages": adv, "rewards": r, "values": v, "dones": d}
        seqs, start = sequence_minibatches(batch, memory0, jax.random.key(1), 2)
        for i in range(2):
            for j in range(B // 2):
                env = int(start.actor[i, j, 0])
                rs, vs, ds = (np.asarray(seqs[n][i][:, j]) for n in ("rewards", "values", "dones"))
                running, want = 0.0, np.zeros(T)
                for t in reversed(range(T)):
                    nv = float(last[env]) if t == T - 1 else vs[t + 1]
                    nd = 0.0 if ds[t] else 1.0
                    running = rs[t] + g * nv * nd - vs[t] + g * lam * nd * running
                    want[t] = running
                np.testing.assert_allclose(seqs["advantages"][i][:, j], want, atol=1e-5)


def _net_and_params():
    net = RecurrentActorCritic(3, (H, 8))
    params = net.init(jax.random.key(0), zero_memory(H, (1,)), jnp.zeros((1, D)))
    return net, params


def test_replay_equals_a_step_by_step_loop_that_zeroes_the_memory_at_episode_ends():
    net, params = _net_and_params()
    k = jax.random.split(jax.random.key(1), 3)
    x = jax.random.normal(k[0], (T, B, D))
    dones = jax.random.bernoulli(k[1], 0.25, (T, B))
    memory0 = jax.tree.map(lambda h: jax.random.normal(k[2], h.shape), zero_memory(H, (B,)))
    means, _, values = replay(net, params, memory0, x, dones)
    memory = memory0
    for t in range(T):
        memory, mean, _, value = net.apply(params, memory, x[t])
        np.testing.assert_allclose(means[t], mean, atol=1e-6)
        np.testing.assert_allclose(values[t], value, atol=1e-6)
        for b in range(B):
            if dones[t, b]:  # the next step starts a new episode from the zero state
                memory = memory._replace(
                    actor=memory.actor.at[b].set(0.0), critic=memory.critic.at[b].set(0.0)
                )
    # The resets matter: without them the outputs after an episode end differ.
    unreset, _, _ = replay(net, params, memory0, x, jnp.zeros_like(dones))
    after = np.asarray(jnp.cumsum(dones, 0) > dones)  # steps after an end in that column
    assert after.any()
    assert float(jnp.abs(unreset - means)[after].max()) > 1e-3


def test_a_done_zeroes_that_environment_s_carry_and_only_its():
    memory = jax.tree.map(lambda h: h + 1.0, zero_memory(H, (3,)))
    out = reset_memory(memory, jnp.array([False, True, False]))
    np.testing.assert_array_equal(out.actor[1], 0.0)
    np.testing.assert_array_equal(out.critic[1], 0.0)
    np.testing.assert_array_equal(np.asarray(out.actor)[[0, 2]], 1.0)


@pytest.fixture(scope="module")
def short_episodes():
    """8 environments whose episodes last 15 steps (0.3 s), rollouts of 10 steps."""
    world = WorldCfg().with_behavior("circle")
    world = world.replace(episode=world.episode.replace(duration_s=0.3))
    ppo = PPOCfg(num_envs=8, num_steps=10, num_minibatches=1, update_epochs=1, hidden_sizes=(8,))
    init, iterate, _ = make_recurrent_train(world, ppo)
    return jax.jit(init), jax.jit(iterate)


def test_the_rollout_resets_the_hidden_state_where_an_episode_ends(short_episodes):
    """Rollout 1 ends at episode step 10, rollout 2 at step 5 of the next episode (an end
    inside it), rollout 3 on the step that ends the second episode: an environment whose
    episode just ended (its state at step 0) holds the zero state, every other one not."""
    init, iterate = short_episodes
    ts = init(jax.random.key(0))
    assert not bool(jnp.any(ts.memory.actor))
    for _ in range(3):
        ts, _ = iterate(ts)
        fresh = np.asarray(ts.env_state.step == 0)
        zero = np.asarray(jnp.all(ts.memory.actor == 0, -1) & jnp.all(ts.memory.critic == 0, -1))
        np.testing.assert_array_equal(zero, fresh)
    assert fresh.sum() >= 4  # most episodes ran to their time limit, ending in rollout 3


def test_the_update_re_evaluates_the_rollout_s_own_policy(short_episodes):
    """One epoch of one minibatch: its loss is taken at the rollout's parameters, so the
    replay over the whole sequences (episode ends inside them) must give the rollout's own
    means: KL 0 and no clipped ratio. A replay misaligned with the resets would not."""
    init, iterate = short_episodes
    ts = init(jax.random.key(1))
    for _ in range(2):  # rollout 2 holds episode ends at its 5th step
        ts, metrics = iterate(ts)
        assert float(metrics["kl"]) < 1e-9
        assert float(metrics["clip_fraction"]) == 0.0
    assert float(metrics["episodes"]) >= 4


def test_rnn_rl_is_a_method_with_memory_trained_and_loaded_by_the_recurrent_learner():
    m = get_method("rnn_rl")
    assert m.memory and m.trained and m.predictor_kind is None
    assert learner("rnn_rl") is RECURRENT and learner("rl") is not RECURRENT
    assert not get_method("rl").memory


def test_the_memory_policy_starts_each_episode_from_zero_and_carries_its_state():
    env = JaxCatchEnv(WorldCfg().with_behavior("circle"))
    ppo = PPOCfg(num_envs=2, num_steps=2, num_minibatches=1, hidden_sizes=(H,))
    init, _, net = make_recurrent_train(env, ppo)
    ts = init(jax.random.key(0))
    policy = MemoryPolicy(net, ts.params, ts.norm, method_obs("rnn_rl"), env)
    # Each call jitted (eagerly, each of its operations would compile on its own).
    state = jax.jit(env.reset)(jax.random.key(2))
    obs = jax.jit(env.observe)(state)
    carry = jax.jit(policy.init_carry)(state, obs)
    assert carry[0] == () and carry[1].shape == (H,) and not bool(jnp.any(carry[1]))
    step = jax.jit(policy.step)
    carry1, command = step(carry, state, obs, None)
    carry2, command2 = step(carry1, state, obs, None)
    assert bool(jnp.any(carry1[1] != carry2[1]))  # the same input moves a different state
    assert command.shape == (3,) and bool(jnp.any(command != command2))


def test_minibatches_that_would_split_an_environment_are_refused_with_the_flag():
    # 6 environments x 4 steps divide into 4 minibatches of steps, not of whole sequences.
    ppo = PPOCfg(num_envs=6, num_steps=4, num_minibatches=4)
    with pytest.raises(ValueError, match="must divide ppo.num_envs=6.*--ppo.num-minibatches"):
        make_recurrent_train(WorldCfg(), ppo)
