"""``dyncatch train``: PPO for one method and behaviour, with logs, checkpoints and resume."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from dyncatch.rl.config import PPOCfg
from dyncatch.sim.config import RewardCfg, WorldCfg

TRAIN_WORLD = WorldCfg().replace(reward=RewardCfg(visibility=0.2 * 0.02))
"""Eq. 9 with w2 = 0.2 read as a per-second rate (x 0.02 s): at 0.2 per step, watching the
target pays more than catching it (measured; docs/model.md, last section)."""


@dataclasses.dataclass(frozen=True)
class TrainCmd:
    """Train a catching policy with PPO."""

    method: str = "sp_rl"
    """One of rl, p_rl, sp_rl, gt_rl (sp_fp is gt_rl evaluated with the predictor)."""
    behavior: str = "reactive"
    """Target behaviour."""
    total_steps: int = 2_000_000
    """Environment steps to train for (rounded up to whole iterations)."""
    seed: int = 0
    """Training seed."""
    out: Path = Path("runs/train")
    """Run folder: checkpoint.safetensors, metrics.csv, tb/."""
    predictor: Path | None = None
    """Predictor checkpoint (from dyncatch predictor train) for p_rl and sp_rl."""
    checkpoint_every: int = 20
    """Iterations between checkpoints (one is always written at the end)."""
    resume: bool = False
    """Continue the run in --out from its checkpoint (same config required)."""
    eval_every: int = 10
    """Iterations between evaluations of the mean-action policy (0: never). The training
    success_rate column is biased upwards (catches end sooner, so they are over-represented
    among the episodes that end in an iteration); eval/success_rate is not."""
    eval_episodes: int = 200
    """Episodes per evaluation: the same evaluation seeds every time, disjoint from training."""
    eval_speed_mps: float = 1.8
    """Target speed of the evaluation episodes."""
    ppo: PPOCfg = PPOCfg()
    """PPO hyper-parameters and batch geometry."""
    world: WorldCfg = TRAIN_WORLD
    """The simulated world."""


def header_of(cmd: TrainCmd) -> dict:
    """What a checkpoint must agree on to be resumed."""
    return {
        "format": "dyncatch.train/1",
        "method": cmd.method,
        "behavior": cmd.behavior,
        "seed": cmd.seed,
        "predictor": str(cmd.predictor) if cmd.predictor else None,
        "ppo": dataclasses.asdict(cmd.ppo),
        "world": dataclasses.asdict(cmd.world.with_behavior(cmd.behavior)),
    }


def run_train(cmd: TrainCmd) -> dict:
    import json
    import time

    import jax
    from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

    from dyncatch.rl.config import validate_ppo
    from dyncatch.rl.logging import MetricLog
    from dyncatch.rl.methods import get_method, method_obs
    from dyncatch.rl.train import make_train
    from dyncatch.sim.validate import validate_world
    from dyncatch.utils.tree_io import load_tree, save_tree

    world = validate_world(cmd.world.with_behavior(cmd.behavior))
    ppo = validate_ppo(cmd.ppo)
    if cmd.total_steps < 1 or cmd.checkpoint_every < 1:
        raise ValueError("--total-steps and --checkpoint-every must be >= 1")
    if cmd.eval_every < 0 or cmd.eval_episodes < 1 or cmd.eval_speed_mps < 0:
        raise ValueError(
            "--eval-every must be >= 0, --eval-episodes >= 1 and --eval-speed-mps >= 0"
        )
    predictor = params = None
    method = get_method(cmd.method)
    if method.trained_as is not None:
        raise ValueError(
            f"method {cmd.method!r} is not trained: train {method.trained_as!r} "
            f"and evaluate it as {cmd.method!r}"
        )
    if method.velocity_input not in (None, "ground_truth"):
        if cmd.predictor is None:
            raise ValueError(f"method {cmd.method!r} needs --predictor PATH")
        from dyncatch.predictor.checkpoint import load as load_predictor

        predictor, params = load_predictor(cmd.predictor)
    obs_fn = method_obs(cmd.method, predictor, params)
    init, iterate, net = make_train(world, ppo, obs_fn)
    init, iterate = jax.jit(init), jax.jit(iterate)

    ckpt = cmd.out / "checkpoint.safetensors"
    header = header_of(cmd)
    ts = init(jax.random.key(cmd.seed))
    if cmd.resume:
        ts, saved = load_tree(ckpt, ts)
        diff = [k for k in header if saved.get(k) != json.loads(json.dumps(header[k]))]
        if diff:
            raise ValueError(
                f"{ckpt} was trained with other {', '.join(diff)}; "
                "resume with the same flags or choose another --out"
            )
    elif ckpt.exists():
        raise ValueError(f"{ckpt} exists: pass --resume to continue it or choose another --out")
    cmd.out.mkdir(parents=True, exist_ok=True)
    start = int(ts.iteration)
    total_iters = -(-cmd.total_steps // ppo.batch_size)
    log = MetricLog(cmd.out, resume_iteration=start)
    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[info]}"),
        TimeRemainingColumn(),
    ]
    metrics: dict[str, float] = {}
    # Wall-clock seconds of training (compilation included, evaluations excluded),
    # continued across resumes.
    clock0 = time.perf_counter() - log.last("time_s")
    eval_world = world.with_speed(cmd.eval_speed_mps)

    def evaluate(ts) -> dict[str, float]:
        from dyncatch.evaluation.episodes import run_episodes
        from dyncatch.evaluation.grid import EVAL_STREAM
        from dyncatch.rl.policy import LearnedPolicy

        policy = LearnedPolicy(net, ts.params, ts.norm, obs_fn, world)
        key = jax.random.fold_in(jax.random.key(cmd.seed), EVAL_STREAM)
        out = jax.device_get(run_episodes(policy, key, eval_world, cmd.eval_episodes))
        return {
            "eval/success_rate": float(out["success"].mean()),
            "eval/catch_time_s": float(out["catch_time_s"].mean()),
        }

    with Progress(*columns) as bar:
        task = bar.add_task(
            f"{cmd.method} vs {cmd.behavior}", total=total_iters, completed=start, info="compiling"
        )
        t0 = None  # the clock starts after the first (compiling) iteration
        for it in range(start, total_iters):
            ts, m = iterate(ts)
            metrics = {k: float(v) for k, v in jax.device_get(m).items()}
            metrics["time_s"] = time.perf_counter() - clock0
            if cmd.eval_every and (
                (it + 1) % cmd.eval_every == 0 or it == start or it + 1 == total_iters
            ):
                t_eval = time.perf_counter()
                metrics.update(evaluate(ts))
                clock0 += time.perf_counter() - t_eval
            else:
                metrics.update({"eval/success_rate": "", "eval/catch_time_s": ""})
            log.write(it + 1, int(ts.env_steps), metrics)
            if t0 is None:
                t0, done0 = time.perf_counter(), it + 1
            elapsed = time.perf_counter() - t0
            rate = (it + 1 - done0) * ppo.batch_size / elapsed if elapsed > 0 else 0.0
            bar.update(
                task,
                advance=1,
                info=f"{rate:,.0f} samples/s  success {metrics['success_rate']:.2f}",
            )
            if (it + 1) % cmd.checkpoint_every == 0 or it + 1 == total_iters:
                save_tree(ckpt, ts, header)
    log.close()
    return metrics
