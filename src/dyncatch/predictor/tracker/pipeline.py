"""The tracker's pipeline: collect 50 Hz interaction data, fit the tracker, measure it on
held-out episodes, save it, and write its error against the time since the last sighting.

``train_tracker(cfg, progress)`` is ``dyncatch predictor train --kind tracker``: it writes
``predictor.safetensors`` (a ``dyncatch.tracker/1`` checkpoint), ``loss.csv``,
``error_vs_time.csv``, ``error_vs_time.png`` and ``metrics.json`` under ``cfg.out`` and
returns the metrics; it prints nothing.
"""

from __future__ import annotations

import csv
import json
import time
from pathlib import Path
from typing import TYPE_CHECKING

from dyncatch.predictor import checkpoint
from dyncatch.predictor.data import check_world
from dyncatch.predictor.tracker.config import validate_tracker
from dyncatch.predictor.tracker.data import collect_track
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.predictor.tracker.train import (
    error_by_time_since_sighting,
    evaluate_tracker,
    fit_tracker,
)
from dyncatch.sim.behaviors import get_behavior
from dyncatch.utils.progress import NoProgress, Progress

if TYPE_CHECKING:
    from dyncatch.predictor.pipeline import PredictorTrainCfg


def train_tracker(cfg: PredictorTrainCfg, progress: Progress | None = None) -> dict:
    """Returns ``{"behavior", "kind", "budget_steps", "train_samples", "eval_samples",
    "error_mps", "position_error_m", "hold_position_error_m", "velocity_error_mps",
    "coverage95", "seconds"}``; ``error_mps`` is the current velocity's error."""
    import jax

    progress = progress or NoProgress()
    validate_tracker(cfg.tracker, cfg.tracker_train, cfg.tracker_data)
    collect_cfg = cfg.tracker_data.collect
    world = cfg.world
    check_world(world, [world.target.behavior], [cfg.steps], collect_cfg)
    tracker = Tracker.for_world(cfg.tracker, world)
    k_data, k_eval, k_fit = jax.random.split(jax.random.key(cfg.seed), 3)
    cfg.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    update = progress.task(f"collecting ({world.target.behavior}, tracker)", cfg.steps)
    every = cfg.tracker_data.sample_every_steps
    data, used = collect_track(k_data, world, collect_cfg, tracker, cfg.steps, every, update)
    held_out, _ = collect_track(k_eval, world, collect_cfg, tracker, cfg.eval_steps)
    train = cfg.tracker_train
    update = progress.task(f"training ({world.target.behavior}, tracker)", train.updates)
    with (cfg.out / "loss.csv").open("w") as log:
        log.write("update,nll\n")

        def on_log(step: int, loss: float) -> None:
            log.write(f"{step},{loss:.6f}\n")
            update(step, f"NLL {loss:.3f}")

        n = len(data.x)
        params, _ = fit_tracker(tracker, train, data, n, k_fit, on_log)
    scores = evaluate_tracker(tracker, params, held_out)
    bins = error_by_time_since_sighting(tracker, params, held_out)
    write_error_vs_time(bins, cfg.out, f"{world.target.behavior}, held-out {cfg.eval_steps} steps")
    metrics = {
        "behavior": world.target.behavior,
        "behavior_params": get_behavior(world.target.behavior).params(world.target),
        "kind": "tracker",
        "budget_steps": used,
        "train_samples": n,
        "eval_samples": len(held_out.x),
        "error_mps": scores["velocity_error_mps"],
        **scores,
        "seconds": time.perf_counter() - t0,
    }
    checkpoint.save(cfg.out / checkpoint.PREDICTOR_FILE, tracker, params, info=metrics)
    (cfg.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    return metrics


def write_error_vs_time(bins: list[dict], out: Path, title: str) -> list[Path]:
    """``error_vs_time.csv`` and ``error_vs_time.png`` (position error of the tracker and of
    the last sighting, and the tracker's standard deviation, against the time since the
    last sighting's capture) under ``out``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    csv_path, png = out / "error_vs_time.csv", out / "error_vs_time.png"
    with csv_path.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(bins[0]))
        writer.writeheader()
        writer.writerows(bins)
    mid = [0.5 * (b["lo_s"] + b["hi_s"]) for b in bins]
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    ax.plot(mid, [b["hold_position_error_m"] for b in bins], "o--", label="last sighting (hold)")
    ax.plot(mid, [b["position_error_m"] for b in bins], "o-", label="tracker mean")
    ax.plot(mid, [b["pos_std_m"] for b in bins], ":", label="tracker std (RMS of axes)")
    ax.set_xscale("symlog", linthresh=0.5)
    ax.set_yscale("log")
    ax.set_xlabel("time since the last sighting's capture (s)")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"Tracker vs sample-and-hold: {title}", fontsize=9)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return [csv_path, png]
