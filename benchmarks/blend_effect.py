"""Eq. 10's blend measured: a policy in a scene with and without it (success, mean catch
time, contacts per episode; docs/scenes.md).

    python benchmarks/blend_effect.py room_8 reactive 200 pursuit
    python benchmarks/blend_effect.py room_8 reactive 200 RUN_DIR --predictor PATH

A baseline is built for the scene's world (``WorldCfg().for_scene``: 40 s, 32 rays); a
trained run plays in its own world moved to the scene with 40 s episodes, with its own scan
and with the plane's (``policies.blend.plane_scan``). Every policy plays the same episodes.
"""

from __future__ import annotations

import argparse
import time

import jax

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.blend import blended, plane_scan
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene")
    p.add_argument("behavior")
    p.add_argument("episodes", type=int)
    p.add_argument("policy", help="a baseline name or a run folder")
    p.add_argument("--predictor", default=None, help="the run's predictor checkpoint")
    a = p.parse_args()
    setup_jax()
    if a.policy in BASELINES:
        world = WorldCfg().for_scene(a.scene).with_behavior(a.behavior)
        catch = BASELINES[a.policy](world)
        policies = {a.policy: catch, f"{a.policy}+blend": blended(catch, world)}
    else:
        from dyncatch.rl.policy import load_run

        run = load_run(a.policy, None, a.predictor)
        world = run.world.with_scene(a.scene).with_behavior(a.behavior)
        world = world.replace(episode=world.episode.replace(duration_s=40.0))
        view = plane_scan(run.policy, world)
        policies = {
            "own scan": run.policy,
            "own scan+blend": blended(run.policy, world),
            "plane scan": view,
            "plane scan+blend": blended(view, world),
        }
    for name, policy in policies.items():
        t = time.perf_counter()
        out = jax.device_get(
            run_episodes(policy, jax.random.key(0), world, a.episodes, contact_tol_m=1e-3)
        )
        print(
            f"{a.scene} {a.behavior} {name:18s} success {out['success'].mean():.3f} "
            f"catch {out['catch_time_s'].mean():5.2f} s "
            f"contacts/ep {out['contacts'].mean():.2f} ({time.perf_counter() - t:.0f} s)",
            flush=True,
        )


if __name__ == "__main__":
    main()
