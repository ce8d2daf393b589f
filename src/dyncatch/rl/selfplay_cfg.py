"""The self-play study's configuration (``dyncatch evader selfplay``'s flags), its checks
and the league world the pursuers train in (``rl.selfplay`` runs it)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

from dyncatch.policies.registry import BASELINES
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.evader import EvaderRewardCfg
from dyncatch.rl.evader_train import EVADER_PPO, EVADER_WORLD
from dyncatch.rl.methods import METHODS, MethodName, get_method
from dyncatch.sim.behaviors.evader_net import FULL_VIEW_RAD
from dyncatch.sim.behaviors.learned import check_fov
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world
from dyncatch.utils.files import check_out_dir

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
    """The predictor checkpoint of p_rl / sp_rl (dyncatch predictor train), used every round
    (or --predictor-steps: one trained each round)."""
    predictor_steps: int = 0
    """0 (default): p_rl and sp_rl read --predictor in every round. N > 0: each round first
    trains the predictor of each kind its methods read (vanilla for p_rl, self_aware for
    sp_rl; dyncatch predictor train, N interaction steps, seed --seed + k) on the round's
    league (evaders 0..k and --league-behaviors), and that round's pursuers read it. A
    reading for issue 34: a predictor models only the targets it was trained on
    (docs/evaders.md, "A predictor of one evader scored on another")."""
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
    cross_eval: bool = True
    """Evaluate every trained pursuer against every round's evader and each scripted
    league member alone, at --eval-speeds-mps (rl.cross_eval; the summary's cross table)."""
    compare: tuple[MethodName, MethodName] = ("sp_rl", "rl")
    """The two methods whose difference (first - second) the summary gives against each
    opponent of the cross-evaluation, with Welch's interval over seeds, where both are in
    --methods (the summary only: it may change between runs of one study)."""
    pursuer_eval_every: int = 0
    """Iterations between the pursuer runs' own evaluations (0: none, the exploit stage
    evaluates them)."""
    evader_speed_action: bool = False
    """Every evader (round and best-response ones) also picks its speed up to the cap
    (dyncatch evader train --speed-action); default off: they run at the cap."""
    evader_fov_rad: float = FULL_VIEW_RAD
    """Every evader's field of view, rad (dyncatch evader train --fov-rad); default 2 pi:
    it sees the robot wherever it is."""
    evader_select_every: int = 0
    """Every evader (round and best-response ones) keeps its best held-out iterate, scored
    every this many iterations (dyncatch evader train --select-every); default 0: the last
    iterate."""
    evader_select_episodes: int = 128
    """Held-out episodes per candidate of --evader-select-every (dyncatch evader train
    --select-episodes)."""
    reward: EvaderRewardCfg = EvaderRewardCfg()
    """Every evader's reward (dyncatch.rl.evader.EvaderRewardCfg)."""
    evader_ppo: PPOCfg = EVADER_PPO
    """PPO of the evaders (round and best-response ones)."""
    pursuer_ppo: PPOCfg = PPOCfg()
    """PPO of the pursuers."""
    world: WorldCfg = EVADER_WORLD
    """The world of both sides (its behaviour is set per stage: commanded for evaders, league
    for pursuers); training caps drawn in [1.4, 1.8] m/s by default."""


RESUMABLE_FIELDS = ("out", "rounds", "compare")
"""Fields that may change between invocations of one study (a larger --rounds extends it;
--compare shapes only the summary)."""


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
        if m.predictor_kind is not None and cfg.predictor is None and not cfg.predictor_steps:
            raise ValueError(
                f"--methods {name!r} needs --predictor PATH (a {m.predictor_kind!r} "
                "checkpoint from dyncatch predictor train) or --predictor-steps N (one "
                "trained on each round's league)"
            )
    if cfg.predictor_steps < 0:
        raise ValueError(f"--predictor-steps {cfg.predictor_steps}: use 0 (--predictor) or more")
    if cfg.predictor_steps and cfg.predictor is not None:
        raise ValueError(
            "--predictor and --predictor-steps both given: the rounds read one or train their "
            "own; give one of them"
        )
    for flag, steps in (
        ("--evader-steps", cfg.evader_steps),
        ("--pursuer-steps", cfg.pursuer_steps),
    ):
        if steps < 1:
            raise ValueError(f"{flag} {steps}: train at least 1 step")
    unknown = [p for p in cfg.first_pursuers if p not in BASELINES and not Path(p).exists()]
    if unknown or not cfg.first_pursuers:
        raise ValueError(
            f"--first-pursuers {unknown or '()'}: name baselines ({', '.join(BASELINES)}) "
            "or run folders of `dyncatch train`"
        )
    if cfg.exploit_steps < 0:
        raise ValueError(f"--exploit-steps {cfg.exploit_steps}: use 0 (off) or more")
    if cfg.eval_episodes < 1 or not cfg.eval_speeds_mps:
        raise ValueError("--eval-episodes must be >= 1 and --eval-speeds-mps non-empty")
    unknown = [name for name in cfg.compare if name not in METHODS]
    if unknown or cfg.compare[0] == cfg.compare[1]:
        raise ValueError(
            f"--compare {' '.join(cfg.compare)}: name two different methods of {', '.join(METHODS)}"
        )
    if cfg.pursuer_eval_every < 0:
        raise ValueError("--pursuer-eval-every must be >= 0 (0: no evaluation in training)")
    check_fov(cfg.evader_fov_rad, "--evader-fov-rad")
    if cfg.evader_select_every < 0 or cfg.evader_select_episodes < 1:
        raise ValueError(
            f"--evader-select-every {cfg.evader_select_every} / --evader-select-episodes "
            f"{cfg.evader_select_episodes}: give --evader-select-every >= 0 (0: the last "
            "iterate) and --evader-select-episodes >= 1"
        )
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
