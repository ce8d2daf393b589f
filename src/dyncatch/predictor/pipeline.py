"""The predictor pipeline: collect interaction data, fit one predictor, measure it, save it.

``train_predictor(cfg, progress)`` writes ``predictor.safetensors``, ``loss.csv``,
``metrics.json`` and TensorBoard events under ``cfg.out`` and returns the metrics; it prints
nothing. ``dyncatch predictor train`` and the reproduction both call it.
``score_predictors(paths, world, ...)`` measures saved predictors on another world's held-out
episodes (a predictor of one target scored on another: ``dyncatch predictor score``).
"""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

from dyncatch.predictor import checkpoint
from dyncatch.predictor.config import (
    TRACKER,
    CollectCfg,
    Frame,
    Kind,
    PredictorCfg,
    TrainCfg,
    validate,
)
from dyncatch.predictor.data import check_world, collect
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.tracker.config import TrackerCfg, TrackerDataCfg, TrackerTrainCfg
from dyncatch.predictor.tracker.pipeline import train_tracker
from dyncatch.predictor.train import encode_samples, evaluate, fit
from dyncatch.sim.behaviors import get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.progress import NoProgress, Progress


@dataclasses.dataclass(frozen=True)
class PredictorTrainCfg:
    """Collect interaction data, train one predictor, save it and report its held-out error."""

    kind: Kind = "self_aware"
    """vanilla (target observations only), self_aware (plus the robot's states) or tracker
    (the current position and velocity at 50 Hz, with uncertainty: docs/tracker.md)."""
    steps: int = 2_000_000
    """Interaction budget in simulator (control) steps."""
    out: Path = Path("runs/predictor")
    """Folder for predictor.safetensors, loss.csv, tb/ (TensorBoard) and metrics.json."""
    frame: Frame = "egocentric"
    """Input frame (see docs/predictor.md)."""
    hidden: tuple[int, ...] = PredictorCfg.hidden
    """Hidden layer widths."""
    eval_steps: int = 200_000
    """Interaction steps of held-out episodes (another seed) for the reported error."""
    seed: int = 0
    """Seed of data collection and initialisation (held-out data use a different stream)."""
    train: TrainCfg = TrainCfg()
    """Optimisation."""
    collect: CollectCfg = CollectCfg()
    """Interaction data."""
    world: WorldCfg = WorldCfg()
    """The simulated world, its target behaviour included (``--behavior``)."""
    tracker: TrackerCfg = TrackerCfg()
    """The tracker's memory and network (kind tracker)."""
    tracker_train: TrackerTrainCfg = TrackerTrainCfg()
    """The tracker's optimisation (kind tracker; train, frame and hidden are unused)."""
    tracker_data: TrackerDataCfg = TrackerDataCfg()
    """The tracker's interaction data (kind tracker; collect is unused)."""


def _keys(seed: int):
    """(data, held-out, fit) keys of a seed: held-out episodes never share the training's."""
    import jax

    return jax.random.split(jax.random.key(seed), 3)


def score_predictors(
    paths: list[str | Path] | tuple[str | Path, ...],
    world: WorldCfg,
    eval_steps: int = 200_000,
    seed: int = 0,
    collect_cfg: CollectCfg | None = None,
) -> list[dict]:
    """The error of each frame predictor saved at ``paths`` on one set of held-out episodes
    of ``world`` (its behaviour included), collected as ``train_predictor`` collects its own
    with the same ``seed``: scored in the world it was trained in, with its seed and
    ``eval_steps``, a predictor gives its ``metrics.json`` error again. One row each: the
    target scored (``behavior``, ``behavior_params``), the one trained on (``trained_on``,
    ``trained_on_params``, from the checkpoint's info), ``kind``, ``eval_samples``,
    ``error_mps``. A tracker is refused (its errors are positions over time: ``dyncatch
    predictor table --kinds tracker``); every file is checked before anything is collected."""
    if not paths:
        raise ValueError("give at least one predictor checkpoint")
    if eval_steps < 1:
        raise ValueError(f"--eval-steps {eval_steps}: give a positive number of steps")
    collect_cfg = collect_cfg or CollectCfg()
    check_world(world, [world.target.behavior], [eval_steps], collect_cfg)
    loaded = []
    for path in map(Path, paths):
        predictor, params = checkpoint.load_any(path, world)
        if not isinstance(predictor, Predictor):
            raise ValueError(
                f"{path} is a tracker: predictor score measures frame predictors (vanilla, "
                "self_aware); measure a tracker with dyncatch predictor table --kinds tracker"
            )
        loaded.append((path, predictor, params, checkpoint.read_info(path)))
    held_out, _ = collect(_keys(seed)[1], world, collect_cfg, eval_steps)
    scored = {
        "behavior": world.target.behavior,
        "behavior_params": get_behavior(world.target.behavior).params(world.target),
        "eval_samples": len(held_out.label_mps),
    }
    rows = []
    for path, predictor, params, info in loaded:
        encoded = encode_samples(predictor, held_out)
        rows.append(
            {
                "predictor": str(path),
                "trained_on": info.get("behavior"),
                "trained_on_params": info.get("behavior_params", {}),
                **scored,
                "kind": predictor.cfg.kind,
                "error_mps": evaluate(predictor, params, encoded, held_out.label_mps),
            }
        )
    return rows


def train_predictor(cfg: PredictorTrainCfg, progress: Progress | None = None) -> dict:
    """Run the pipeline; returns ``{"behavior", "behavior_params", "kind", "budget_steps",
    "train_samples", "eval_samples", "error_mps", "seconds"}`` (also written to
    ``metrics.json`` and the checkpoint's info); ``behavior_params`` are the behaviour's own
    fields (``learned``: its evader file)."""
    from tensorboardX import SummaryWriter

    if cfg.kind == TRACKER:
        return train_tracker(cfg, progress)
    progress = progress or NoProgress()
    predictor_cfg = PredictorCfg(kind=cfg.kind, frame=cfg.frame, hidden=cfg.hidden)
    validate(predictor_cfg, cfg.train, cfg.collect)
    check_world(cfg.world, [cfg.world.target.behavior], [cfg.steps], cfg.collect)
    world = cfg.world
    predictor = Predictor.for_world(predictor_cfg, world)
    k_data, k_eval, k_fit = _keys(cfg.seed)
    cfg.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    update = progress.task(f"collecting ({world.target.behavior}, {cfg.kind})", cfg.steps)
    data, used = collect(k_data, world, cfg.collect, cfg.steps, update)
    held_out, _ = collect(k_eval, world, cfg.collect, cfg.eval_steps)
    update = progress.task(f"training ({world.target.behavior}, {cfg.kind})", cfg.train.updates)
    writer = SummaryWriter(str(cfg.out / "tb"))
    with (cfg.out / "loss.csv").open("w") as log:
        log.write("update,loss_mps\n")

        def on_log(step: int, loss: float) -> None:
            log.write(f"{step},{loss:.6f}\n")
            writer.add_scalar("loss/l2_mps", loss, step)
            update(step, f"loss {loss:.3f} m/s")

        n = len(data.label_mps)
        params, _ = fit(
            predictor, cfg.train, encode_samples(predictor, data), data.label_mps, n, k_fit, on_log
        )
    error = evaluate(predictor, params, encode_samples(predictor, held_out), held_out.label_mps)
    writer.add_scalar("eval/error_mps", error, cfg.train.updates)
    writer.close()
    metrics = {
        "behavior": world.target.behavior,
        "behavior_params": get_behavior(world.target.behavior).params(world.target),
        "kind": cfg.kind,
        "budget_steps": used,
        "train_samples": n,
        "eval_samples": len(held_out.label_mps),
        "error_mps": error,
        "seconds": time.perf_counter() - t0,
    }
    checkpoint.save(cfg.out / checkpoint.PREDICTOR_FILE, predictor, params, info=metrics)
    (cfg.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics
