"""The training runner: one PPO run of one method, with checkpoints, resume, periodic
evaluation and logs (rsl_rl's ``OnPolicyRunner`` is the model).

``TrainRunner(cfg).learn(progress)`` is the loop ``iterate -> log -> evaluate -> save``
around the pure, jitted ``make_train``. Everything that touches files lives here; the CLI
(``dyncatch train``) and the reproduction pipeline both call it and only attach a progress
display. The state lives on every local device (``dyncatch.rl.sharding``): the environment
batch and the PPO minibatches are split over them. ``dyncatch.rl.seeds.SeedGroupRunner``
trains several seeds of one config as one ``vmap``-ped computation; ``rl.seeds.make_runner``
picks.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import jax
from jax.sharding import Mesh

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.evaluation.grid import EVAL_STREAM
from dyncatch.predictor.checkpoint import load_any
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.guard import check_finite
from dyncatch.rl.logging import LoggerName, MetricLog, validate_loggers
from dyncatch.rl.methods import GROUND_TRUTH_READING, GroundTruthReading, MethodName, get_method
from dyncatch.rl.policy import CHECKPOINT, TRAIN_FORMAT, learner
from dyncatch.rl.sharding import batch_mesh, state_shardings, validate_mesh
from dyncatch.rl.train import TrainState
from dyncatch.sim.api import Environment, JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_speeds, validate_world
from dyncatch.utils.files import check_out_dir
from dyncatch.utils.progress import NoProgress, Progress
from dyncatch.utils.tree_io import load_tree, save_tree


@dataclasses.dataclass(frozen=True)
class TrainRunCfg:
    """Train a catching policy with PPO."""

    method: MethodName = "sp_rl"
    """A trained method of dyncatch.rl.methods.METHODS (sp_fp is gt_rl evaluated with the
    predictor)."""
    total_steps: int = 2_000_000
    """Environment steps to train for (rounded up to whole iterations)."""
    seed: int = 0
    """Training seed (the first one with --seeds)."""
    seeds: int = 1
    """Seeds to train together as one vmap-ped computation: seed, seed + 1, ...; with more
    than one, each seed's run goes to OUT/seed{s}/ (the same files as a one-seed run, which
    it equals to float tolerance)."""
    out: Path = Path("runs/train")
    """Run folder: checkpoint.safetensors and the loggers' files (metrics.csv, tb/, wandb/)."""
    predictor: Path | None = None
    """Predictor checkpoint (from dyncatch predictor train) for p_rl and sp_rl, or the
    tracker's (dyncatch predictor train --kind tracker) for st_rl."""
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
    logger: tuple[LoggerName, ...] = ("csv", "tensorboard")
    """Where the per-iteration metrics go, one or more of dyncatch.rl.logging.LOGGERS: csv
    (metrics.csv, which dyncatch plot reads and a resumed run continues its wall clock
    from), tensorboard (tb/), wandb (wandb/, offline unless WANDB_MODE is set)."""
    ground_truth: GroundTruthReading = GROUND_TRUTH_READING
    """How gt_rl reads the target's true velocity (dyncatch.rl.methods.GroundTruthReading):
    when_predicted (default), where the predictor would give one (the last two camera frames
    saw the target), else 0 with its flag at 0, as the predictor; always, at every step with
    the flag at 1 (the reading before issue 31). Recorded in the checkpoint, which is
    evaluated with it; other methods ignore it."""
    ppo: PPOCfg = PPOCfg()
    """PPO hyper-parameters and batch geometry."""
    world: WorldCfg = WorldCfg()
    """The simulated world (the library's default is the training default)."""


def header_of(cfg: TrainRunCfg) -> dict:
    """What a checkpoint records, and must agree on to be resumed."""
    return {
        "format": TRAIN_FORMAT,
        "method": cfg.method,
        # The world's behaviour again, for readers of the file (and older runs' headers).
        "behavior": cfg.world.target.behavior,
        "seed": cfg.seed,
        "predictor": str(cfg.predictor) if cfg.predictor else None,
        "ground_truth": cfg.ground_truth,
        "ppo": dataclasses.asdict(cfg.ppo),
        "world": dataclasses.asdict(cfg.world),
    }


def eval_due(cfg: TrainRunCfg, it: int, start: int, total_iters: int) -> bool:
    """Whether iteration ``it`` (0-based) ends with an evaluation: every ``eval_every``,
    the first of this invocation and the last."""
    return bool(cfg.eval_every) and (
        (it + 1) % cfg.eval_every == 0 or it == start or it + 1 == total_iters
    )


def seed_cfgs(cfg: TrainRunCfg) -> list[TrainRunCfg]:
    """The one-seed runs ``cfg`` stands for: itself, or with ``--seeds S`` one per seed,
    each in ``out/seed{s}``."""
    if cfg.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {cfg.seeds}")
    if cfg.seeds == 1:
        return [cfg]
    return [
        dataclasses.replace(cfg, seed=s, seeds=1, out=cfg.out / f"seed{s}")
        for s in range(cfg.seed, cfg.seed + cfg.seeds)
    ]


def _validate(cfg: TrainRunCfg) -> None:
    if cfg.seeds != 1:
        raise ValueError(
            f"one TrainRunner trains one seed (got --seeds {cfg.seeds}); "
            "use make_runner or SeedGroupRunner"
        )
    if cfg.total_steps < 1 or cfg.checkpoint_every < 1:
        raise ValueError("--total-steps and --checkpoint-every must be >= 1")
    if cfg.eval_every < 0 or cfg.eval_episodes < 1:
        raise ValueError("--eval-every must be >= 0 and --eval-episodes >= 1")
    validate_speeds((cfg.eval_speed_mps,), "--eval-speed-mps")
    validate_loggers(cfg.logger)
    method = get_method(cfg.method)
    if not method.trained:
        raise ValueError(
            f"method {cfg.method!r} is not trained: train {method.trained_as!r} "
            f"and evaluate it as {cfg.method!r}"
        )
    if method.predictor_kind is not None and cfg.predictor is None:
        raise ValueError(f"method {cfg.method!r} needs --predictor PATH")


class TrainRunner:
    """One training run: build it from a config, then ``learn``.

    ``env`` is the backend to train in (default the JAX world); the config's world is set
    on it, so a second backend trains with no other change. ``mesh`` is the devices the
    batch is split over (default every local device, ``dyncatch.rl.sharding``).
    """

    def __init__(self, cfg: TrainRunCfg, env: Environment | None = None, mesh: Mesh | None = None):

        _validate(cfg)
        check_out_dir(cfg.out)
        self.cfg = cfg
        self.ppo = validate_ppo(cfg.ppo)
        world = validate_world(cfg.world)
        self.env = (env if env is not None else JaxCatchEnv()).with_world(world)
        predictor = params = None
        if get_method(cfg.method).predictor_kind is not None:
            predictor, params = load_any(cfg.predictor, world)
        self.obs_fn = get_method(cfg.method).obs_fn(
            predictor, params, ground_truth=cfg.ground_truth
        )
        self.mesh = mesh if mesh is not None else batch_mesh()
        validate_mesh(self.ppo, self.mesh.size)
        self.learner = learner(cfg.method)
        init, iterate, self.net = self.learner.make_train(
            self.env, self.ppo, self.obs_fn, self.mesh
        )
        self.shardings = state_shardings(jax.eval_shape(init, jax.random.key(0)), self.mesh)
        whole = jax.sharding.NamedSharding(self.mesh, jax.sharding.PartitionSpec())
        self._init = jax.jit(init, out_shardings=self.shardings)
        self._iterate = jax.jit(iterate, out_shardings=(self.shardings, whole))
        self.header = header_of(cfg)
        self.checkpoint = cfg.out / CHECKPOINT

    def save(self, ts: TrainState) -> Path:
        """Write the checkpoint atomically, with the run's header."""

        return save_tree(self.checkpoint, ts, self.header)

    def load(self) -> TrainState:
        """The checkpoint in ``out``; refused if it was trained with other settings."""

        template = jax.eval_shape(self._init, jax.random.key(self.cfg.seed))
        ts, saved = load_tree(self.checkpoint, template)
        want = json.loads(json.dumps(self.header))
        diff = [k for k in want if saved.get(k) != want[k]]
        if diff:
            raise ValueError(
                f"{self.checkpoint} was trained with other {', '.join(diff)}; "
                "resume with the same flags or choose another --out"
            )
        return jax.device_put(ts, self.shardings)

    def initial_state(self) -> TrainState:
        """A fresh state, or the checkpoint's when resuming; never overwrites a run."""
        if self.cfg.resume:
            return self.load()
        if self.checkpoint.exists():
            raise ValueError(
                f"{self.checkpoint} exists: pass --resume to continue it or choose another --out"
            )
        return self._init(jax.random.key(self.cfg.seed))

    def evaluate(self, ts: TrainState) -> dict[str, float]:
        """Unbiased success and catch time of the mean-action policy at ``eval_speed_mps``,
        on evaluation seeds disjoint from training (the same seeds at every call)."""

        policy = self.learner.policy(self.net, ts.params, ts.norm, self.obs_fn, self.env)
        key = jax.random.fold_in(jax.random.key(self.cfg.seed), EVAL_STREAM)
        env = self.env.with_world(self.env.world.with_speed(self.cfg.eval_speed_mps))
        out = jax.device_get(run_episodes(policy, key, env, self.cfg.eval_episodes))
        return {
            "eval/success_rate": float(out["success"].mean()),
            "eval/catch_time_s": float(out["catch_time_s"].mean()),
        }

    def learn(self, progress: Progress | None = None) -> dict[str, float]:
        """Train to ``total_steps``; returns the last iteration's metrics."""
        cfg = self.cfg
        ts = self.initial_state()
        cfg.out.mkdir(parents=True, exist_ok=True)
        start = int(ts.iteration)
        log = MetricLog(cfg.out, start, cfg.logger, self.header)
        try:
            return self._loop(ts, start, log, progress)
        finally:
            log.close()

    def _loop(self, ts: TrainState, start: int, log: MetricLog, progress: Progress | None):
        cfg, ppo = self.cfg, self.ppo
        total_iters = -(-cfg.total_steps // ppo.batch_size)
        update = (progress or NoProgress()).task(
            f"{cfg.method} vs {cfg.world.target.behavior}", total_iters, start
        )
        update(start, "compiling")
        # A run resumed at its end trains nothing: its final metrics are the last logged.
        metrics: dict[str, float] = log.last_row() if start >= total_iters else {}
        # Wall-clock seconds of training (compilation included, evaluations excluded),
        # continued across resumes.
        clock0 = time.perf_counter() - log.last("time_s")
        t0 = None  # the rate's clock starts after the first (compiling) iteration
        saved = start if cfg.resume else None  # the iteration of the checkpoint on disk
        for it in range(start, total_iters):
            ts, m = self._iterate(ts)
            metrics = {k: float(v) for k, v in jax.device_get(m).items()}
            check_finite(ts.params, ts.norm, metrics, it + 1, self.checkpoint, saved)
            metrics["time_s"] = time.perf_counter() - clock0
            if eval_due(cfg, it, start, total_iters):
                t_eval = time.perf_counter()
                metrics.update(self.evaluate(ts))
                clock0 += time.perf_counter() - t_eval
            else:
                metrics.update({"eval/success_rate": "", "eval/catch_time_s": ""})
            log.write(it + 1, int(ts.env_steps), metrics)
            if t0 is None:
                t0, done0 = time.perf_counter(), it + 1
            elapsed = time.perf_counter() - t0
            rate = (it + 1 - done0) * ppo.batch_size / elapsed if elapsed > 0 else 0.0
            update(it + 1, f"{rate:,.0f} samples/s  success {metrics['success_rate']:.2f}")
            if (it + 1) % cfg.checkpoint_every == 0 or it + 1 == total_iters:
                self.save(ts)
                saved = it + 1
        return metrics
