"""``dyncatch predictor train``, ``table`` (Section III-B, Table II) and ``score``.

The pipelines live in ``dyncatch.predictor``; this module turns flags into their configs and
attaches a progress display.
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

import tyro

from dyncatch.cli.progress import rich_progress
from dyncatch.predictor.config import (
    TRACKER,
    CollectCfg,
    Frame,
    Kind,
    PredictorCfg,
    TrainCfg,
    validate,
)
from dyncatch.predictor.data import check_world
from dyncatch.predictor.pipeline import PredictorTrainCfg, score_predictors, train_predictor
from dyncatch.predictor.table import (
    TRACKER_KEYS,
    TableCfg,
    all_behaviors,
    all_kinds,
    markdown,
    run_table,
    write,
)
from dyncatch.predictor.tracker.config import (
    TrackerCfg,
    TrackerDataCfg,
    TrackerTrainCfg,
    validate_tracker,
)
from dyncatch.reproduce.paper import PAPER_BUDGETS, PAPER_TABLE_II_ERRORS
from dyncatch.sim.behaviors import BehaviorName
from dyncatch.sim.config import WorldCfg


def run_predictor_train(cfg: PredictorTrainCfg) -> dict:

    with rich_progress() as progress:
        metrics = train_predictor(cfg, progress)
    print(json.dumps(metrics))
    return metrics


@dataclasses.dataclass(frozen=True)
class PredictorScoreCmd:
    """Score saved predictors on one set of held-out episodes of any target (--behavior and
    the --world.* flags): predictors of one target measured on another. Prints one JSON
    object per predictor: the target scored, the one trained on, kind, eval_samples,
    error_mps."""

    predictors: tyro.conf.Positional[tuple[Path, ...]]
    """The predictors' checkpoints (OUT/predictor.safetensors of dyncatch predictor train)."""
    eval_steps: int = 200_000
    """Interaction steps of the held-out episodes (predictor train's default)."""
    seed: int = 0
    """Seed of the held-out episodes: the stream predictor train holds out with the same
    seed, so its own world, seed and --eval-steps give its metrics.json error again."""
    collect: CollectCfg = CollectCfg()
    """Interaction data."""
    world: WorldCfg = WorldCfg()
    """The world scored in, its target behaviour included (--behavior)."""


def run_predictor_score(cmd: PredictorScoreCmd) -> list[dict]:
    rows = score_predictors(cmd.predictors, cmd.world, cmd.eval_steps, cmd.seed, cmd.collect)
    for row in rows:
        print(json.dumps(row))
    return rows


@dataclasses.dataclass(frozen=True)
class PredictorTableCmd:
    """Reproduce Table II: error ||v_hat - v||_2 (m/s) per behaviour, kind and budget."""

    json: bool = False
    """Print one JSON object {"rows": [...]} instead of the Markdown table."""
    out: Path = Path("results/predictor")
    """Folder for table_ii.md, table_ii.csv and table_ii.png."""
    budgets: tuple[int, ...] = PAPER_BUDGETS
    """Interaction budgets in simulator steps."""
    behaviors: tuple[BehaviorName, ...] = dataclasses.field(default_factory=all_behaviors)
    """Target behaviours (rows); default every registered behaviour."""
    kinds: tuple[Kind, ...] = dataclasses.field(default_factory=all_kinds)
    """Predictor kinds (default every frame predictor's); name tracker for the tracker's rows
    (position_error_m, hold_position_error_m, coverage95 and an error-vs-time plot)."""
    frame: Frame = "egocentric"
    """Input frame of the frame predictors."""
    eval_steps: int = 500_000
    """Interaction steps of the held-out episodes, per behaviour."""
    seed: int = 0
    """Seed of the whole grid."""
    train: TrainCfg = TrainCfg()
    """Optimisation (the same for every cell)."""
    collect: CollectCfg = CollectCfg()
    """Interaction data."""
    world: WorldCfg = WorldCfg()
    """The simulated world."""
    tracker: TrackerCfg = TrackerCfg()
    """The tracker's memory and network (kinds tracker)."""
    tracker_train: TrackerTrainCfg = TrackerTrainCfg()
    """The tracker's optimisation (kinds tracker)."""
    tracker_data: TrackerDataCfg = TrackerDataCfg()
    """The tracker's interaction data (kinds tracker; collect is the frame predictors')."""


def run_predictor_table(cmd: PredictorTableCmd) -> list[dict]:
    from rich.console import Console

    cfg = PredictorCfg(frame=cmd.frame)
    validate(cfg, cmd.train, cmd.collect)
    check_world(cmd.world, cmd.behaviors, cmd.budgets, cmd.collect)
    if TRACKER in cmd.kinds:
        validate_tracker(cmd.tracker, cmd.tracker_train, cmd.tracker_data)
        check_world(cmd.world, cmd.behaviors, cmd.budgets, cmd.tracker_data.collect)
    table = TableCfg(
        behaviors=cmd.behaviors,
        kinds=cmd.kinds,
        budgets=cmd.budgets,
        eval_steps=cmd.eval_steps,
        seed=cmd.seed,
    )
    console = Console(stderr=cmd.json)
    t0 = time.perf_counter()
    with console.status("Table II") as status:

        def on_cell(r: dict) -> None:
            status.update(
                f"{r['behavior']} {r['kind']} {r['budget_steps'] / 1e6:g}M: "
                f"{r['error_mps']:.3f} m/s"
            )

        setup = (cmd.tracker, cmd.tracker_train, cmd.tracker_data)
        rows = run_table(
            table, cfg, cmd.train, cmd.collect, cmd.world, on_cell, setup, PAPER_TABLE_II_ERRORS
        )
    wall_s = time.perf_counter() - t0
    header = f"Table II, regenerated in {wall_s:.0f} s (seed {cmd.seed})."
    paths = write(rows, cmd.out, header)
    if cmd.json:
        keys = ("behavior", "behavior_params", "kind", "budget_steps", "error_mps", *TRACKER_KEYS)
        print(json.dumps({"rows": [{k: r[k] for k in keys if k in r} for r in rows]}))
    else:
        console.print(markdown(rows))
        console.print(f"{header} Wrote {', '.join(str(p) for p in paths)}")
    return rows
