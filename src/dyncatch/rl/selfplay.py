"""Self-play rounds: alternate best responses between a learned evader and the pursuers.

Round k (0-based):

1. ``evader``: an evader trained (``rl.evader_train``) against the frozen pursuers of round
   k-1, every method and seed drawn with equal weight (round 0: ``first_pursuers``).
2. ``pursuer/{method}``: each method's seeds trained (``rl.seeds``, one ``vmap``-ped group)
   in the ``league`` world: each episode a member of evaders 0..k plus the scripted
   ``league_behaviors`` (``sim.behaviors.league``), so a pursuer does not overfit the last
   evader.
3. ``exploit/{method}/seed{s}``: a fresh best-response evader trained against that one
   pursuer (skipped with ``exploit_steps`` 0), and ``eval/{method}/seed{s}``: the pursuer's
   success against the round's league and against its best response
   (``rl.exploitability``).

Layout under ``out``: ``selfplay.json`` (the config; another is refused, naming the field),
``round{k}/{evader,pursuer/{method},exploit/{method}/seed{s},eval/{method}/seed{s}}/``
(each finished by ``done.json``, ``rl.stages``) and ``summary.json`` / ``summary.md``.
Adding rounds to a finished study (a larger ``--rounds``) reuses every finished stage.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from dyncatch.evaluation.intervals import CONFIDENCE
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.evader import EvaderRewardCfg
from dyncatch.rl.evader_train import EVADER_PPO, EVADER_WORLD, EvaderTrainCfg, train_evader
from dyncatch.rl.exploitability import evaluate_pursuer, summary_rows, write_summary
from dyncatch.rl.methods import MethodName, get_method
from dyncatch.rl.runner import TrainRunCfg, seed_cfgs
from dyncatch.rl.seeds import make_runner
from dyncatch.rl.stages import Stage, diff_message, run_stage
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world
from dyncatch.utils.config_io import to_json
from dyncatch.utils.files import check_out_dir, read_json, write_json
from dyncatch.utils.progress import NoProgress, Progress

PURSUER_LOGGERS = ("csv",)
"""The pursuer runs log metrics.csv only (no TensorBoard files per stage)."""


@dataclasses.dataclass(frozen=True)
class SelfPlayCfg:
    """Self-play rounds: evaders and pursuers trained against each other's frozen past."""

    out: Path = Path("runs/selfplay")
    """Study folder: selfplay.json, round{k}/..., summary.json and summary.md. Re-running
    with the same flags skips every finished stage; more --rounds extends the study."""
    rounds: int = 3
    """Rounds to run (0..rounds-1)."""
    methods: tuple[MethodName, ...] = ("rl",)
    """The pursuer methods trained each round (dyncatch.rl.methods.METHODS, trained ones)."""
    seeds: int = 2
    """Pursuer seeds per method and round (seed, seed + 1, ...), one vmap-ped group."""
    seed: int = 0
    """First pursuer seed; round k's evader trains with seed + k, pursuer seed s's
    best-response evader with s."""
    first_pursuers: tuple[str, ...] = ("pursuit",)
    """Round 0's frozen opponents: baselines (pursuit, intercept) or `dyncatch train` run
    folders trained in --world."""
    predictor: Path | None = None
    """The predictor checkpoint of p_rl / sp_rl (dyncatch predictor train), used every round."""
    evader_steps: int = 2_000_000
    """Environment steps of each round's evader."""
    pursuer_steps: int = 5_000_000
    """Environment steps of each round's pursuers (per seed)."""
    exploit_steps: int = 2_000_000
    """Environment steps of each best-response evader (0: no exploitability stage)."""
    league_behaviors: tuple[str, ...] = ("reactive",)
    """The scripted members of every round's league (target.league_behaviors)."""
    league_scripted_share: float = 0.5
    """The share of the league's episodes that play a scripted member; the rest is split
    evenly among evaders 0..k (target.league_scripted_share)."""
    eval_speeds_mps: tuple[float, ...] = (1.4, 1.6, 1.8)
    """Fixed target speeds of the exploitability evaluation (success is averaged over them)."""
    eval_episodes: int = 200
    """Evaluation episodes per speed, per pursuer and opponent."""
    eval_seed: int = 0
    """Seed of the evaluation episodes (the same episodes for every pursuer)."""
    pursuer_eval_every: int = 0
    """Iterations between the pursuer runs' own evaluations (0: none, the exploit stage
    evaluates them)."""
    reward: EvaderRewardCfg = EvaderRewardCfg()
    """Every evader's reward (dyncatch.rl.evader.EvaderRewardCfg)."""
    evader_ppo: PPOCfg = EVADER_PPO
    """PPO of the evaders (round and best-response ones)."""
    pursuer_ppo: PPOCfg = PPOCfg()
    """PPO of the pursuers."""
    world: WorldCfg = EVADER_WORLD
    """The world of both sides (its behaviour is set per stage: commanded for evaders, league
    for pursuers); training caps drawn in [1.4, 1.8] m/s by default."""


RESUMABLE_FIELDS = ("out", "rounds")
"""Fields that may change between invocations of one study (a larger --rounds extends it)."""


def validate_selfplay(cfg: SelfPlayCfg) -> None:
    """ValueError naming the flag and the fix, before any work."""
    check_out_dir(cfg.out)
    if cfg.rounds < 1:
        raise ValueError(f"--rounds {cfg.rounds}: run at least 1 round")
    if cfg.seeds < 1:
        raise ValueError(f"--seeds {cfg.seeds}: train at least 1 pursuer seed")
    if not cfg.methods or len(set(cfg.methods)) != len(cfg.methods):
        raise ValueError(f"--methods {list(cfg.methods)}: name each trained method once")
    for name in cfg.methods:
        m = get_method(name)
        if not m.trained:
            raise ValueError(
                f"--methods {name!r} is not trained (it reuses {m.trained_as!r}); "
                f"list {m.trained_as!r} instead"
            )
        if m.predictor_kind is not None and cfg.predictor is None:
            raise ValueError(
                f"--methods {name!r} needs --predictor PATH (a {m.predictor_kind!r} "
                "checkpoint from dyncatch predictor train)"
            )
    for flag, steps in (
        ("--evader-steps", cfg.evader_steps),
        ("--pursuer-steps", cfg.pursuer_steps),
    ):
        if steps < 1:
            raise ValueError(f"{flag} {steps}: train at least 1 step")
    if cfg.exploit_steps < 0:
        raise ValueError(f"--exploit-steps {cfg.exploit_steps}: use 0 (off) or more")
    if cfg.eval_episodes < 1 or not cfg.eval_speeds_mps:
        raise ValueError("--eval-episodes must be >= 1 and --eval-speeds-mps non-empty")
    if cfg.pursuer_eval_every < 0:
        raise ValueError("--pursuer-eval-every must be >= 0 (0: no evaluation in training)")
    validate_ppo(cfg.evader_ppo)
    validate_ppo(cfg.pursuer_ppo)
    league = league_world(cfg, ())
    validate_world(league)  # names --world.target.league-* on bad members or weights


def league_world(cfg: SelfPlayCfg, evaders: tuple[str, ...]) -> WorldCfg:
    """The pursuers' world: ``league`` of the scripted behaviours and ``evaders``."""
    w = cfg.world.with_behavior("league")
    return w.replace(
        target=w.target.replace(
            league_behaviors=tuple(cfg.league_behaviors),
            league_evaders=tuple(evaders),
            league_scripted_share=cfg.league_scripted_share,
            league_weights=(),
        )
    )


def study_spec(cfg: SelfPlayCfg) -> dict:
    """What the study's stages share: the config less ``RESUMABLE_FIELDS``."""
    d = to_json(cfg)
    return {k: v for k, v in d.items() if k not in RESUMABLE_FIELDS}


def check_study(cfg: SelfPlayCfg) -> None:
    """Record the config in ``out/selfplay.json``; refuse a folder made with another."""
    path = cfg.out / "selfplay.json"
    want = study_spec(cfg)
    if path.exists():
        msg = diff_message(
            read_json(path, "delete it, or choose another --out"),
            want,
            str(cfg.out),
            "re-run with the same flags to resume, or choose another --out",
        )
        if msg:
            raise ValueError(msg)
    else:
        write_json(path, want)


def evader_path(out: Path, k: int) -> Path:
    return out / f"round{k}" / "evader"


def pursuer_runs(cfg: SelfPlayCfg, k: int, method: str) -> list[TrainRunCfg]:
    """The one-seed runs of ``method`` in round ``k`` (their ``out`` are the run folders)."""
    return seed_cfgs(pursuer_cfg(cfg, k, method))


def pursuer_cfg(cfg: SelfPlayCfg, k: int, method: str) -> TrainRunCfg:
    evaders = tuple(str(evader_path(cfg.out, j) / EVADER_CHECKPOINT) for j in range(k + 1))
    m = get_method(method)
    return TrainRunCfg(
        method=method,
        total_steps=cfg.pursuer_steps,
        seed=cfg.seed,
        seeds=cfg.seeds,
        out=cfg.out / f"round{k}" / "pursuer" / method,
        predictor=cfg.predictor if m.predictor_kind is not None else None,
        eval_every=cfg.pursuer_eval_every,
        logger=PURSUER_LOGGERS,
        ppo=cfg.pursuer_ppo,
        world=league_world(cfg, evaders),
    )


def evader_cfg(cfg: SelfPlayCfg, k: int) -> EvaderTrainCfg:
    if k == 0:
        against = tuple(cfg.first_pursuers)
    else:
        against = tuple(str(run.out) for m in cfg.methods for run in pursuer_runs(cfg, k - 1, m))
    return EvaderTrainCfg(
        against=against,
        total_steps=cfg.evader_steps,
        seed=cfg.seed + k,
        out=evader_path(cfg.out, k),
        reward=cfg.reward,
        ppo=cfg.evader_ppo,
        world=cfg.world,
    )


def exploit_cfg(cfg: SelfPlayCfg, run: TrainRunCfg, k: int) -> EvaderTrainCfg:
    """The best-response evader of one pursuer run."""
    return dataclasses.replace(
        evader_cfg(cfg, 0),
        against=(str(run.out),),
        total_steps=cfg.exploit_steps,
        seed=run.seed,
        out=cfg.out / f"round{k}" / "exploit" / run.method / f"seed{run.seed}",
    )


class SelfPlayRunner:
    """``SelfPlayRunner(cfg).learn(progress)`` runs (or resumes) every round and writes the
    summary; each stage is a ``rl.stages.Stage``."""

    def __init__(self, cfg: SelfPlayCfg):
        validate_selfplay(cfg)
        self.cfg = cfg

    def round_stages(self, k: int) -> list[Stage]:
        """Round ``k``'s stages in the order they run."""
        cfg = self.cfg
        ev = evader_cfg(cfg, k)
        stages = [Stage(f"round{k}/evader", ev.out, to_json(ev), lambda p: train_evader(ev, p))]
        for method in cfg.methods:
            pc = pursuer_cfg(cfg, k, method)
            stages.append(Stage(f"round{k}/pursuer/{method}", pc.out, to_json(pc), _trainer(pc)))
        if cfg.exploit_steps == 0:
            return stages
        league = pursuer_cfg(cfg, k, cfg.methods[0]).world
        for method in cfg.methods:
            for run in pursuer_runs(cfg, k, method):
                stages += self.exploit_stages(k, run, league)
        return stages

    def exploit_stages(self, k: int, run: TrainRunCfg, league: WorldCfg) -> list[Stage]:
        """One pursuer run's best-response evader and its evaluation against the league
        and that evader."""
        cfg = self.cfg
        br = exploit_cfg(cfg, run, k)
        name = f"{run.method}/seed{run.seed}"
        spec = {
            "run": str(run.out),
            "best_response": str(br.out),
            "league": to_json(league),
            "speeds_mps": list(cfg.eval_speeds_mps),
            "episodes": cfg.eval_episodes,
            "eval_seed": cfg.eval_seed,
        }

        def evaluate(progress: Progress | None) -> dict:
            del progress
            return evaluate_pursuer(
                run.out, league, br.out, cfg.eval_speeds_mps, cfg.eval_episodes, cfg.eval_seed
            )

        return [
            Stage(f"round{k}/exploit/{name}", br.out, to_json(br), lambda p: train_evader(br, p)),
            Stage(f"round{k}/eval/{name}", cfg.out / f"round{k}" / "eval" / name, spec, evaluate),
        ]

    def learn(self, progress: Progress | None = None) -> list[dict]:
        """Every round's stages (finished ones skipped); returns the summary rows."""
        cfg = self.cfg
        check_study(cfg)
        bar = progress or NoProgress()
        records: list[tuple[int, Stage, dict]] = []
        for k in range(cfg.rounds):
            for stage in self.round_stages(k):
                bar.task(stage.name, 1)(0, "running")
                done = run_stage(stage, progress)
                bar.task(stage.name, 1)(1, "skipped (done)" if done["skipped"] else "done")
                records.append((k, stage, done))
        rows = summary_rows(records, cfg.methods, CONFIDENCE)
        write_summary(cfg.out, rows)
        return rows


def _trainer(pc: TrainRunCfg):
    def make(progress: Progress | None = None) -> dict:
        out = make_runner(pc).learn(progress)
        per_seed = [out] if isinstance(out, dict) else out
        return {"success_rate": [float(m.get("success_rate", float("nan"))) for m in per_seed]}

    return make
