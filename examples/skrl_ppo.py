"""skrl's PPO on dyncatch's Gymnasium vector adapter, evaluated as ``dyncatch eval`` does.

The adapter is used unmodified: ``CatchVectorEnv`` (one jitted call steps every
environment; same-step auto-reset, which skrl's Gymnasium wrapper expects of a vector env)
under Gymnasium's ``RescaleAction`` (the policy acts in [-1, 1]^3, mapped to the base
command box as dyncatch's own PPO maps it). The agent follows dyncatch's PPO where skrl has
the knob: ``--hidden-sizes`` with ELU for the actor and the critic, a state-independent
log std, running observation standardisation, 256 envs x 32 steps per update in 4
minibatches, 4 epochs, an adaptive-KL learning rate. Then every environment of a fresh
``CatchVectorEnv`` plays one episode of the mean action on evaluation seeds: success rate
with a Wilson 95 % CI and mean catch time (failures count as the 20 s limit).

    pip install -e '.[examples]'   # torch (CPU) and skrl; or `make examples`
    python examples/skrl_ppo.py --total-steps 400000
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time

import gymnasium
import numpy as np
import torch
from skrl.agents.torch.ppo import PPO, PPO_CFG
from skrl.envs.wrappers.torch import wrap_env
from skrl.memories.torch import RandomMemory
from skrl.models.torch import DeterministicMixin, GaussianMixin, Model
from skrl.resources.preprocessors.torch import RunningStandardScaler
from skrl.resources.schedulers.torch import KLAdaptiveLR
from skrl.trainers.torch import SequentialTrainer
from skrl.utils import set_seed

from dyncatch.evaluation.gym_episodes import format_summary, run_gym_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.gym import CatchVectorEnv


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--total-steps", type=int, default=400_000, help="environment steps")
    p.add_argument("--behavior", default="circle", help="target behaviour")
    p.add_argument("--speed-mps", type=float, default=0.5, help="target speed (m/s)")
    p.add_argument("--hidden-sizes", type=int, nargs="+", default=[64, 64])
    p.add_argument("--num-envs", type=int, default=256, help="environments of the vector env")
    p.add_argument("--episodes", type=int, default=200, help="evaluation episodes")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--json", action="store_true", help="print one JSON object")
    return p.parse_args(argv)


def mlp(inputs: int, hidden: list[int], outputs: int) -> torch.nn.Sequential:
    layers: list[torch.nn.Module] = []
    for width in hidden:
        layers += [torch.nn.Linear(inputs, width), torch.nn.ELU()]
        inputs = width
    return torch.nn.Sequential(*layers, torch.nn.Linear(inputs, outputs))


class Policy(GaussianMixin, Model):
    """Gaussian actor: mean (N, 3) from the MLP, one learned log std per action."""

    def __init__(self, observation_space, action_space, hidden: list[int]):
        Model.__init__(self, observation_space=observation_space, action_space=action_space)
        GaussianMixin.__init__(self, clip_actions=True)
        self.net = mlp(self.num_observations, hidden, self.num_actions)
        self.log_std = torch.nn.Parameter(torch.zeros(self.num_actions))

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {"log_std": self.log_std}


class Value(DeterministicMixin, Model):
    """Critic: value (N, 1) from its own MLP."""

    def __init__(self, observation_space, action_space, hidden: list[int]):
        Model.__init__(self, observation_space=observation_space, action_space=action_space)
        DeterministicMixin.__init__(self)
        self.net = mlp(self.num_observations, hidden, 1)

    def compute(self, inputs, role=""):
        return self.net(inputs["observations"]), {}


def make_vector_env(num_envs: int, args: argparse.Namespace) -> gymnasium.vector.VectorEnv:
    env = CatchVectorEnv(num_envs, behavior=args.behavior, speed_mps=args.speed_mps)
    return gymnasium.wrappers.vector.RescaleAction(env, np.float32(-1), np.float32(1))


def train(args: argparse.Namespace) -> tuple[PPO, int, float]:
    """Train; returns the agent, the environment steps taken and the wall time in seconds."""
    torch.set_num_threads(1)  # small MLPs: more threads only fight JAX's for the cores
    set_seed(args.seed)
    start = time.perf_counter()
    env = wrap_env(make_vector_env(args.num_envs, args), wrapper="gymnasium", verbose=False)
    rollouts = 32
    models = {
        "policy": Policy(env.observation_space, env.action_space, args.hidden_sizes),
        "value": Value(env.observation_space, env.action_space, args.hidden_sizes),
    }
    cfg = PPO_CFG(
        rollouts=rollouts,
        learning_epochs=4,
        mini_batches=4,
        discount_factor=0.99,
        gae_lambda=0.95,
        learning_rate=1e-3,
        learning_rate_scheduler=KLAdaptiveLR,
        learning_rate_scheduler_kwargs={"kl_threshold": 0.01},
        observation_preprocessor=RunningStandardScaler,
        observation_preprocessor_kwargs={"size": env.observation_space},
        grad_norm_clip=1.0,
        ratio_clip=0.2,
        value_clip=0.2,
        entropy_loss_scale=0.005,
        value_loss_scale=1.0,
        experiment={
            "directory": tempfile.mkdtemp(prefix="skrl_"),
            "write_interval": 0,
            "checkpoint_interval": 0,
        },
    )
    memory = RandomMemory(memory_size=rollouts, num_envs=env.num_envs)
    agent = PPO(
        models=models,
        memory=memory,
        observation_space=env.observation_space,
        action_space=env.action_space,
        cfg=cfg,
    )
    iterations = -(-args.total_steps // (rollouts * env.num_envs))
    timesteps = iterations * rollouts  # whole updates, each of num_envs x rollouts samples
    trainer_cfg = {
        "timesteps": timesteps,
        "headless": True,
        "disable_progressbar": True,
        "close_environment_at_exit": False,  # skrl would log at exit, after streams close
    }
    SequentialTrainer(env=env, agents=agent, cfg=trainer_cfg).train()
    return agent, timesteps * env.num_envs, time.perf_counter() - start


def evaluate(agent: PPO, args: argparse.Namespace) -> dict:
    """``dyncatch eval``'s numbers for the mean action, one episode per environment."""
    agent.enable_training_mode(False)

    def policy(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            _, out = agent.act(torch.as_tensor(obs), None, timestep=0, timesteps=0)
        return out["mean_actions"].clamp(-1.0, 1.0).numpy()

    return summarize(run_gym_episodes(make_vector_env(args.episodes, args), policy, args.seed))


def main(argv: list[str] | None = None) -> dict:
    args = parse_args(argv)
    agent, steps, train_s = train(args)
    result = {
        "library": "skrl",
        "total_steps": steps,
        "train_s": train_s,
        "samples_per_s": steps / train_s,
        "hidden_sizes": list(args.hidden_sizes),
        "behavior": args.behavior,
        "speed_mps": args.speed_mps,
        **evaluate(agent, args),
    }
    if args.json:
        print(json.dumps(result))
    else:
        print(
            f"skrl PPO, {result['total_steps']} steps in {train_s:.0f} s "
            f"({result['samples_per_s']:.0f} samples/s); {args.behavior} at "
            f"{args.speed_mps} m/s: {format_summary(result)}"
        )
    return result


if __name__ == "__main__":
    main()
