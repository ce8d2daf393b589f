"""``make_train(env, ppo)`` -> pure ``init(key)`` and ``iterate(state)``, each one jit.

One iteration = a ``lax.scan`` rollout of ``num_steps`` over ``num_envs`` auto-resetting
environments, GAE with time-out bootstrapping, then ``update_epochs`` x ``num_minibatches``
Adam steps with an adaptive-KL learning rate, all inside a single compiled function. The
state is a pytree, so a run can be ``vmap``-ed over seeds. ``env`` is any backend of the
environment protocol (``dyncatch.sim.api``); a ``WorldCfg`` means the JAX world. The
policy's input function may carry a state per environment (the tracker's memory,
``rl.methods.MethodObs.init_carry`` / ``step``): it rides in ``TrainState.obs_carry`` and is
started afresh where the batched auto-reset starts a new episode.

Given a ``jax.sharding.Mesh`` with a ``"batch"`` axis, the environment batch and the PPO
minibatches are constrained to be split along it (data parallel: each device steps its
share of the environments and computes its share of each gradient, averaged by XLA). The
same code runs on one device or many; only float reduction order differs between them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import jax
import jax.numpy as jnp
import optax
from flax import struct
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.gae import bootstrap_timeouts, gae
from dyncatch.rl.loss import ppo_loss
from dyncatch.rl.networks import ActorCritic, gaussian_kl, gaussian_log_prob
from dyncatch.rl.normalize import RunningNorm
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import EnvState, Obs
from dyncatch.sim.vec import batch_observe, batch_reset, batch_step_with_final

ObsFn = Callable[[EnvState, Obs], jax.Array]
"""(state, obs) of one environment -> the policy's input vector (D,)."""


def flat_obs(state: EnvState, obs: Obs) -> jax.Array:
    """The monolithic policy's input: the observation as it is."""
    del state
    return obs.flat


@struct.dataclass
class Stateless:
    """A plain ``ObsFn`` seen through the carry seam of ``rl.methods.MethodObs``: the carry
    is ``()`` and ``step`` is the function. A pytree without leaves (the function is
    static), so a policy holding it can be a jit argument."""

    fn: ObsFn = struct.field(pytree_node=False)
    stateful = False

    def init_carry(self, state: EnvState) -> tuple:
        return ()

    def step(self, carry: tuple, state: EnvState, obs: Obs) -> tuple[tuple, jax.Array]:
        return carry, self.fn(state, obs)


def as_stepper(obs_fn):
    """``obs_fn`` itself if it has the carry seam (``init_carry``, ``step``), else wrapped."""
    return obs_fn if hasattr(obs_fn, "init_carry") else Stateless(obs_fn)


@struct.dataclass
class TrainState:
    params: dict
    opt_state: optax.OptState
    norm: RunningNorm
    env_state: EnvState
    obs: Obs
    key: jax.Array
    learning_rate: jax.Array
    iteration: jax.Array
    env_steps: jax.Array
    obs_carry: Any = ()
    """The input function's carry per environment, [B, ...] (``()``, no leaves, for every
    method but the tracker's: their checkpoints hold exactly what they held before)."""


class Transition(NamedTuple):
    obs: jax.Array
    """Raw policy inputs (for the running normaliser)."""
    norm_obs: jax.Array
    """The same, normalised as the policy saw them."""
    means: jax.Array
    actions: jax.Array
    log_probs: jax.Array
    values: jax.Array
    rewards: jax.Array
    dones: jax.Array
    truncated: jax.Array
    final_obs: jax.Array
    success: jax.Array
    episode_steps: jax.Array


def to_command(action: jax.Array, env: Environment) -> jax.Array:
    """Map a normalised action in [-1, 1]^3 (clipped) to the base command (vx, vy, yaw rate)."""
    spec = env.action_spec
    return spec.low + (jnp.clip(action, -1.0, 1.0) + 1.0) * 0.5 * (spec.high - spec.low)


BATCH_AXIS = "batch"
"""The mesh axis the environment batch and the PPO minibatches are split along."""


def batch_constraint(mesh: Mesh | None) -> Callable[[jax.Array, int], jax.Array]:
    """``constrain(x, axis)``: ``x`` split along ``axis`` over the mesh's batch axis (the
    identity without a mesh). Inside ``vmap`` the mapped axis stays whole."""
    if mesh is None:
        return lambda x, axis: x

    def constrain(x: jax.Array, axis: int) -> jax.Array:
        spec = PartitionSpec(*([None] * axis), BATCH_AXIS)
        return jax.lax.with_sharding_constraint(x, NamedSharding(mesh, spec))

    return constrain


def minibatch_loss(params, net: ActorCritic, ppo: PPOCfg, mb: dict[str, jax.Array]):
    """(PPO loss, metrics with the KL to the rollout's policy) of one minibatch ``mb``
    (``obs``, ``actions``, ``log_probs``, ``advantages``, ``returns``, ``values``,
    ``means``, ``log_stds``) under ``params``."""
    mean, log_std, value = net.apply(params, mb["obs"])
    loss, metrics = ppo_loss(
        mean, log_std, value, mb, ppo.clip_eps, ppo.value_clip_eps, ppo.vf_coef, ppo.ent_coef
    )
    kl = gaussian_kl(mb["means"], mb["log_stds"], mean, log_std).mean()
    return loss, {**metrics, "kl": kl}


def step_with_final_input(env: Environment, vstep, vinit, env_state, action, obs_carry):
    """The batched auto-reset step; the policy input at each finished episode's last state
    (for time-out bootstrapping: taken with the pre-reset state, so a method that reads the
    state, as the predictors and the oracle do, sees its own episode's end, not the next
    episode's start); and the carry of the next step (a fresh one where an episode began).

    ``vstep``/``vinit``: the method's ``step``/``init_carry`` vmapped over the batch.
    Returns (state, obs, reward, done, info, final input, carry)."""
    next_state, next_obs, reward, done, info, final_state = batch_step_with_final(
        env_state, action, env
    )
    _, final_x = vstep(obs_carry, final_state, info["final_obs"])
    fresh = vinit(next_state)
    obs_carry = jax.tree.map(
        lambda a, b: jnp.where(done.reshape(-1, *[1] * (a.ndim - 1)), a, b), fresh, obs_carry
    )
    return next_state, next_obs, reward, done, info, final_x, obs_carry


def epoch_permutations(key: jax.Array, epochs: int, batch_size: int) -> jax.Array:
    """(epochs, batch_size) int32: epoch ``i`` visits the batch in the order
    ``jax.random.permutation(jax.random.split(key, epochs)[i], batch_size)``, bit for bit.

    All are drawn before the first epoch: they depend on no parameter, so XLA is free to
    sort them beside other work instead of between two epochs' products (a permutation of
    16,384 is two stable sorts, about 14 ms on one core, measured in isolation)."""
    keys = jax.random.split(key, epochs)
    return jax.vmap(jax.random.permutation, in_axes=(0, None))(keys, batch_size)


def make_optimizer(ppo: PPOCfg) -> optax.GradientTransformation:
    """Adam behind a global-norm clip, its learning rate a hyperparameter that
    ``adapt_learning_rate`` sets each minibatch (``opt_state[1].hyperparams``)."""
    return optax.chain(
        optax.clip_by_global_norm(ppo.max_grad_norm),
        optax.inject_hyperparams(optax.adam)(learning_rate=ppo.learning_rate),
    )


def adapt_learning_rate(lr: jax.Array, kl: jax.Array, ppo: PPOCfg) -> jax.Array:
    """The adaptive-KL rule: ``lr`` / 1.5 above 2x ``desired_kl``, x 1.5 below half, clipped."""
    lr = jnp.where(kl > 2 * ppo.desired_kl, lr / 1.5, lr)
    lr = jnp.where(kl < 0.5 * ppo.desired_kl, lr * 1.5, lr)
    return jnp.clip(lr, ppo.min_lr, ppo.max_lr)


def make_train(
    env: Environment | WorldCfg, ppo: PPOCfg, obs_fn: ObsFn = flat_obs, mesh: Mesh | None = None
):
    """Build the pure ``init(key) -> TrainState`` and ``iterate(TrainState) -> (TrainState,
    metrics)`` for one method (``obs_fn`` decides what the policy sees). With ``mesh``, the
    environment batch (``num_envs``) and each minibatch are split over its ``"batch"`` axis
    (both sizes must divide by the number of devices; ``dyncatch.rl.sharding`` checks)."""
    env = as_env(env)
    constrain = batch_constraint(mesh)
    net = ActorCritic(env.action_spec.shape[0], ppo.hidden_sizes, ppo.init_log_std)
    stepper = as_stepper(obs_fn)
    vstep = jax.vmap(stepper.step)
    vinit = jax.vmap(stepper.init_carry)
    optimizer = make_optimizer(ppo)

    def init(key: jax.Array) -> TrainState:
        k_net, k_env, k_next = jax.random.split(key, 3)
        env_state = batch_reset(k_env, env, ppo.num_envs)
        obs = batch_observe(env_state, env)
        obs_carry = vinit(env_state)
        _, x = vstep(obs_carry, env_state, obs)
        params = net.init(k_net, x[:1])
        return TrainState(
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
        )

    def env_step(env_state, action, obs_carry):
        return step_with_final_input(env, vstep, vinit, env_state, action, obs_carry)

    def rollout(ts: TrainState):
        def step(carry, key):
            env_state, obs, obs_carry = jax.tree.map(lambda x: constrain(x, 0), carry)
            obs_carry, x = vstep(obs_carry, env_state, obs)
            x_norm = ts.norm(x)
            mean, log_std, value = net.apply(ts.params, x_norm)
            action = mean + jnp.exp(log_std) * jax.random.normal(key, mean.shape)
            log_prob = gaussian_log_prob(action, mean, log_std)
            next_state, next_obs, reward, done, info, final_x, obs_carry = env_step(
                env_state, to_command(action, env), obs_carry
            )
            tr = Transition(
                obs=x,
                norm_obs=x_norm,
                means=mean,
                actions=action,
                log_probs=log_prob,
                values=value,
                rewards=reward,
                dones=done,
                truncated=info["truncated"],
                # The input the policy would have seen at the end of a finished episode.
                final_obs=final_x,
                success=info["success"],
                episode_steps=env_state.step + 1,
            )
            return (next_state, next_obs, obs_carry), tr

        key, k_roll = jax.random.split(ts.key)
        (env_state, obs, obs_carry), traj = jax.lax.scan(
            step,
            (ts.env_state, ts.obs, ts.obs_carry),
            jax.random.split(k_roll, ppo.num_steps),
        )
        return ts.replace(env_state=env_state, obs=obs, obs_carry=obs_carry, key=key), traj

    def update(ts: TrainState, batch: dict[str, jax.Array]):
        def minibatch_step(carry, mb):
            params, opt_state, lr = carry

            grads, metrics = jax.grad(minibatch_loss, has_aux=True)(params, net, ppo, mb)
            lr = adapt_learning_rate(lr, metrics["kl"], ppo)
            opt_state[1].hyperparams["learning_rate"] = lr
            updates, opt_state = optimizer.update(grads, opt_state, params)
            return (optax.apply_updates(params, updates), opt_state, lr), metrics

        def epoch(carry, perm):
            shuffled = jax.tree.map(
                lambda x: constrain(
                    x[perm].reshape(ppo.num_minibatches, ppo.minibatch_size, *x.shape[1:]), 1
                ),
                batch,
            )
            return jax.lax.scan(minibatch_step, carry, shuffled)

        key, k_epochs = jax.random.split(ts.key)
        perms = epoch_permutations(k_epochs, ppo.update_epochs, ppo.batch_size)
        (params, opt_state, lr), metrics = jax.lax.scan(
            epoch, (ts.params, ts.opt_state, ts.learning_rate), perms
        )
        ts = ts.replace(params=params, opt_state=opt_state, learning_rate=lr, key=key)
        return ts, jax.tree.map(jnp.mean, metrics)

    def iterate(ts: TrainState):
        ts, traj = rollout(ts)
        flat = lambda x: x.reshape(ppo.batch_size, *x.shape[2:])  # noqa: E731
        _, _, final_values = net.apply(ts.params, ts.norm(traj.final_obs))
        _, last_x = vstep(ts.obs_carry, ts.env_state, ts.obs)
        _, _, last_value = net.apply(ts.params, ts.norm(last_x))
        rewards = bootstrap_timeouts(traj.rewards, traj.truncated, final_values, ppo.gamma)
        adv, returns = gae(rewards, traj.values, traj.dones, last_value, ppo.gamma, ppo.gae_lambda)
        # The rollout's own outputs are the "old" policy of the KL and ratio terms.
        log_stds = ts.params["params"]["log_std"]
        batch = {
            "obs": flat(traj.norm_obs),
            "actions": flat(traj.actions),
            "log_probs": flat(traj.log_probs),
            "values": flat(traj.values),
            "advantages": flat(adv),
            "returns": flat(returns),
            "means": flat(traj.means),
            "log_stds": jnp.broadcast_to(log_stds, (ppo.batch_size, log_stds.shape[0])),
        }
        ts, metrics = update(ts, batch)
        ts = ts.replace(
            norm=ts.norm.update(traj.obs),
            iteration=ts.iteration + 1,
            env_steps=ts.env_steps + ppo.batch_size,
        )
        return ts, {**metrics, **rollout_metrics(ts, traj, env)}

    return init, iterate, net


def rollout_metrics(ts: TrainState, traj: Transition, env: Environment) -> dict[str, jax.Array]:
    """Per-iteration rollout metrics (metrics.csv's columns): episodes ended, their success
    rate and length, the mean reward, the learning rate and the policy's action std."""
    done = traj.dones.astype(jnp.float32)
    episodes = done.sum()
    return {
        "episodes": episodes,
        "success_rate": (traj.success * done).sum() / jnp.maximum(episodes, 1),
        "episode_length_s": (traj.episode_steps * done).sum()
        / jnp.maximum(episodes, 1)
        * env.world.episode.dt_s,
        "reward_per_step": traj.rewards.mean(),
        "learning_rate": ts.learning_rate,
        "action_std": jnp.exp(ts.params["params"]["log_std"]).mean(),
    }
