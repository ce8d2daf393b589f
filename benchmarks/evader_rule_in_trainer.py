"""Does the evader's trainer present the interception planner as `dyncatch eval` does?

Plays the deterministic eq. 11-12 rule (no gamma) as the agent of ``rl.evader.EvaderEnv``
(the flee action frame: an action of sign(beta) x alpha within r_ev, 0 beyond) against
``intercept``, one episode per environment from reset, and prints the catch rate per speed.
Compare with ``dyncatch eval intercept --speeds 1.4 1.6 1.8 --episodes 1000 --behavior
reactive --world.target.gamma-max-rad 0`` (docs/evaders.md, "what limits the learned
evader"). Measured: 0.169 / 0.080 / 0.008 here against 0.175 / 0.085 / 0.005 there.

    PYTHONPATH=src python benchmarks/evader_rule_in_trainer.py [EPISODES]
"""

from __future__ import annotations

import sys

import jax
import jax.numpy as jnp

from dyncatch.policies.registry import BASELINES
from dyncatch.rl.evader import evader_env
from dyncatch.rl.evader_train import EVADER_WORLD
from dyncatch.sim.geometry import wrap_angle


def caught_share(speed_mps: float, episodes: int, seed: int = 0) -> float:
    """The share of ``episodes`` in which ``intercept`` catches the noise-free rule."""
    world = EVADER_WORLD.with_speed(speed_mps)
    env = evader_env(world, BASELINES["intercept"](world), action_frame="flee")
    tc = world.target

    def rule(s):
        t, r = s.world.target, s.world.robot
        d = t.xy_m - r.xy_m
        beta = wrap_angle(jnp.arctan2(d[1], d[0]) - r.yaw_rad)
        close = jnp.sum(d * d) <= tc.evade_radius_m**2
        return jnp.where(close, jnp.sign(beta) * tc.evade_angle_rad, 0.0)[None]

    def episode(key):
        def body(carry, _):
            s, ended, caught = carry
            s, _, _, done, info = env.step(s, rule(s))
            return (s, ended | done, caught | (~ended & info["caught"])), None

        start = (env.reset(key), jnp.zeros((), bool), jnp.zeros((), bool))
        (_, _, caught), _ = jax.lax.scan(body, start, None, world.episode.max_steps)
        return caught

    keys = jax.random.split(jax.random.key(seed), episodes)
    return float(jnp.mean(jax.jit(jax.vmap(episode))(keys)))


if __name__ == "__main__":
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 1000
    for speed in (1.4, 1.6, 1.8):
        print(f"{speed} m/s: caught {caught_share(speed, n):.3f} of {n}", flush=True)
