"""Run a policy for exactly one episode in each of N parallel environments.

No auto-reset: every environment plays one episode to its end and then freezes its
statistics, so the N outcomes are independent and unbiased by episode length.

What compiles: one program per (policy structure, world's static fields, episodes, steps,
contact counting; and the number of speeds for ``run_episodes_at_speeds``). The policy
structure is a method's network and input function, or a scripted baseline with the world
it was built for (a hashable policy is a constant); the world's static fields are the
behaviour, the scene and the scan's rays. A trained policy's parameters, the world's
numbers (the target's speed among them) and the key are arguments, and so is eq. 10's
blend when it is a flag (``policies.blend.deploy(..., blend_as_flag=True)``): every seed,
speed and blend variant of a method in a scene shares one compilation
(``benchmarks/eval_compiles.py``).
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp

from dyncatch.policies.api import as_recurrent
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scan import robot_clearance_m


def _touching(state, env: Environment, tol_m: float) -> jax.Array:
    """(N,) bool: each robot's footprint is within ``tol_m`` of a wall or obstacle."""
    clearance = jax.vmap(robot_clearance_m, in_axes=(0, None))(state, env.world)
    return clearance <= tol_m


def _run_impl(
    policy: Callable,
    key: jax.Array,
    env: Environment,
    num_episodes: int,
    num_steps: int,
    contact_tol_m: float | None = None,
    events: tuple[str, ...] = (),
):
    k_reset, k_act = jax.random.split(key)
    state = jax.vmap(env.reset)(jax.random.split(k_reset, num_episodes))
    obs = jax.vmap(env.observe)(state)
    vstep = jax.vmap(env.step)
    pol = as_recurrent(policy)
    vpolicy = jax.vmap(pol.step)

    count = contact_tol_m is not None

    def body(carry, t):
        state, obs, pcarry, done, success, steps, ret, touching, contacts, happened = carry
        keys = jax.random.split(jax.random.fold_in(k_act, t), num_episodes)
        pcarry, action = vpolicy(pcarry, state, obs, keys)
        state, obs, reward, now_done, info = vstep(state, action)
        live = ~done
        # Steps until the first catch (or the end): the catch time, whether or not the
        # catch ends the episode (``reward.success_per``).
        steps = steps + (live & ~success).astype(jnp.int32)
        success = success | (live & info["success"])
        ret = ret + jnp.where(live, reward, 0.0)
        happened = {k: v | (live & info[k]) for k, v in happened.items()}
        if count:  # a contact is a step that begins a touch (not one that holds it)
            now = _touching(state, env, contact_tol_m)
            contacts = contacts + (live & now & ~touching).astype(jnp.int32)
            touching = now
        carry = (state, obs, pcarry, done | now_done, success, steps, ret, touching, contacts)
        return (*carry, happened), None

    zeros_b = jnp.zeros(num_episodes, bool)
    pcarry = jax.vmap(pol.init_carry)(state, obs)
    ints, floats = jnp.zeros(num_episodes, jnp.int32), jnp.zeros(num_episodes)
    touching = _touching(state, env, contact_tol_m) if count else zeros_b
    happened = {k: zeros_b for k in events}
    init = (state, obs, pcarry, zeros_b, zeros_b, ints, floats, touching, ints, happened)
    final, _ = jax.lax.scan(body, init, jnp.arange(num_steps))
    success, steps, ret, _, contacts, happened = final[4:]
    return success, steps, ret, contacts, happened


_STATIC = ("num_episodes", "num_steps", "contact_tol_m", "events")
_run_static = jax.jit(_run_impl, static_argnames=("policy", *_STATIC))
"""Hashable policies (scripted baselines) are compile-time constants."""
_run_pytree = jax.jit(_run_impl, static_argnames=_STATIC)
"""Pytree policies (``is_pytree_policy``, e.g. trained networks) are arguments, so every
checkpoint of one architecture reuses one compilation."""


def _run(policy, key, env: Environment, num_episodes: int, num_steps: int, contact_tol_m, events):
    run = _run_pytree if getattr(policy, "is_pytree_policy", False) else _run_static
    return run(policy, key, env, num_episodes, num_steps, contact_tol_m, events)


def run_episodes(
    policy: Callable,
    key: jax.Array,
    env: Environment | WorldCfg,
    num_episodes: int,
    contact_tol_m: float | None = None,
    events: tuple[str, ...] = (),
) -> dict[str, jax.Array]:
    """Play ``num_episodes`` episodes of a policy (see ``dyncatch.policies.api``) in ``env``
    (a backend of ``dyncatch.sim.api``; a ``WorldCfg`` means the JAX world).

    Returns ``success`` (N,) bool, ``catch_time_s`` (N,) (the episode limit on failure, as
    in the paper) and ``return`` (N,). With ``contact_tol_m`` (the JAX world only) also
    ``contacts`` (N,) int: the collisions of each episode, counted as the steps on which
    the robot's footprint comes within ``contact_tol_m`` of a wall or obstacle
    (``sim.scan.robot_clearance_m``) after a step on which it was not (a push-out leaves
    it at 0: a slide along an obstacle is one contact, however long). For each name in
    ``events``, a boolean key of the backend's step ``info`` (``fell`` on the full body),
    (N,) bool: whether it was true after one of the episode's steps.
    """
    env = as_env(env)
    num_steps = int(env.world.episode.max_steps)
    success, steps, ret, contacts, happened = _run(
        policy, key, env, num_episodes, num_steps, contact_tol_m, tuple(events)
    )
    dt = env.world.episode.dt_s
    catch_time = jnp.where(success, steps * dt, num_steps * dt)
    out = {"success": success, "catch_time_s": catch_time, "return": ret}
    if contact_tol_m is not None:
        out["contacts"] = contacts
    return {**out, **happened}


def _run_speeds_impl(policy, keys, env, speeds, num_episodes, num_steps, contact_tol_m=None):
    def one(key, speed):
        cell = env.with_world(env.world.with_speed(speed))
        return _run_impl(policy, key, cell, num_episodes, num_steps, contact_tol_m)

    return jax.vmap(one)(keys, speeds)


_SPEEDS_STATIC = ("num_episodes", "num_steps", "contact_tol_m")
_speeds_static = jax.jit(_run_speeds_impl, static_argnames=("policy", *_SPEEDS_STATIC))
_speeds_pytree = jax.jit(_run_speeds_impl, static_argnames=_SPEEDS_STATIC)


def run_episodes_at_speeds(
    policy: Callable, keys: jax.Array, env: Environment | WorldCfg, speeds_mps, num_episodes: int
) -> dict[str, jax.Array]:
    """``run_episodes`` at each fixed target speed, all speeds in one batched computation:
    row ``i`` of every output, shape (S, N), is ``run_episodes(policy, keys[i],
    env.with_speed(speeds_mps[i]), num_episodes)`` (the same episodes, to float
    tolerance; one compilation and one larger batch instead of S calls). The speed is a
    traced leaf of the world, so the JAX world only."""
    env = as_env(env)
    num_steps = int(env.world.episode.max_steps)
    speeds = jnp.asarray(speeds_mps, jnp.float32)
    run = _speeds_pytree if getattr(policy, "is_pytree_policy", False) else _speeds_static
    success, steps, ret, *_ = run(policy, keys, env, speeds, num_episodes, num_steps, None)
    dt = env.world.episode.dt_s
    catch_time = jnp.where(success, steps * dt, num_steps * dt)
    return {"success": success, "catch_time_s": catch_time, "return": ret}
