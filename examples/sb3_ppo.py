"""Stable-Baselines3's PPO on dyncatch's Gymnasium adapter, evaluated as ``dyncatch eval`` does.

The adapter is used unmodified: ``gymnasium.make("dyncatch/Catch-v0", ...)`` under two
standard wrappers, Gymnasium's ``RescaleAction`` (the policy acts in [-1, 1]^3, mapped to
the base command box as dyncatch's own PPO maps it) and SB3's ``VecNormalize`` (running
observation normalisation, as dyncatch's PPO has). The network and the batch geometry
follow dyncatch's PPO where SB3 has the knob (``--hidden-sizes``, ELU, 8192 samples per
update in 4 minibatches, 4 epochs). Then every environment of a ``CatchVectorEnv`` plays
one episode of the mean action on evaluation seeds: success rate with a Wilson 95 % CI and
mean catch time (failures count as the 20 s limit).

    pip install -e '.[examples]'   # torch (CPU) and stable-baselines3; or `make examples`
    python examples/sb3_ppo.py --total-steps 400000
"""

from __future__ import annotations

import argparse
import json
import time

import gymnasium
import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecNormalize

import dyncatch  # noqa: F401  (registers dyncatch/Catch-v0)
from dyncatch.evaluation.gym_episodes import format_summary, run_gym_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.gym import CATCH_ID, CatchVectorEnv


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--total-steps", type=int, default=400_000, help="environment steps")
    p.add_argument("--behavior", default="circle", help="target behaviour")
    p.add_argument("--speed-mps", type=float, default=0.5, help="target speed (m/s)")
    p.add_argument("--hidden-sizes", type=int, nargs="+", default=[64, 64])
    p.add_argument("--num-envs", type=int, default=16, help="environments (DummyVecEnv)")
    p.add_argument("--episodes", type=int, default=200, help="evaluation episodes")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    return p.parse_args(argv)


def train(args: argparse.Namespace) -> tuple[PPO, VecNormalize, float]:
    """Train; returns the model, its observation normaliser and the wall time in seconds."""
    # One thread: a 64-64 MLP on 16 rows gains nothing from more, and torch's spinning
    # workers would fight JAX's for the cores (measured: 4 ms per forward pass instead of µs).
    torch.set_num_threads(1)
    start = time.perf_counter()

    def make_env() -> gymnasium.Env:
        env = gymnasium.make(CATCH_ID, behavior=args.behavior, speed_mps=args.speed_mps)
        return gymnasium.wrappers.RescaleAction(env, np.float32(-1), np.float32(1))

    venv = VecNormalize(
        make_vec_env(make_env, n_envs=args.num_envs, seed=args.seed),
        norm_obs=True,
        norm_reward=False,
        clip_obs=10.0,
    )
    n_steps = max(1, 8192 // args.num_envs)  # 8192 samples per update, as dyncatch's PPO
    model = PPO(
        "MlpPolicy",
        venv,
        n_steps=n_steps,
        batch_size=n_steps * args.num_envs // 4,
        n_epochs=4,
        learning_rate=1e-3,
        gamma=0.99,
        gae_lambda=0.95,
        clip_range=0.2,
        ent_coef=0.005,
        vf_coef=1.0,
        max_grad_norm=1.0,
        policy_kwargs={
            "net_arch": {"pi": list(args.hidden_sizes), "vf": list(args.hidden_sizes)},
            "activation_fn": torch.nn.ELU,
            "log_std_init": 0.0,
        },
        seed=args.seed,
        device="cpu",
    )
    model.learn(total_timesteps=args.total_steps)
    venv.training = False  # freeze the observation statistics for evaluation
    return model, venv, time.perf_counter() - start


def evaluate(model: PPO, venv: VecNormalize, args: argparse.Namespace) -> dict:
    """``dyncatch eval``'s numbers for the mean action, one episode per environment."""
    env = gymnasium.wrappers.vector.RescaleAction(
        CatchVectorEnv(args.episodes, behavior=args.behavior, speed_mps=args.speed_mps),
        np.float32(-1),
        np.float32(1),
    )

    def policy(obs):
        return model.predict(venv.normalize_obs(obs), deterministic=True)[0]

    return summarize(run_gym_episodes(env, policy, seed=args.seed))


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    model, venv, train_s = train(args)
    result = {
        "library": "stable-baselines3",
        "total_steps": int(model.num_timesteps),
        "train_s": train_s,
        "samples_per_s": model.num_timesteps / train_s,
        "hidden_sizes": list(args.hidden_sizes),
        "behavior": args.behavior,
        "speed_mps": args.speed_mps,
        **evaluate(model, venv, args),
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"SB3 PPO, {result['total_steps']} steps in {train_s:.0f} s "
            f"({result['samples_per_s']:.0f} samples/s); {args.behavior} at "
            f"{args.speed_mps} m/s: {format_summary(result)}"
        )
    return result


if __name__ == "__main__":
    main()
