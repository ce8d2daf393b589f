"""How the tracker's uncertainty should be made: one Gaussian head trained by NLL, or an
ensemble (docs/tracker.md, "Choice of the uncertainty").

``python benchmarks/tracker_uncertainty.py [--steps N] [--members M]`` trains ``M`` trackers
(the library's Gaussian NLL head, different initialisation and minibatch seeds) on the same
interaction data and scores, on held-out 50 Hz samples, three ways of reading them:

- ``gaussian``: the first member alone (what the library ships);
- ``ensemble_spread``: the members' means, with the spread of the means (plus the position
  floor) as the only uncertainty (an ensemble of point estimators);
- ``deep_ensemble``: the mixture of the members' Gaussians, moment-matched (mean of the
  means, variance = mean of variances + variance of means).

Each prints position_error_m, coverage95 and the mean position standard deviation.
"""

from __future__ import annotations

import dataclasses
import json

import jax
import numpy as np
import tyro

from dyncatch.predictor.tracker.config import (
    CHI2_2D_95,
    TrackerCfg,
    TrackerDataCfg,
    TrackerTrainCfg,
)
from dyncatch.predictor.tracker.data import collect_track
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.predictor.tracker.train import fit_tracker
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


@dataclasses.dataclass(frozen=True)
class UncertaintyCmd:
    behavior: str = "reactive"
    """Target behaviour."""
    speed_mps: float = 1.8
    """Target speed (fixed)."""
    steps: int = 500_000
    """Interaction steps of training data."""
    eval_steps: int = 100_000
    """Interaction steps of held-out data (every control step scored)."""
    members: int = 3
    """Trackers trained (ensemble size)."""
    tracker: TrackerCfg = TrackerCfg()
    train: TrackerTrainCfg = TrackerTrainCfg()
    data: TrackerDataCfg = TrackerDataCfg()


def _score(mean: np.ndarray, var: np.ndarray, true: np.ndarray) -> dict[str, float]:
    d = true - mean
    return {
        "position_error_m": float(np.linalg.norm(d, axis=-1).mean()),
        "coverage95": float((np.sum(d * d / var, -1) <= CHI2_2D_95).mean()),
        "pos_std_m": float(np.sqrt(var.mean(-1)).mean()),
    }


def main(cmd: UncertaintyCmd) -> dict:
    world = WorldCfg().with_behavior(cmd.behavior).with_speed(cmd.speed_mps)
    tracker = Tracker.for_world(cmd.tracker, world)
    every = cmd.data.sample_every_steps
    train, _ = collect_track(jax.random.key(0), world, cmd.data.collect, tracker, cmd.steps, every)
    held, _ = collect_track(jax.random.key(1), world, cmd.data.collect, tracker, cmd.eval_steps)
    apply = jax.jit(tracker.apply_encoded)
    means, variances = [], []
    for m in range(cmd.members):
        params, _ = fit_tracker(tracker, cmd.train, train, len(train.x), jax.random.key(10 + m))
        g = jax.device_get(apply(params, held.x, held.base))
        means.append(g.pos_m)
        variances.append(g.pos_std_m**2)
    means, variances = np.stack(means), np.stack(variances)
    true = held.label[:, :2]
    mixture_mean = means.mean(0)
    floor = cmd.tracker.min_pos_std_m**2
    result = {
        "gaussian": _score(means[0], variances[0], true),
        "ensemble_spread": _score(mixture_mean, means.var(0) + floor, true),
        "deep_ensemble": _score(mixture_mean, variances.mean(0) + means.var(0), true),
        "hold_position_error_m": float(np.linalg.norm(held.hold_m - true, axis=-1).mean()),
        "train_samples": len(train.x),
        "eval_samples": len(held.x),
    }
    print(json.dumps(result, indent=2))
    return result


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(UncertaintyCmd))
