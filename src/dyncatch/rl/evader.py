"""The evader's training environment: the catch world seen from the target's side.

``EvaderEnv`` implements the environment protocol (``dyncatch.sim.api``), so the PPO of
``rl.train.make_train`` trains the target unchanged. Its world runs the ``commanded``
behaviour: each ``step`` writes the evader's turn (the heading change its action asks for
from its action frame, ``sim.behaviors.learned.ACTION_FRAMES``), and with a speed action
its share of the speed cap (``sim.behaviors.learned.speed_share_of``), into the
target's behaviour state, asks the frozen pursuer (any policy of ``policies.api``, run
through ``as_recurrent``) for the base command, and steps the world once. The evader
observes ``sim.behaviors.learned.evader_features``, the function the deployed ``learned``
behaviour computes, so a trained actor runs as a behaviour with no other change.

One difference remains between training and deployment: the world adds the gait's velocity
noise to the robot before the target turns (``sim.env.step``), so a deployed evader sees
the robot's velocity with that noise (``base.gait_noise_mps``, 0.05 m/s by default) and the
trainer observes it from the step before, without it.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dyncatch.policies.api import as_recurrent
from dyncatch.sim import env as sim_env
from dyncatch.sim.api import Spec
from dyncatch.sim.behaviors.evader_net import FULL_VIEW_RAD
from dyncatch.sim.behaviors.learned import (
    ACTION_FRAMES,
    TURN_LIMIT_RAD,
    check_fov,
    evader_features,
    feature_names,
    speed_share_of,
    turn_of,
)
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import EnvState, Obs

PURSUER_STREAM = 0x9E5
"""The pursuer's key at a step (and the draw of the episode's pursuer at reset) is the world
key folded with this (the world's own draws are unchanged; the scripted pursuers ignore
their key)."""


@struct.dataclass
class EvaderRewardCfg:
    """The evader's reward, a sum of named terms logged as ``reward/<name>``."""

    alive_per_episode: float = 1.0
    """Paid as this / max_steps at every step the target is not caught, so a whole episode
    uncaught earns this (1: the same size as the catch penalty)."""
    caught: float = -1.0
    """Paid once, at the step of the catch (which ends the episode)."""
    distance_per_m: float = 0.1
    """Times the step's change of the robot-target distance, m (a shaping term: over an
    episode it sums to 0.1 x the net distance gained, so 10 m gained is worth one survival;
    it speeds up learning which way to run and cannot outweigh being caught)."""


@struct.dataclass
class EvaderObs:
    """The evader's observation; ``flat`` is the network view (``rl.train.flat_obs``)."""

    features: jax.Array
    """``evader_features``, (len(feature_names(fov_rad, speed_action)),)."""

    @property
    def flat(self) -> jax.Array:
        return self.features


@struct.dataclass
class EvaderEnvState:
    """The world's state, the pursuers' observation of it, which pursuer plays this episode
    and every pursuer's carry (only the playing one's moves)."""

    world: EnvState
    world_obs: Obs
    pursuer_index: jax.Array
    """The pursuer of this episode, () int32, an index into ``EvaderEnv.pursuers``."""
    pursuer_carries: tuple

    @property
    def key(self) -> jax.Array:
        return self.world.key

    @property
    def step(self) -> jax.Array:
        return self.world.step


@struct.dataclass
class StaticPolicy:
    """A policy that is not a pytree (the scripted baselines), held as a static field."""

    policy: Any = struct.field(pytree_node=False)

    def init_carry(self, state: EnvState, obs: Obs) -> Any:
        return self.policy.init_carry(state, obs)

    def step(self, carry: Any, state: EnvState, obs: Obs, key: jax.Array):
        return self.policy.step(carry, state, obs, key)


def stack(trees: list) -> Any:
    """Pytrees of one structure as one, each leaf stacked on a new leading axis."""
    return jax.tree.map(lambda *xs: jnp.stack(xs), *trees)


@dataclasses.dataclass(frozen=True)
class Skeleton:
    """A pytree less its array leaves, hashable: ``split_arrays``'s static half."""

    treedef: Any
    statics: tuple
    """Per leaf: ``(type, value)`` of a leaf that is not an array (its type too, so that
    ``1`` and ``1.0``, equal as keys, trace apart), None where an array goes."""

    def fill(self, arrays: tuple) -> Any:
        """The pytree with ``arrays`` (in leaf order) where its arrays were."""
        it = iter(arrays)
        leaves = [next(it) if s is None else s[1] for s in self.statics]
        return jax.tree.unflatten(self.treedef, leaves)


def split_arrays(tree: Any) -> tuple[tuple, Skeleton]:
    """``tree``'s array leaves and the rest (``Skeleton.fill`` joins them again). A jitted
    function that takes the arrays as arguments and the skeleton as a static argument builds
    one program for every tree of one skeleton: an ``EvaderEnv``'s frozen pursuers' weights
    are then not compiled in as constants, and the seeds and rounds of a self-play study
    share the evader's training program. Python scalars (the world's configuration) stay
    constants, as they were when the environment was closed over."""
    leaves, treedef = jax.tree.flatten(tree)
    is_array = [isinstance(x, jax.Array | np.ndarray) for x in leaves]
    arrays = tuple(x for x, a in zip(leaves, is_array, strict=True) if a)
    statics = tuple(None if a else (type(x), x) for x, a in zip(leaves, is_array, strict=True))
    return arrays, Skeleton(treedef, statics)


def stack_groups(pursuers: tuple) -> list[list[int]]:
    """Indices of ``pursuers`` grouped by structure (tree, static fields, leaf shapes and
    dtypes), first appearance first: each group of two or more runs as one stacked network.
    Pursuers without leaves (the scripted ones) stay alone."""
    groups: dict[Any, list[int]] = {}
    for i, p in enumerate(pursuers):
        leaves, treedef = jax.tree.flatten(p)
        key = (treedef, tuple((jnp.shape(x), jnp.result_type(x)) for x in leaves)) if leaves else i
        groups.setdefault(key, []).append(i)
    return list(groups.values())


def frozen_pursuer(policy) -> Any:
    """``policy`` as ``EvaderEnv.pursuer``: a pytree policy (a trained run's) as it is, any
    other seen through ``as_recurrent`` and held static."""
    if getattr(policy, "is_pytree_policy", False):
        return policy
    return StaticPolicy(as_recurrent(policy))


@struct.dataclass
class EvaderEnv:
    """The catch world with the target as the agent and a frozen pursuer (``evader_env``
    builds one)."""

    world: WorldCfg
    """The world, its behaviour ``commanded``."""
    pursuers: tuple
    """The frozen pursuers (``frozen_pursuer``), one drawn per episode."""
    reward: EvaderRewardCfg = EvaderRewardCfg()
    pursuer_weights: tuple[float, ...] = struct.field(pytree_node=False, default=())
    """The chance of each pursuer per episode (normalised; a 0 never plays); empty: uniform."""
    turn_limit_rad: float = struct.field(pytree_node=False, default=TURN_LIMIT_RAD)
    """The turn the action's range [-1, 1] spans, rad (``EvaderTrainCfg.turn_limit_rad``)."""
    action_frame: str = struct.field(pytree_node=False, default="heading")
    """What the turn is added to (``sim.behaviors.learned.ACTION_FRAMES``)."""
    fov_rad: float = struct.field(pytree_node=False, default=FULL_VIEW_RAD)
    """The evader's field of view (``sim.behaviors.learned.evader_features``)."""
    speed_action: bool = struct.field(pytree_node=False, default=False)
    """A second action picks the share of the speed cap (``speed_share_of``); False: the
    evader runs at the cap."""

    def reset(self, key: jax.Array) -> EvaderEnvState:
        ws = sim_env.reset(key, self.world)
        obs = sim_env.observe(ws, self.world)
        k = jax.random.fold_in(key, PURSUER_STREAM)
        if self.pursuer_weights:
            logits = jnp.log(jnp.asarray(self.pursuer_weights, jnp.float32))
            index = jax.random.categorical(k, logits).astype(jnp.int32)
        else:
            index = jax.random.randint(k, (), 0, len(self.pursuers))
        carries = tuple(p.init_carry(ws, obs) for p in self.pursuers)
        return EvaderEnvState(ws, obs, index, carries)

    def _pursue(self, state: EvaderEnvState, ws: EnvState, key: jax.Array):
        """(every pursuer's carry, the command (3,)) of the episode's pursuer.

        Every pursuer is evaluated and the episode's one selected, which is what
        ``lax.switch`` on a batched index becomes under the batch's ``vmap`` anyway; the
        pursuers of one structure (the seeds of one method) run as one ``vmap``-ped network
        over their stacked parameters (``stack_groups``). Measured with two trained ``rl``
        seeds: 0.5 s an evader iteration against 5.2 s through ``lax.switch``. Only the
        playing pursuer's carry moves."""
        obs = state.world_obs
        if len(self.pursuers) == 1:
            carry, command = self.pursuers[0].step(state.pursuer_carries[0], ws, obs, key)
            return (carry,), command
        n = len(self.pursuers)
        carries, commands = [None] * n, [None] * n
        for group in stack_groups(self.pursuers):
            if len(group) == 1:
                i = group[0]
                carries[i], commands[i] = self.pursuers[i].step(
                    state.pursuer_carries[i], ws, obs, key
                )
                continue
            policies = stack([self.pursuers[i] for i in group])
            old = stack([state.pursuer_carries[i] for i in group])
            new, command = jax.vmap(lambda p, c: p.step(c, ws, obs, key))(policies, old)
            for j, i in enumerate(group):
                carries[i] = jax.tree.map(lambda x, j=j: x[j], new)
                commands[i] = command[j]
        index = state.pursuer_index
        kept = tuple(
            jax.tree.map(lambda a, b, i=i: jnp.where(index == i, a, b), carries[i], old_carry)
            for i, old_carry in enumerate(state.pursuer_carries)
        )
        return kept, jnp.stack(commands)[index]

    def observe(self, state: EvaderEnvState) -> EvaderObs:
        ws = state.world
        return EvaderObs(
            evader_features(ws.target, ws.robot, self.world, self.fov_rad, self.speed_action)
        )

    def step(self, state: EvaderEnvState, action: jax.Array):
        """Head ``action[0]`` rad (clipped to +-``turn_limit_rad``) off the action frame,
        and with ``speed_action`` run at ``speed_share_of(action[1])`` of the cap, while the
        pursuer acts; returns (state, obs, reward, done, info); info's
        ``success`` is the evader's (the episode ran out uncaught), ``terminated`` the
        catch."""
        turn = jnp.clip(action[0], -self.turn_limit_rad, self.turn_limit_rad)
        ws = state.world
        turn = turn_of(turn, ws.target, ws.robot, self.action_frame, self.world)
        behavior_state = ws.target.behavior_state.replace(turn_rad=turn)
        if self.speed_action:
            behavior_state = behavior_state.replace(speed_share=speed_share_of(action[1]))
        ws = ws.replace(target=ws.target.replace(behavior_state=behavior_state))
        key = jax.random.fold_in(ws.key, PURSUER_STREAM)
        carries, command = self._pursue(state, ws, key)
        next_ws, next_obs, _, _, world_info = sim_env.step(ws, command, self.world)
        caught = world_info["success"]
        max_steps = self.world.episode.max_steps
        truncated = (next_ws.step >= max_steps) & ~caught
        r = self.reward
        terms = {
            "alive": jnp.where(caught, 0.0, r.alive_per_episode / max_steps),
            "caught": jnp.where(caught, r.caught, 0.0),
            "distance": r.distance_per_m * (next_ws.distance_m - ws.distance_m),
        }
        info = {f"reward/{name}": value for name, value in terms.items()}
        info.update(
            success=truncated,
            terminated=caught,
            truncated=truncated,
            caught=caught,
            distance_m=next_ws.distance_m,
        )
        next_state = EvaderEnvState(next_ws, next_obs, state.pursuer_index, carries)
        reward = sum(terms.values())
        return next_state, self.observe(next_state), reward, caught | truncated, info

    def with_world(self, world: WorldCfg) -> EvaderEnv:
        return self.replace(world=world.with_behavior("commanded"))

    @property
    def observation_spec(self) -> Spec:
        """``evader_features``, (len(feature_names(fov_rad, speed_action)),), unbounded."""
        dim = len(feature_names(self.fov_rad, self.speed_action))
        inf = jnp.full((dim,), jnp.inf)
        return Spec((dim,), -inf, inf)

    @property
    def action_spec(self) -> Spec:
        """The turn, rad, within +-``turn_limit_rad``, (1,); with ``speed_action`` then the
        speed action in [-1, 1] (``speed_share_of``), (2,)."""
        limit = self.turn_limit_rad
        if not self.speed_action:
            return Spec((1,), jnp.full((1,), -limit), jnp.full((1,), limit))
        return Spec((2,), jnp.asarray([-limit, -1.0]), jnp.asarray([limit, 1.0]))


def evader_env(
    world: WorldCfg,
    pursuers,
    reward: EvaderRewardCfg | None = None,
    weights: tuple[float, ...] = (),
    turn_limit_rad: float = TURN_LIMIT_RAD,
    action_frame: str = "heading",
    fov_rad: float = FULL_VIEW_RAD,
    speed_action: bool = False,
) -> EvaderEnv:
    """An ``EvaderEnv`` in ``world`` (its behaviour set to ``commanded``) against a pursuer
    or a list or tuple of them, one drawn per episode with ``weights`` (one per pursuer,
    normalised; empty: uniform), its action spanning turns of +-``turn_limit_rad`` off
    ``action_frame``, seeing the robot within ``fov_rad``, picking its speed too with
    ``speed_action``. Pursuers are policies built for
    that world (``policies.registry.BASELINES[name](world)``) or trained runs'
    (``rl.policy.load_run``)."""
    pursuers = tuple(pursuers) if isinstance(pursuers, list | tuple) else (pursuers,)
    if not pursuers:
        raise ValueError("give the evader at least one pursuer")
    weights = tuple(float(w) for w in weights)
    if weights and (len(weights) != len(pursuers) or min(weights) < 0 or not sum(weights) > 0):
        raise ValueError(
            f"pursuer weights {list(weights)}: give {len(pursuers)} non-negative weights "
            "with a positive sum, or none (uniform)"
        )
    frozen = tuple(frozen_pursuer(p) for p in pursuers)
    total = sum(weights)
    weights = tuple(w / total for w in weights)
    if action_frame not in ACTION_FRAMES:
        raise ValueError(f"action frame {action_frame!r}: choose one of {', '.join(ACTION_FRAMES)}")
    if not turn_limit_rad > 0:
        raise ValueError(f"turn_limit_rad {turn_limit_rad}: give a positive turn range, rad")
    check_fov(fov_rad)
    return EvaderEnv(
        world.with_behavior("commanded"),
        frozen,
        reward or EvaderRewardCfg(),
        weights,
        float(turn_limit_rad),
        action_frame,
        float(fov_rad),
        bool(speed_action),
    )
