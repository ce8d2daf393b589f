"""Self-play rounds: alternate best responses between a learned evader and the pursuers.

Round k (0-based):

1. ``evader``: an evader trained (``rl.evader_train``) against the frozen pursuers of round
   k-1, every method and seed drawn with equal weight (round 0: ``first_pursuers``).
2. ``predictor/{kind}`` (with ``predictor_steps``): the predictor of each kind the methods
   read, trained on the round's league (below), which that round's pursuers read.
3. ``pursuer/{method}``: each method's seeds trained (``rl.seeds``, one ``vmap``-ped group)
   in the ``league`` world: each episode a member of evaders 0..k plus the scripted
   ``league_behaviors`` (``sim.behaviors.league``), so a pursuer does not overfit the last
   evader.
4. ``exploit/{method}/seed{s}``: a fresh best-response evader trained against that one
   pursuer (skipped with ``exploit_steps`` 0), and ``eval/{method}/seed{s}``: the pursuer's
   success against the round's league and against its best response
   (``rl.exploitability``).

After every round (``cross_eval``), ``round{k}/cross/{method}/{opponent}``: round k's
pursuers of one method (all seeds) against one opponent alone, round j's evader
(``round{j}``) or a scripted league member (``rl.cross_eval``).

Layout under ``out``: ``selfplay.json`` (the config; another is refused, naming the field),
``round{k}/{evader,predictor/{kind},pursuer/{method},exploit/{method}/seed{s},
eval/{method}/seed{s},cross/{method}/{opponent}}/`` (each finished by ``done.json``,
``rl.stages``) and
``summary.json`` / ``summary.md``. Adding rounds to a finished study (a larger
``--rounds``) reuses every finished stage.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from dyncatch.evaluation.intervals import CONFIDENCE
from dyncatch.predictor.checkpoint import PREDICTOR_FILE
from dyncatch.predictor.pipeline import PredictorTrainCfg, train_predictor
from dyncatch.rl.cross_eval import (
    Opponent,
    cross_rows,
    cross_table,
    difference_rows,
    difference_table,
    evaluate_runs,
)
from dyncatch.rl.evader_train import EvaderTrainCfg, resumable, train_evader
from dyncatch.rl.exploitability import (
    best_response_world,
    evaluate_pursuer,
    summary_rows,
    summary_table,
)
from dyncatch.rl.methods import get_method
from dyncatch.rl.runner import TrainRunCfg, seed_cfgs
from dyncatch.rl.seeds import make_runner
from dyncatch.rl.selfplay_cfg import (
    PURSUER_LOGGERS,
    RESUMABLE_FIELDS,
    SelfPlayCfg,
    league_world,
    validate_selfplay,
)
from dyncatch.rl.stages import Stage, diff_message, run_stage
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.config_io import to_json
from dyncatch.utils.files import read_json, write_json
from dyncatch.utils.progress import NoProgress, Progress


def study_spec(cfg: SelfPlayCfg) -> dict:
    """What the study's stages share: the config less ``RESUMABLE_FIELDS``."""
    d = to_json(cfg)
    return {k: v for k, v in d.items() if k not in RESUMABLE_FIELDS}


def check_study(cfg: SelfPlayCfg) -> None:
    """Record the config in ``out/selfplay.json``; refuse a folder made with another."""
    path = cfg.out / "selfplay.json"
    want = study_spec(cfg)
    if path.exists():
        have = read_json(path, "delete it, or choose another --out")
        # A field added since the study was made reads as its default there.
        defaults = study_spec(SelfPlayCfg(out=cfg.out))
        have.update({k: v for k, v in want.items() if k not in have and v == defaults.get(k)})
        msg = diff_message(
            have,
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


def league_evaders(cfg: SelfPlayCfg, k: int) -> tuple[str, ...]:
    """The evader files of round ``k``'s league: rounds 0..k."""
    return tuple(str(evader_path(cfg.out, j) / EVADER_CHECKPOINT) for j in range(k + 1))


def predictor_kinds(cfg: SelfPlayCfg) -> list[str]:
    """The predictor kinds the study's methods read, in the order of --methods."""
    kinds = [get_method(m).predictor_kind for m in cfg.methods]
    return list(dict.fromkeys(k for k in kinds if k is not None))


def round_predictor_cfg(cfg: SelfPlayCfg, k: int, kind: str) -> PredictorTrainCfg:
    """Round ``k``'s predictor of ``kind`` (with --predictor-steps): trained on the round's
    league, the pursuers' own world."""
    return PredictorTrainCfg(
        kind=kind,
        steps=cfg.predictor_steps,
        seed=cfg.seed + k,
        out=cfg.out / f"round{k}" / "predictor" / kind,
        world=league_world(cfg, league_evaders(cfg, k)),
    )


def pursuer_predictor(cfg: SelfPlayCfg, k: int, method: str) -> Path | None:
    """The predictor file round ``k``'s ``method`` reads (None: it reads none)."""
    kind = get_method(method).predictor_kind
    if kind is None:
        return None
    if cfg.predictor_steps:
        return round_predictor_cfg(cfg, k, kind).out / PREDICTOR_FILE
    return cfg.predictor


def pursuer_cfg(cfg: SelfPlayCfg, k: int, method: str) -> TrainRunCfg:
    evaders = league_evaders(cfg, k)
    return TrainRunCfg(
        method=method,
        total_steps=cfg.pursuer_steps,
        seed=cfg.seed,
        seeds=cfg.seeds,
        out=cfg.out / f"round{k}" / "pursuer" / method,
        predictor=pursuer_predictor(cfg, k, method),
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
        fov_rad=cfg.evader_fov_rad,
        speed_action=cfg.evader_speed_action,
        select_every=cfg.evader_select_every,
        select_episodes=cfg.evader_select_episodes,
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
        stages = [_evader_stage(f"round{k}/evader", ev)]
        if cfg.predictor_steps:
            for kind in predictor_kinds(cfg):
                pc = round_predictor_cfg(cfg, k, kind)
                stages.append(
                    Stage(
                        f"round{k}/predictor/{kind}",
                        pc.out,
                        to_json(pc),
                        lambda p, pc=pc: train_predictor(pc, p),
                    )
                )
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
            _evader_stage(f"round{k}/exploit/{name}", br),
            Stage(f"round{k}/eval/{name}", cfg.out / f"round{k}" / "eval" / name, spec, evaluate),
        ]

    def opponents(self) -> list[Opponent]:
        """Every round's evader, then each scripted league member, in the study's world."""
        cfg = self.cfg
        evaders = [
            Opponent(f"round{j}", best_response_world(cfg.world, evader_path(cfg.out, j)))
            for j in range(cfg.rounds)
        ]
        scripted = [Opponent(b, cfg.world.with_behavior(b)) for b in cfg.league_behaviors]
        return evaders + scripted

    def cross_stages(self, k: int, method: str) -> list[Stage]:
        """Round ``k``'s pursuers of ``method`` (every seed) against each opponent."""
        cfg = self.cfg
        runs = [run.out for run in pursuer_runs(cfg, k, method)]
        stages = []
        for opp in self.opponents():

            def evaluate(progress: Progress | None, world=opp.world) -> dict:
                del progress
                return evaluate_runs(
                    runs, world, cfg.eval_speeds_mps, cfg.eval_episodes, cfg.eval_seed
                )

            spec = {
                "runs": [str(r) for r in runs],
                "opponent": opp.name,
                "world": to_json(opp.world),
                "speeds_mps": list(cfg.eval_speeds_mps),
                "episodes": cfg.eval_episodes,
                "eval_seed": cfg.eval_seed,
            }
            name = f"round{k}/cross/{method}/{opp.name}"
            stages.append(Stage(name, cfg.out / name, spec, evaluate))
        return stages

    def _run(self, stage: Stage, progress: Progress | None) -> dict:
        bar = progress or NoProgress()
        bar.task(stage.name, 1)(0, "running")
        done = run_stage(stage, progress)
        bar.task(stage.name, 1)(1, "skipped (done)" if done["skipped"] else "done")
        return done

    def cross_evaluate(self, progress: Progress | None = None) -> tuple[list[dict], float]:
        """The cross-evaluation's cells ``{"method", "pursuer_round", "opponent", "result"}``
        and their time (s, each stage's as first made)."""
        cfg = self.cfg
        cells, time_s = [], 0.0
        for k in range(cfg.rounds):
            for method in cfg.methods:
                for stage in self.cross_stages(k, method):
                    done = self._run(stage, progress)
                    time_s += done["time_s"]
                    opponent = stage.spec["opponent"]
                    cell = {"method": method, "pursuer_round": k, "opponent": opponent}
                    cells.append({**cell, "result": done["result"]})
        return cells, time_s

    def learn(self, progress: Progress | None = None) -> dict:
        """Every round's stages, then the cross-evaluation (finished ones skipped); returns
        the summary: ``rounds`` (exploitability and round time per round and method),
        ``cross_eval`` (``rl.cross_eval.cross_rows``), ``compare``
        (``rl.cross_eval.difference_rows``) and ``cross_eval_time_s``."""
        cfg = self.cfg
        check_study(cfg)
        records: list[tuple[int, Stage, dict]] = []
        for k in range(cfg.rounds):
            for stage in self.round_stages(k):
                records.append((k, stage, self._run(stage, progress)))
        cells, cross_time_s = self.cross_evaluate(progress) if cfg.cross_eval else ([], 0.0)
        summary = {
            "rounds": summary_rows(records, cfg.methods, CONFIDENCE),
            "cross_eval": cross_rows(cells, CONFIDENCE),
            "compare": difference_rows(cells, tuple(cfg.compare), CONFIDENCE),
            "cross_eval_time_s": cross_time_s,
        }
        write_summary(cfg.out, summary)
        return summary


def write_summary(out: Path, summary: dict) -> None:
    """``out/summary.json`` and ``out/summary.md`` (the exploitability table, then the
    cross-evaluation's and the methods' difference where there are any)."""
    write_json(out / "summary.json", summary)
    lines = summary_table(summary["rounds"])
    for title, table in (
        ("Cross-evaluation", cross_table(summary["cross_eval"])),
        ("Difference of methods", difference_table(summary["compare"])),
    ):
        if table:
            lines += ["", f"## {title}", "", *table]
    (out / "summary.md").write_text("\n".join(lines) + "\n")


def _evader_stage(name: str, cfg: EvaderTrainCfg) -> Stage:
    """An evader's training as a stage that continues an interrupted run from its saved
    training state (``evader_train.resumable``)."""
    return Stage(
        name, cfg.out, to_json(cfg), lambda p: train_evader(resumable(cfg), p), keeps_partial=True
    )


def _trainer(pc: TrainRunCfg):
    def make(progress: Progress | None = None) -> dict:
        out = make_runner(pc).learn(progress)
        per_seed = [out] if isinstance(out, dict) else out
        return {"success_rate": [float(m.get("success_rate", float("nan"))) for m in per_seed]}

    return make
