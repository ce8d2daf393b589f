"""Recurrent PPO: ``make_recurrent_train(env, ppo, obs_fn)`` -> pure ``init`` and ``iterate``,
the counterpart of ``rl.train.make_train`` for ``rl.recurrent.RecurrentActorCritic``.

What differs from the feed-forward PPO, and why:

- **The hidden state rides in the rollout** (``RecurrentTrainState.memory``, (B, H) per
  GRU), carried from one rollout to the next and zeroed where an episode ends (the batched
  auto-reset starts a new one there), as the input function's carry is.
- **Minibatches are whole sequences**: each epoch permutes the environments and splits
  them into ``num_minibatches`` groups; a minibatch is its environments' full rollout
  windows (T, B / num_minibatches), never a shuffle of time steps, so the GRU can be run
  over them from the hidden state each held at the rollout's start.
- **Truncated back-propagation through time over the rollout window**: the loss replays
  the network over the T = ``num_steps`` steps (``rl.recurrent.replay``, zeroing the
  memory where the rollout did), so gradients flow back at most T steps (32 x 20 ms =
  0.64 s by default; ``--ppo.num-steps`` sets it); the memory at the window's start is
  data, not differentiated.

GAE with time-out bootstrapping, the loss, the clipping and the adaptive-KL learning rate
are ``rl.train``'s; the critic's value of a truncated episode's final input is its GRU one
step on from the memory it had there.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
import optax
from flax import struct
from jax.sharding import Mesh

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.gae import bootstrap_timeouts, gae
from dyncatch.rl.loss import ppo_loss
from dyncatch.rl.networks import gaussian_kl, gaussian_log_prob
from dyncatch.rl.normalize import RunningNorm
from dyncatch.rl.recurrent import (
    Memory,
    RecurrentActorCritic,
    replay,
    reset_memory,
    zero_memory,
)
from dyncatch.rl.train import (
    ObsFn,
    TrainState,
    Transition,
    adapt_learning_rate,
    as_stepper,
    batch_constraint,
    flat_obs,
    make_optimizer,
    rollout_metrics,
    step_with_final_input,
    to_command,
)
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.vec import batch_observe, batch_reset


@struct.dataclass
class RecurrentTrainState(TrainState):
    memory: Any = ()
    """Each environment's hidden states (``Memory``, (B, H) each), zero where an episode
    begins."""


def validate_recurrent(ppo: PPOCfg, devices: int = 1) -> None:
    """Raise ValueError naming the flag when the environments cannot be split into whole
    sequences (over ``devices`` too)."""
    if ppo.num_envs % ppo.num_minibatches:
        raise ValueError(
            f"recurrent PPO splits its minibatches over environments: ppo.num_minibatches="
            f"{ppo.num_minibatches} must divide ppo.num_envs={ppo.num_envs} "
            "(--ppo.num-minibatches)"
        )
    if (ppo.num_envs // ppo.num_minibatches) % devices:
        raise ValueError(
            f"a recurrent minibatch ({ppo.num_envs // ppo.num_minibatches} environments) must "
            f"divide by the {devices} local devices; change --ppo.num-minibatches"
        )


def sequence_minibatches(
    batch: dict[str, jax.Array], memory0: Any, key: jax.Array, num_minibatches: int
) -> tuple[dict[str, jax.Array], Any]:
    """Whole sequences in random groups of environments.

    ``batch`` leaves are (T, B, ...), ``memory0`` leaves (B, ...); returns leaves
    (num_minibatches, T, B / num_minibatches, ...) and (num_minibatches, B /
    num_minibatches, ...): minibatch i holds environments ``perm[i * b : (i + 1) * b]`` of a
    permutation of B drawn from ``key``, each with its whole window and starting memory.
    """
    b = jax.tree.leaves(memory0)[0].shape[0] // num_minibatches
    perm = jax.random.permutation(key, b * num_minibatches)

    def seq(x):
        x = x[:, perm].reshape(x.shape[0], num_minibatches, b, *x.shape[2:])
        return jnp.swapaxes(x, 0, 1)

    start = jax.tree.map(lambda h: h[perm].reshape(num_minibatches, b, *h.shape[1:]), memory0)
    return jax.tree.map(seq, batch), start


def sequence_loss(
    params, net: RecurrentActorCritic, ppo: PPOCfg, mb: dict[str, jax.Array], memory0: Memory
):
    """(PPO loss, metrics with the KL to the rollout's policy) of one minibatch of
    sequences: ``mb`` leaves (T, b, ...) (``obs``, ``dones``, ``actions``, ``log_probs``,
    ``values``, ``advantages``, ``returns``, ``means``; ``log_stds`` (A,), the rollout's),
    ``memory0`` the hidden states (b, H) at the window's start."""
    means, log_std, values = replay(net, params, memory0, mb["obs"], mb["dones"])
    flat = {k: v.reshape(-1, *v.shape[2:]) for k, v in mb.items() if k != "log_stds"}
    mean, value = means.reshape(flat["means"].shape), values.reshape(-1)
    loss, metrics = ppo_loss(
        mean, log_std, value, flat, ppo.clip_eps, ppo.value_clip_eps, ppo.vf_coef, ppo.ent_coef
    )
    kl = gaussian_kl(flat["means"], mb["log_stds"], mean, log_std).mean()
    return loss, {**metrics, "kl": kl}


def make_recurrent_train(
    env: Environment | WorldCfg, ppo: PPOCfg, obs_fn: ObsFn = flat_obs, mesh: Mesh | None = None
):
    """``rl.train.make_train``'s ``(init, iterate, net)`` for a GRU actor-critic trained by
    recurrent PPO (``RecurrentTrainState``; the module docstring says what differs).
    ``ppo.num_minibatches`` must divide ``ppo.num_envs`` (``validate_recurrent``)."""
    env = as_env(env)
    validate_recurrent(ppo, 1 if mesh is None else mesh.size)
    constrain = batch_constraint(mesh)
    net = RecurrentActorCritic(env.action_spec.shape[0], ppo.hidden_sizes, ppo.init_log_std)
    stepper = as_stepper(obs_fn)
    vstep, vinit = jax.vmap(stepper.step), jax.vmap(stepper.init_carry)
    optimizer = make_optimizer(ppo)

    def init(key: jax.Array) -> RecurrentTrainState:
        k_net, k_env, k_next = jax.random.split(key, 3)
        env_state = batch_reset(k_env, env, ppo.num_envs)
        obs = batch_observe(env_state, env)
        obs_carry = vinit(env_state)
        _, x = vstep(obs_carry, env_state, obs)
        memory = zero_memory(net.memory_size, (ppo.num_envs,))
        params = net.init(k_net, jax.tree.map(lambda h: h[:1], memory), x[:1])
        return RecurrentTrainState(
            params=params,
            opt_state=optimizer.init(params),
            norm=RunningNorm.create(x.shape[-1], ppo.obs_min_std),
            env_state=env_state,
            obs=obs,
            key=k_next,
            learning_rate=jnp.asarray(ppo.learning_rate, jnp.float32),
            iteration=jnp.zeros((), jnp.int32),
            env_steps=jnp.zeros((), jnp.int32),
            obs_carry=obs_carry,
            memory=memory,
        )

    def rollout(ts: RecurrentTrainState):
        def step(carry, key):
            env_state, obs, obs_carry, memory = jax.tree.map(lambda x: constrain(x, 0), carry)
            obs_carry, x = vstep(obs_carry, env_state, obs)
            x_norm = ts.norm(x)
            memory, mean, log_std, value = net.apply(ts.params, memory, x_norm)
            action = mean + jnp.exp(log_std) * jax.random.normal(key, mean.shape)
            next_state, next_obs, reward, done, info, final_x, obs_carry = step_with_final_input(
                env, vstep, vinit, env_state, to_command(action, env), obs_carry
            )
            # V(final input) of a finished episode: its critic one step on, before the reset.
            final_value = net.apply(ts.params, memory.critic, ts.norm(final_x), method="value")
            tr = Transition(
                obs=x,
                norm_obs=x_norm,
                means=mean,
                actions=action,
                log_probs=gaussian_log_prob(action, mean, log_std),
                values=value,
                rewards=reward,
                dones=done,
                truncated=info["truncated"],
                final_obs=final_x,
                success=info["success"],
                episode_steps=env_state.step + 1,
            )
            memory = reset_memory(memory, done)
            return (next_state, next_obs, obs_carry, memory), (tr, final_value)

        key, k_roll = jax.random.split(ts.key)
        (env_state, obs, obs_carry, memory), (traj, final_values) = jax.lax.scan(
            step,
            (ts.env_state, ts.obs, ts.obs_carry, ts.memory),
            jax.random.split(k_roll, ppo.num_steps),
        )
        ts = ts.replace(env_state=env_state, obs=obs, obs_carry=obs_carry, memory=memory, key=key)
        return ts, traj, final_values

    def update(ts: RecurrentTrainState, batch: dict[str, jax.Array], memory0: Memory):
        def minibatch_step(carry, mb):
            params, opt_state, lr = carry
            seqs, start = mb
            seqs = {**seqs, "log_stds": batch["log_stds"]}
            grads, metrics = jax.grad(sequence_loss, has_aux=True)(params, net, ppo, seqs, start)
            lr = adapt_learning_rate(lr, metrics["kl"], ppo)
            opt_state[1].hyperparams["learning_rate"] = lr
            updates, opt_state = optimizer.update(grads, opt_state, params)
            return (optax.apply_updates(params, updates), opt_state, lr), metrics

        sequences = {k: v for k, v in batch.items() if k != "log_stds"}

        def epoch(carry, key):
            seqs, start = sequence_minibatches(sequences, memory0, key, ppo.num_minibatches)
            seqs = jax.tree.map(lambda x: constrain(x, 2), seqs)
            start = jax.tree.map(lambda x: constrain(x, 1), start)
            return jax.lax.scan(minibatch_step, carry, (seqs, start))

        key, k_epochs = jax.random.split(ts.key)
        (params, opt_state, lr), metrics = jax.lax.scan(
            epoch,
            (ts.params, ts.opt_state, ts.learning_rate),
            jax.random.split(k_epochs, ppo.update_epochs),
        )
        ts = ts.replace(params=params, opt_state=opt_state, learning_rate=lr, key=key)
        return ts, jax.tree.map(jnp.mean, metrics)

    def iterate(ts: RecurrentTrainState):
        memory0 = ts.memory
        ts, traj, final_values = rollout(ts)
        _, last_x = vstep(ts.obs_carry, ts.env_state, ts.obs)
        last_value = net.apply(ts.params, ts.memory.critic, ts.norm(last_x), method="value")
        rewards = bootstrap_timeouts(traj.rewards, traj.truncated, final_values, ppo.gamma)
        adv, returns = gae(rewards, traj.values, traj.dones, last_value, ppo.gamma, ppo.gae_lambda)
        batch = {
            "obs": traj.norm_obs,
            "dones": traj.dones,
            "actions": traj.actions,
            "log_probs": traj.log_probs,
            "values": traj.values,
            "advantages": adv,
            "returns": returns,
            "means": traj.means,
            # The rollout's own outputs are the "old" policy of the KL and ratio terms.
            "log_stds": ts.params["params"]["log_std"],
        }
        ts, metrics = update(ts, batch, memory0)
        ts = ts.replace(
            norm=ts.norm.update(traj.obs),
            iteration=ts.iteration + 1,
            env_steps=ts.env_steps + ppo.batch_size,
        )
        return ts, {**metrics, **rollout_metrics(ts, traj, env)}

    return init, iterate, net
