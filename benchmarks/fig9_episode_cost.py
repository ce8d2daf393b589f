"""Seconds per 1000 Fig. 9 episodes of a trained policy in a scene, plain and blended, and of
the scripted pursuit (the simulator alone), after compilation: the rates behind
``reproduce/estimate.py``'s ``EST_SCENE_S_PER_1000_EPISODES``.

    python benchmarks/fig9_episode_cost.py --run RUN --predictor PREDICTOR.safetensors \\
        [--method sp_rl --scene room_8 --behavior reactive --speed-mps 1.8 --episodes 500]

``--breakdown`` also times the blended row with eq. 10's blend cut to each of its parts
(``Blended._blend`` replaced, for profiling only): the flag's ``lax.cond`` alone, the
clearance and weights, pi_collid's range scan, pi_collid's corridor steering on a fixed scan.

Each rate is the second of two identical calls; the first call's extra seconds are its
compilation (the blended row shares the plain row's program: none). On the idle machine.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import jax


def seconds_per_1000(policy, world, episodes: int, contact_tol_m: float) -> tuple[float, float]:
    """(seconds per 1000 episodes of the second call, the first call's extra seconds: its
    compilation, where the program was not compiled before)."""
    from dyncatch.evaluation.episodes import run_episodes

    def call() -> float:
        t = time.perf_counter()
        out = run_episodes(
            policy, jax.random.PRNGKey(0), world, episodes, contact_tol_m=contact_tol_m
        )
        jax.block_until_ready(out)
        return time.perf_counter() - t

    first, second = call(), call()
    return second / episodes * 1000, first - second


def run(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run", type=Path, required=True, help="a trained run's folder")
    ap.add_argument("--predictor", type=Path, default=None, help="its frozen predictor")
    ap.add_argument("--method", default="sp_rl")
    ap.add_argument("--scene", default="room_8")
    ap.add_argument("--behavior", default="reactive")
    ap.add_argument("--speed-mps", type=float, default=1.8)
    ap.add_argument("--episodes", type=int, default=500)
    ap.add_argument("--breakdown", action="store_true", help="time the blend's parts too")
    args = ap.parse_args(argv)

    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    from dyncatch.reproduce.fig9 import CONTACT_TOL_M, Deployment
    from dyncatch.reproduce.jobs import PolicySpec

    spec = PolicySpec(args.method, 0, args.run, args.predictor)
    out = {"scene": args.scene, "behavior": args.behavior, "episodes": args.episodes}
    for name, learned, blend in (("pursuit", False, False), ("plain", True, False),
                                 ("blended", True, True)):  # fmt: skip
        where = Deployment(args.scene, args.behavior, blend, spec, None, args.speed_mps)
        policy, world = where.load(blend_as_flag=True)
        if not learned:
            from dyncatch.policies.registry import BASELINES

            policy = BASELINES["pursuit"](world)
        rate, compile_s = seconds_per_1000(policy, world, args.episodes, CONTACT_TOL_M)
        out[f"{name}_s_per_1000"], out[f"{name}_first_call_extra_s"] = rate, compile_s
    if args.breakdown:
        out["blend_parts_s_per_1000"] = _breakdown(spec, args, CONTACT_TOL_M)
    print(json.dumps(out))
    return 0


def _breakdown(spec, args, contact_tol_m: float) -> dict[str, float]:
    import jax.numpy as jnp

    from dyncatch.policies import blend
    from dyncatch.reproduce.fig9 import Deployment

    def scan(self, state):
        return blend.collid_scan_m(state, self.world, self.cfg.collid)

    def fixed_scan(state):
        # A scan the compiler cannot fold away (it depends on the state).
        return jnp.full((blend.CollidCfg().scan_rays,), 3.0) + 1e-3 * state.robot.xy_m[0]

    parts = {
        "cond only": lambda self, state, a: a,
        "clearance and weights": lambda self, state, a: sum(self.weights(state)) * a,
        "range scan": lambda self, state, a: a + 0.0 * jnp.sum(scan(self, state)),
        "corridor steering on a fixed scan": lambda self, state, a: blend.collid_action(
            fixed_scan(state), a, self.world, self.cfg.collid
        ),
    }
    whole, out = blend.Blended._blend, {}
    try:
        for name, fn in parts.items():
            blend.Blended._blend = fn
            jax.clear_caches()
            where = Deployment(args.scene, args.behavior, True, spec, None, args.speed_mps)
            policy, world = where.load(blend_as_flag=True)
            out[name] = seconds_per_1000(policy, world, args.episodes, contact_tol_m)[0]
    finally:
        blend.Blended._blend = whole
    return out


if __name__ == "__main__":
    raise SystemExit(run())
