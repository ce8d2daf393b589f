"""Train an evader against a frozen pursuer: ``train_evader(cfg)`` writes the checkpoint the
``learned`` behaviour loads (``OUT/evader.safetensors``), ``OUT/metrics.csv`` and, for
``--resume``, the whole training state (``OUT/train_state.safetensors``).

The PPO is ``rl.train.make_train`` over ``rl.evader.EvaderEnv``, unchanged; only the actor
and the observation normaliser are exported (``sim.behaviors.evader_net``), with a header
that records the features, the architecture, the pursuer, the world, PPO and the reward.
"""

from __future__ import annotations

import dataclasses
import functools
import json
import math
import shutil
import time
from pathlib import Path

import jax
import numpy as np

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.registry import BASELINES
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.evader import EvaderRewardCfg, Skeleton, evader_env, split_arrays
from dyncatch.rl.guard import check_finite
from dyncatch.rl.logging import MetricLog
from dyncatch.rl.networks import ActorCritic
from dyncatch.rl.policy import LearnedPolicy, load_run
from dyncatch.rl.stages import diff_message
from dyncatch.rl.train import TrainState, as_stepper, flat_obs, make_train
from dyncatch.sim.behaviors.evader_net import (
    EVADER_CHECKPOINT,
    FULL_VIEW_RAD,
    EvaderNet,
    save_evader,
)
from dyncatch.sim.behaviors.learned import TURN_LIMIT_RAD, ActionFrame, check_fov, feature_names
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world
from dyncatch.utils.config_io import config_diff, to_json
from dyncatch.utils.files import check_out_dir, read_json, write_json
from dyncatch.utils.progress import NoProgress, Progress
from dyncatch.utils.tree_io import TreeFileError, load_tree, read_header, save_tree

EVADER_PPO = PPOCfg(num_envs=256, num_steps=32, hidden_sizes=(64, 64))
"""The evader's PPO: the pursuer's defaults but a small network (11 inputs, one output: two
layers of 64 are ample, and cheap inside every world step that deploys it) and 256
environments, so an iteration takes a couple of seconds on two CPU cores."""
EVADER_WORLD = WorldCfg().replace(
    target=WorldCfg().target.replace(speed_min_mps=1.4, speed_max_mps=1.8)
)
"""The evader's training world: the default one with the per-episode speed cap drawn in
[1.4, 1.8] m/s, the speeds issue 34 measures it at (its speed is among its inputs)."""


@dataclasses.dataclass(frozen=True)
class EvaderTrainCfg:
    """Train a target (the evader) with PPO against a frozen pursuer."""

    against: tuple[str, ...] = ("pursuit",)
    """The frozen pursuers: scripted baselines of dyncatch.policies.registry.BASELINES
    (pursuit, intercept) or run folders of `dyncatch train` (rl, p_rl, sp_rl, gt_rl; a
    predictor method loads the predictor its checkpoint names); with several, each episode
    draws one (--against-weights)."""
    against_weights: tuple[float, ...] = ()
    """The chance of each pursuer of --against per episode, one weight each (normalised);
    empty: uniform."""
    total_steps: int = 2_000_000
    """Environment steps to train for (rounded up to whole iterations)."""
    seed: int = 0
    """Training seed."""
    out: Path = Path("runs/evader")
    """Run folder: evader.safetensors (load it with --behavior learned
    --world.target.evader-checkpoint OUT) and metrics.csv."""
    checkpoint_every: int = 20
    """Iterations between checkpoints (one is always written at the end): the evader and
    the whole training state (train_state.safetensors, which --resume continues)."""
    resume: bool = False
    """Continue the run in --out from its training state (train_state.safetensors) with the
    same flags (--total-steps, --checkpoint-every and --out may change): the iterations
    after it are those of an uninterrupted run, to the bit on one machine, and metrics.csv
    drops its rows past it. Without --resume an existing run is refused."""
    select_every: int = 0
    """Keep the best iterate instead of the last: every this many iterations (and at the
    end) the deterministic evader plays --select-episodes held-out episodes of its training
    world (keys of their own, the same for every candidate) and evader.safetensors is
    rewritten only when its escape rate beats every earlier one; selection.json records
    each candidate, evader_last.safetensors the last iterate. 0 (default): the last
    iterate, written every --checkpoint-every. A reading for issue 34: evader training
    peaks early and then declines (docs/evaders.md)."""
    select_episodes: int = 128
    """Held-out episodes per candidate of --select-every (a binomial error of about 0.04 at
    128)."""
    turn_limit_rad: float = TURN_LIMIT_RAD
    """The turn, rad, that the action's range [-1, 1] spans (default pi, a reading: any
    heading change; the body then turns by at most target.max_turn_rate_rps x dt, 0.2 rad a
    step by default, so every turn beyond that is the same turn). Recorded in the file, so
    the deployed evader maps actions as in training."""
    action_frame: ActionFrame = "heading"
    """What the action's angle is added to for the desired heading
    (dyncatch.sim.behaviors.learned.ACTION_FRAMES): heading, the target's own heading (a
    heading change); flee, the direction straight away from the robot, as eq. 11-12 write
    the reactive target's; reactive, the eq. 11-12 heading without gamma (flee plus the
    alpha dodge within r_ev, the world's target.* fields), so the action is a correction to
    the scripted rule. Recorded in the file, so the deployed evader acts as in
    training."""
    fov_rad: float = FULL_VIEW_RAD
    """The evader's field of view, rad, its full angle centred on its heading (default 2 pi:
    it sees the robot wherever it is). Narrower, the robot outside it reads as 0 and a last
    input, robot_visible, says so (dyncatch.sim.behaviors.learned.evader_features; a
    reading of the issue's "optionally only within its own field of view", no memory).
    Recorded in the file, so the deployed evader sees as in training."""
    speed_action: bool = False
    """Also pick the speed, up to the episode's cap, with a second action a in [-1, 1]: the
    share of the cap is clip(1 + a, 0, 1) (dyncatch.sim.behaviors.learned.speed_share_of; a
    reading: an untrained policy's mean, 0, runs at the cap as the scripted targets do), and
    the cap becomes an input (speed_cap_mps). Default off: the evader runs at its cap.
    Recorded in the file, so the deployed evader acts as in training."""
    reward: EvaderRewardCfg = EvaderRewardCfg()
    """The evader's reward terms (dyncatch.rl.evader.EvaderRewardCfg)."""
    ppo: PPOCfg = EVADER_PPO
    """PPO hyper-parameters and batch geometry (EVADER_PPO)."""
    world: WorldCfg = EVADER_WORLD
    """The simulated world (its target behaviour is replaced by the trainer's commanded)."""


def evader_header(cfg: EvaderTrainCfg) -> dict:
    """What an evader checkpoint records beyond its architecture."""
    return {
        "features": list(feature_names(cfg.fov_rad, cfg.speed_action)),
        "against": list(cfg.against),
        "against_weights": list(cfg.against_weights),
        "seed": cfg.seed,
        "total_steps": cfg.total_steps,
        "reward": dataclasses.asdict(cfg.reward),
        "ppo": dataclasses.asdict(cfg.ppo),
        "world": dataclasses.asdict(cfg.world),
    }


def evader_net_of(
    ts: TrainState,
    header: dict,
    turn_limit_rad: float = TURN_LIMIT_RAD,
    action_frame: str = "heading",
    fov_rad: float = FULL_VIEW_RAD,
    speed_action: bool = False,
) -> EvaderNet:
    """The actor and normaliser of a training state as a deployable ``EvaderNet`` whose
    actions span turns of +-``turn_limit_rad`` from ``action_frame`` (and the speed, with
    ``speed_action``), seeing within ``fov_rad``."""
    actor = jax.device_get(ts.params["params"]["actor"])
    n = len(actor)
    std = np.exp(np.asarray(jax.device_get(ts.params["params"]["log_std"])))
    layers = tuple(
        (np.asarray(actor[f"Dense_{i}"]["kernel"]), np.asarray(actor[f"Dense_{i}"]["bias"]))
        for i in range(n)
    )
    return EvaderNet(
        layers,
        np.asarray(ts.norm.mean),
        np.asarray(ts.norm.std),
        turn_limit_rad,
        {**header, "iteration": int(ts.iteration), "env_steps": int(ts.env_steps)},
        float(std[0]),
        action_frame,
        fov_rad,
        speed_action,
        float(std[1]) if speed_action else None,
    )


IGNORED_WORLD_PARTS = ("target", "reward")
"""What may differ between a trained pursuer's world and the evader's: the target (the
evader replaces it) and the pursuer's reward (not an input of its policy)."""


def world_mismatch(pursuer_world: WorldCfg, world: WorldCfg) -> list[str]:
    """Dotted fields, outside ``IGNORED_WORLD_PARTS``, where a pursuer's training world
    differs from the evader's (its observations would then mean something else)."""
    diff = config_diff(pursuer_world, world)
    return [k for k in diff if k.split(".")[0] not in IGNORED_WORLD_PARTS]


def load_pursuer(name: str, world: WorldCfg):
    """A pursuer of ``--against``: a baseline built for ``world``, or a trained run folder
    (its frozen mean-action policy), refused if its world differs from ``world``."""
    if name in BASELINES:
        return BASELINES[name](world)
    if not Path(name).exists():
        raise ValueError(
            f"--against {name!r}: not a baseline ({', '.join(BASELINES)}) nor a run folder "
            "of `dyncatch train`"
        )
    try:
        run = load_run(name)
    except (TreeFileError, ValueError, FileNotFoundError) as err:
        raise ValueError(f"--against {name!r}: {err}") from None
    diff = world_mismatch(run.world, world)
    if diff:
        raise ValueError(
            f"--against {name!r} was trained in another world ({', '.join(diff[:4])} differ); "
            "give the evader the same --world.* flags as that run"
        )
    return run.policy


def _validate(cfg: EvaderTrainCfg) -> None:
    if not cfg.against:
        raise ValueError(f"--against is empty: name baselines ({', '.join(BASELINES)}) or runs")
    bad = [n for n in cfg.against if n not in BASELINES and not Path(n).exists()]
    if bad:
        raise ValueError(f"--against {bad}: choose from {', '.join(BASELINES)} or give run folders")
    if cfg.against_weights and len(cfg.against_weights) != len(cfg.against):
        raise ValueError(
            f"--against-weights has {len(cfg.against_weights)} values for "
            f"{len(cfg.against)} pursuers; give one per --against or none"
        )
    if cfg.against_weights and (min(cfg.against_weights) < 0 or sum(cfg.against_weights) <= 0):
        raise ValueError("--against-weights must be non-negative with a positive sum")
    if not cfg.turn_limit_rad > 0:
        raise ValueError(f"--turn-limit-rad {cfg.turn_limit_rad}: give a positive turn, rad")
    check_fov(cfg.fov_rad, "--fov-rad")
    if cfg.total_steps < 1 or cfg.checkpoint_every < 1:
        raise ValueError("--total-steps and --checkpoint-every must be >= 1")
    if cfg.select_every < 0 or cfg.select_episodes < 1:
        raise ValueError(
            f"--select-every {cfg.select_every} / --select-episodes {cfg.select_episodes}: "
            "give --select-every >= 0 (0: keep the last iterate) and --select-episodes >= 1"
        )
    validate_ppo(cfg.ppo)
    validate_world(cfg.world.with_behavior("commanded"))
    check_out_dir(cfg.out)


@functools.partial(jax.jit, static_argnames=("skeleton", "ppo"))
def evader_init(weights: tuple, key: jax.Array, skeleton: Skeleton, ppo: PPOCfg) -> TrainState:
    """``make_train``'s ``init`` over the ``EvaderEnv`` of ``split_arrays``'s ``(weights,
    skeleton)``."""
    init, _, _ = make_train(skeleton.fill(weights), ppo)
    return init(key)


@functools.partial(jax.jit, static_argnames=("skeleton", "ppo"))
def evader_iterate(weights: tuple, ts: TrainState, skeleton: Skeleton, ppo: PPOCfg):
    """``make_train``'s ``iterate`` over the ``EvaderEnv`` of ``split_arrays``'s ``(weights,
    skeleton)``: the pursuers' weights are arguments, so the exploit evaders of a self-play
    round (one pursuer each, of one structure) compile once (about 3 CPU s each in the
    tests' two-round study)."""
    _, iterate, _ = make_train(skeleton.fill(weights), ppo)
    return iterate(ts)


SELECTION_FILE = "selection.json"
"""--select-every's record in the run folder: each candidate's iteration and held-out escape
rate, and the one kept (``selected_iteration``, ``selected_escape``)."""
LAST_CHECKPOINT = "evader_last.safetensors"
"""With --select-every, the last iterate beside the kept one (evader.safetensors), so the two
can be compared on the same seed."""
SELECT_STREAM = 0x5E1EC7
"""The held-out selection episodes' keys are the training seed folded with this."""
TRAIN_STATE = "train_state.safetensors"
"""The whole PPO state (actor, critic, optimiser, normaliser, environments, key) at the
last checkpoint, with ``resume_header``: what --resume continues. evader.safetensors is
the deployable actor alone."""
NOT_RESUME_FIELDS = ("out", "resume", "checkpoint_every", "total_steps")
"""Fields of ``EvaderTrainCfg`` a resumed run may change: where it lives, how often it
saves, and how long it trains (a finished run can be extended)."""


def resume_header(cfg: EvaderTrainCfg) -> dict:
    """What the training state records, and a resumed run must agree on: the config less
    ``NOT_RESUME_FIELDS``."""
    return {k: v for k, v in to_json(cfg).items() if k not in NOT_RESUME_FIELDS}


def load_train_state(cfg: EvaderTrainCfg, template) -> TrainState:
    """The training state in ``cfg.out``, refused (naming the fields, as flags) if it was
    trained with other settings; ``template`` is an (abstract) state of this config."""
    path = cfg.out / TRAIN_STATE
    if not path.exists():
        raise ValueError(
            f"--resume: {path} is missing (an evader run written before it was kept, or "
            "interrupted before its first checkpoint): train it again without --resume in a "
            "new --out"
        )
    try:
        ts, saved = load_tree(path, template)
    except TreeFileError as err:
        raise ValueError(f"--resume: {err}; resume with the same flags") from None
    msg = diff_message(
        saved, resume_header(cfg), str(path), "resume with the same flags or choose another --out"
    )
    if msg:
        raise ValueError(msg)
    return ts


def resumable(cfg: EvaderTrainCfg) -> EvaderTrainCfg:
    """``cfg`` set to continue the interrupted run in its folder when that run's training
    state matches it, else with the folder cleared: for a cached pipeline's own folders
    (the self-play rounds' evader stages), never a user's ``--out``."""
    path = cfg.out / TRAIN_STATE
    if path.exists():
        try:
            if read_header(path) == json.loads(json.dumps(resume_header(cfg))):
                return dataclasses.replace(cfg, resume=True)
        except TreeFileError:
            pass
    if cfg.out.exists():
        shutil.rmtree(cfg.out)
    return dataclasses.replace(cfg, resume=False)


def _resumed_selection(cfg: EvaderTrainCfg, start: int) -> dict:
    """--select-every's record as it stood at iteration ``start``: the candidates after it
    (scored after the state was saved) are dropped and played again."""
    selection: dict = {"episodes": cfg.select_episodes, "iterations": [], "escape": []}
    path = cfg.out / SELECTION_FILE
    if not (cfg.resume and path.exists()):
        return selection
    had = read_json(path, "delete it and resume")
    for it, escape in zip(had.get("iterations", []), had.get("escape", []), strict=True):
        if it <= start:
            if not selection["escape"] or escape > max(selection["escape"]):
                selection.update(selected_iteration=it, selected_escape=escape)
            selection["iterations"].append(it)
            selection["escape"].append(escape)
    return selection


def held_out_escape(ts: TrainState, net: ActorCritic, env, key: jax.Array, episodes: int) -> float:
    """The escape rate of the training state's deterministic evader (the mean action, as the
    ``learned`` behaviour deploys it; ``net`` is ``make_train``'s) over ``episodes`` fresh
    episodes of ``env`` from ``key``. The policy is a pytree, so every candidate of a run
    shares one compiled evaluation."""
    policy = LearnedPolicy(net, ts.params, ts.norm, as_stepper(flat_obs), env)
    return float(np.mean(np.asarray(run_episodes(policy, key, env, episodes)["success"])))


def train_evader(cfg: EvaderTrainCfg, progress: Progress | None = None) -> dict[str, float]:
    """Train to ``total_steps`` (from the saved state with ``resume``) and write
    ``out/evader.safetensors``; returns the last iteration's metrics (``success_rate`` is the
    evader's: episodes it ran out uncaught)."""
    _validate(cfg)
    path = cfg.out / EVADER_CHECKPOINT
    if not cfg.resume and (path.exists() or (cfg.out / TRAIN_STATE).exists()):
        raise ValueError(f"{path} exists: pass --resume to continue it or choose another --out")
    pursuers = [load_pursuer(name, cfg.world) for name in cfg.against]
    env = evader_env(
        cfg.world,
        pursuers,
        cfg.reward,
        cfg.against_weights,
        cfg.turn_limit_rad,
        cfg.action_frame,
        cfg.fov_rad,
        cfg.speed_action,
    )
    weights, skeleton = split_arrays(env)
    key = jax.random.key(cfg.seed)
    if cfg.resume:
        template = jax.eval_shape(lambda k: evader_init(weights, k, skeleton, cfg.ppo), key)
        ts = load_train_state(cfg, template)
    else:
        ts = evader_init(weights, key, skeleton, cfg.ppo)
    start = int(ts.iteration)
    header, state_header = evader_header(cfg), resume_header(cfg)
    total_iters = -(-cfg.total_steps // cfg.ppo.batch_size)
    update = (progress or NoProgress()).task(
        f"evader vs {'+'.join(cfg.against)}", total_iters, start
    )
    update(start, "compiling")
    cfg.out.mkdir(parents=True, exist_ok=True)
    log = MetricLog(cfg.out, start, ("csv",), header)
    # A run resumed at its end trains nothing: its final metrics are the last logged.
    metrics: dict[str, float] = log.last_row() if start >= total_iters else {}
    select_key = jax.random.fold_in(key, SELECT_STREAM)
    select_env = skeleton.fill(weights)
    select_net = make_train(select_env, cfg.ppo)[2]
    selection = _resumed_selection(cfg, start)
    clock0 = time.perf_counter() - log.last("time_s")  # continued across resumes
    saved = start if cfg.resume else None  # the iteration of the training state on disk

    def save(to=path):
        net = evader_net_of(
            ts, header, cfg.turn_limit_rad, cfg.action_frame, cfg.fov_rad, cfg.speed_action
        )
        save_evader(to, net)

    try:
        for it in range(start, total_iters):
            ts, m = evader_iterate(weights, ts, skeleton, cfg.ppo)
            metrics = {k: float(v) for k, v in jax.device_get(m).items()}
            check_finite(ts.params, ts.norm, metrics, it + 1, cfg.out / TRAIN_STATE, saved)
            last = it + 1 == total_iters
            if cfg.select_every:  # a column of its own, empty between candidates
                metrics["held_out_escape"] = math.nan
            selected = cfg.select_every and ((it + 1) % cfg.select_every == 0 or last)
            if selected:
                escape = held_out_escape(
                    ts, select_net, select_env, select_key, cfg.select_episodes
                )
                metrics["held_out_escape"] = escape
                if not selection["escape"] or escape > max(selection["escape"]):
                    selection.update(selected_iteration=it + 1, selected_escape=escape)
                    save()
                selection["iterations"].append(it + 1)
                selection["escape"].append(escape)
                write_json(cfg.out / SELECTION_FILE, selection)
                if last:
                    save(cfg.out / LAST_CHECKPOINT)
            metrics["time_s"] = time.perf_counter() - clock0
            log.write(it + 1, int(ts.env_steps), metrics)
            update(it + 1, f"escaped {metrics['success_rate']:.2f}")
            checkpoint = (it + 1) % cfg.checkpoint_every == 0 or last
            if checkpoint and not cfg.select_every:
                save()
            # The state after the files it goes with: a resume never skips a saved candidate.
            if checkpoint or selected:
                save_tree(cfg.out / TRAIN_STATE, ts, state_header)
                saved = it + 1
    finally:
        log.close()
    return metrics
