"""The tracker's rows of ``dyncatch predictor table --kinds tracker``.

Per behaviour, 50 Hz data are collected once at the largest budget (smaller budgets train
on its prefix) and held-out episodes from another key are scored at every control step:
``position_error_m`` (the tracker's mean), ``hold_position_error_m`` (the last sighting,
sample-and-hold), ``coverage95`` and ``error_mps`` (the current velocity's error). The row
of the largest budget also carries ``by_time_since_sighting`` (``train.TAU_BINS_S`` bins),
which ``predictor.table.write`` plots.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import jax

from dyncatch.predictor.tracker.config import TrackerCfg, TrackerDataCfg, TrackerTrainCfg
from dyncatch.predictor.tracker.data import budget_rows, collect_track
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.predictor.tracker.train import (
    error_by_time_since_sighting,
    evaluate_tracker,
    fit_tracker,
)
from dyncatch.sim.config import WorldCfg


def tracker_rows(
    behavior: str,
    world: WorldCfg,
    budgets: tuple[int, ...],
    eval_steps: int,
    keys: tuple[jax.Array, jax.Array, jax.Array],
    cfg: TrackerCfg,
    train: TrackerTrainCfg,
    data: TrackerDataCfg,
    on_cell: Callable[[dict], None] | None = None,
) -> list[dict]:
    """One row per budget for ``behavior`` in ``world``; ``keys`` are (collection,
    held-out, initialisation)."""
    k_train, k_eval, k_fit = keys
    tracker = Tracker.for_world(cfg, world)
    every = data.sample_every_steps
    samples, _ = collect_track(k_train, world, data.collect, tracker, max(budgets), every)
    held_out, _ = collect_track(k_eval, world, data.collect, tracker, eval_steps)
    rows = []
    for budget in sorted(budgets):
        t0 = time.perf_counter()
        n = budget_rows(samples, world, data.collect, budget)
        params, _ = fit_tracker(tracker, train, samples, n, k_fit)
        scores = evaluate_tracker(tracker, params, held_out)
        row = {
            "behavior": behavior,
            "kind": "tracker",
            "budget_steps": budget,
            "error_mps": scores["velocity_error_mps"],
            "paper_error_mps": None,
            "train_samples": n,
            "eval_samples": len(held_out.x),
            "position_error_m": scores["position_error_m"],
            "hold_position_error_m": scores["hold_position_error_m"],
            "coverage95": scores["coverage95"],
            "seconds": time.perf_counter() - t0,
        }
        if budget == max(budgets):
            row["by_time_since_sighting"] = error_by_time_since_sighting(tracker, params, held_out)
        rows.append(row)
        if on_cell is not None:
            on_cell(row)
    return rows
