"""How much of its speed cap a learned evader with a speed action uses (issue 34, R10 in
``benchmarks/results/evader_intercept/NOTES.md``).

    .venv/bin/python benchmarks/evader_speed_share.py RUN [RUN ...] [--against intercept]
        [--speeds 1.4 1.6] [--episodes 200] [--sample]

Plays each evader (``--behavior learned``, deterministic unless ``--sample``) against a
scripted pursuer in the default world, as ``dyncatch eval`` does, and prints the target's
speed over its cap averaged over every live step of every episode, and the lowest
episode's average (1.0: the evader always runs at the cap, the speed action unused).
"""

from __future__ import annotations

import argparse

import jax
import jax.numpy as jnp

from dyncatch.policies.api import as_recurrent
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.api import as_env
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


def speed_share(run: str, against: str, speed_mps: float, episodes: int, sample: bool, seed: int):
    """(mean share over live steps, lowest episode's mean share)."""
    world = WorldCfg().with_behavior("learned")
    target = world.target.replace(evader_checkpoint=run, evader_sample=sample)
    world = world.replace(target=target).with_speed(speed_mps)
    env, policy = as_env(world), as_recurrent(BASELINES[against](world))

    def play(key):
        k_reset, k_act = jax.random.split(key)
        state = jax.vmap(env.reset)(jax.random.split(k_reset, episodes))
        obs = jax.vmap(env.observe)(state)
        carry = jax.vmap(policy.init_carry)(state, obs)

        def body(c, t):
            state, obs, carry, done, total, count = c
            keys = jax.random.split(jax.random.fold_in(k_act, t), episodes)
            carry, action = jax.vmap(policy.step)(carry, state, obs, keys)
            state, obs, _, now_done, _ = jax.vmap(env.step)(state, action)
            live = ~done
            share = state.target.speed_mps / state.target.speed_cap_mps
            return (state, obs, carry, done | now_done, total + jnp.where(live, share, 0.0),
                    count + live), None  # fmt: skip

        zeros = jnp.zeros(episodes)
        init = (state, obs, carry, jnp.zeros(episodes, bool), zeros, zeros)
        final, _ = jax.lax.scan(body, init, jnp.arange(int(world.episode.max_steps)))
        total, count = final[4], final[5]
        return total.sum() / count.sum(), (total / jnp.maximum(count, 1)).min()

    mean, lowest = jax.jit(play)(jax.random.key(seed))
    return float(mean), float(lowest)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="evader run folders (dyncatch evader train --out)")
    ap.add_argument("--against", default="intercept", choices=sorted(BASELINES))
    ap.add_argument("--speeds", type=float, nargs="+", default=[1.4, 1.6])
    ap.add_argument("--episodes", type=int, default=200)
    ap.add_argument("--sample", action="store_true", help="the evader samples its actions")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    for run in args.runs:
        for v in args.speeds:
            mean, lowest = speed_share(run, args.against, v, args.episodes, args.sample, args.seed)
            print(f"{run} at {v} m/s: mean speed share {mean:.3f}, lowest episode {lowest:.3f}")


if __name__ == "__main__":
    setup_jax()
    main()
