"""A recurrent actor-critic (GRU memory under MLP heads) and the policy that carries it.

``RecurrentActorCritic`` reads the normalised input through a GRU and then the MLP heads
of ``rl.networks``: the first of ``PPOCfg.hidden_sizes`` is the GRU's width, the rest the
heads' hidden layers (the actor and the critic each have their own GRU, as rsl_rl's
``ActorCriticRecurrent``, so the value loss does not shape the actor's memory and a
deployed actor carries only its own). The hidden state is zero at an episode's start
(``reset_memory``); ``replay`` runs the network over stored sequences the way the rollout
ran it, step by step, so recurrent PPO re-evaluates the rollout exactly
(``rl.recurrent_train``). ``MemoryPolicy`` is a trained one behind the policy protocol of
``dyncatch.policies.api``: its carry is the input function's and the actor's hidden state.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import flax.linen as nn
import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.rl.methods import MethodObs
from dyncatch.rl.networks import MLP
from dyncatch.rl.normalize import RunningNorm
from dyncatch.rl.train import to_command
from dyncatch.sim.api import Environment
from dyncatch.sim.state import EnvState, Obs


class GRU(nn.Module):
    """One GRU step, flax ``GRUCell``'s equations with the gates' products fused:

    r = sigmoid(x W_ir + b_ir + h W_hr + b_hr),  z = sigmoid(x W_iz + b_iz + h W_hz + b_hz),
    n = tanh(x W_in + b_in + r * (h W_hn + b_hn)),  h' = (1 - z) * n + z * h;

    ``input`` holds [W_ir | W_iz | W_in] (D, 3H) and its biases, ``hidden`` [W_hr | W_hz | W_hn]
    (H, 3H) and its biases (ONNX's GRU with ``linear_before_reset``)."""

    features: int

    @nn.compact
    def __call__(self, h: jax.Array, x: jax.Array) -> jax.Array:
        """(hidden state (..., H), input (..., D)) -> the next hidden state (..., H)."""
        gi = nn.Dense(3 * self.features, name="input")(x)
        gh = nn.Dense(3 * self.features, kernel_init=nn.initializers.orthogonal(), name="hidden")(h)
        ir, iz, i_n = jnp.split(gi, 3, axis=-1)
        hr, hz, h_n = jnp.split(gh, 3, axis=-1)
        r = nn.sigmoid(ir + hr)
        z = nn.sigmoid(iz + hz)
        n = jnp.tanh(i_n + r * h_n)
        return (1.0 - z) * n + z * h


class Memory(NamedTuple):
    """The hidden states of one or more environments, (..., H) each."""

    actor: jax.Array
    critic: jax.Array


def zero_memory(width: int, batch: tuple[int, ...] = ()) -> Memory:
    """The hidden state at an episode's start: zeros, (*batch, width) each."""
    return Memory(jnp.zeros((*batch, width)), jnp.zeros((*batch, width)))


def reset_memory(memory: Any, done: jax.Array) -> Any:
    """``memory`` (leaves (B, H)) with the rows of finished episodes (``done`` (B,)) zeroed:
    the next step of those environments starts a new episode."""
    return jax.tree.map(lambda h: jnp.where(done[:, None], jnp.zeros_like(h), h), memory)


class RecurrentActorCritic(nn.Module):
    """(memory, normalised input (..., D)) -> (memory, action mean (..., A), log std (A,),
    value (...)); ``act`` is the actor alone, ``value`` the critic alone."""

    action_dim: int
    hidden_sizes: tuple[int, ...]
    init_log_std: float = 0.0

    @property
    def memory_size(self) -> int:
        """H, the width of each GRU (the first of ``hidden_sizes``)."""
        return self.hidden_sizes[0]

    def setup(self):
        heads = tuple(self.hidden_sizes[1:])
        self.actor_memory = GRU(self.memory_size)
        self.critic_memory = GRU(self.memory_size)
        self.actor = MLP(heads, self.action_dim, 0.01)
        self.critic = MLP(heads, 1, 1.0)
        self.log_std = self.param(
            "log_std", nn.initializers.constant(self.init_log_std), (self.action_dim,)
        )

    def __call__(self, memory: Memory, x: jax.Array):
        h_a = self.actor_memory(memory.actor, x)
        h_c = self.critic_memory(memory.critic, x)
        return Memory(h_a, h_c), self.actor(h_a), self.log_std, self.critic(h_c)[..., 0]

    def act(self, h: jax.Array, x: jax.Array) -> tuple[jax.Array, jax.Array]:
        """(actor hidden state (..., H), input) -> (its next state, action mean (..., A))."""
        h = self.actor_memory(h, x)
        return h, self.actor(h)

    def value(self, h: jax.Array, x: jax.Array) -> jax.Array:
        """The critic's value (...) of input ``x`` after hidden state ``h`` (its next state is
        not kept: the time-out bootstrap's look at an episode's final input)."""
        return self.critic(self.critic_memory(h, x))[..., 0]


def replay(net: RecurrentActorCritic, params, memory0: Memory, x: jax.Array, dones: jax.Array):
    """The network over sequences, as the rollout ran it: from ``memory0`` (B, H), input
    ``x`` (T, B, D), the memory zeroed after each ``dones`` (T, B) step.

    Returns (means (T, B, A), log std (A,), values (T, B)). Gradients flow through the whole
    window (truncated back-propagation through time, T steps; ``memory0`` is data).
    """

    def body(memory, inputs):
        x_t, done_t = inputs
        memory, mean, _, value = net.apply(params, memory, x_t)
        return reset_memory(memory, done_t), (mean, value)

    _, (means, values) = jax.lax.scan(body, memory0, (x, dones))
    return means, params["params"]["log_std"], values


@struct.dataclass
class MemoryPolicy:
    """A trained recurrent actor behind the policy protocol (``dyncatch.policies.api``):
    the carry is (the input function's carry, the actor's hidden state (H,)), zero at an
    episode's start; the critic's memory is not needed to act and is left out.

    A pytree like ``rl.policy.LearnedPolicy`` (one compilation per method, not per
    checkpoint); the deterministic mean action, scaled to the training environment's limits.
    """

    net: RecurrentActorCritic = struct.field(pytree_node=False)
    params: dict
    norm: RunningNorm
    obs_fn: MethodObs
    env: Environment
    is_pytree_policy: bool = struct.field(pytree_node=False, default=True)

    def init_carry(self, state: EnvState, obs: Obs) -> tuple[Any, jax.Array]:
        return self.obs_fn.init_carry(state), jnp.zeros(self.net.memory_size)

    def step(self, carry: tuple[Any, jax.Array], state: EnvState, obs: Obs, key: jax.Array):
        del key  # the mean action: evaluation is deterministic given the world's noise
        obs_carry, h = carry
        obs_carry, x = self.obs_fn.step(obs_carry, state, obs)
        h, mean = self.net.apply(self.params, h, self.norm(x), method="act")
        return (obs_carry, h), to_command(mean, self.env)
