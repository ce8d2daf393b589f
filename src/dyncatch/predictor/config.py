"""Configs of the behaviour predictor: the network, its training and the data collection."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from dyncatch.predictor.features import FEATURES
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import ConfigError

Kind = Literal["vanilla", "self_aware", "tracker"]
TRACKER = "tracker"
"""The kind that is not a frame predictor: ``dyncatch.predictor.tracker``."""
Frame = Literal["world", "relative", "egocentric"]


@dataclass(frozen=True)
class PredictorCfg:
    """The network: which inputs it sees, in which frame, and its size."""

    kind: Kind = "self_aware"
    """``vanilla``: target observations and walls only; ``self_aware``: plus the robot's states."""
    frame: Frame = "egocentric"
    """``world``: absolute world coordinates; ``relative``: world axes, robot quantities taken
    relative to the target; ``egocentric``: everything in the robot's frame at t (vanilla: the
    target's displacement and walls), the output rotated back to the world. Chosen by
    measurement, see docs/predictor.md."""
    hidden: tuple[int, ...] = (128, 128, 128)
    """Hidden layer widths of the MLP."""


@dataclass(frozen=True)
class TrainCfg:
    """Supervised training with the L2 loss of eq. 4 (Adam, random minibatches)."""

    loss: Literal["norm", "squared"] = "norm"
    """Eq. 4 as written, ||v - v_hat||_2 (``norm``), or its square (``squared``, MSE)."""
    updates: int = 6000
    """Gradient steps, whatever the data budget (so budgets compare data, not compute)."""
    batch_size: int = 256
    """Samples per gradient step (drawn with replacement)."""
    lr: float = 1e-3
    """Adam learning rate at the start; cosine-decayed to ``lr * final_lr_frac``."""
    final_lr_frac: float = 0.05
    """Learning rate at the end, as a fraction of ``lr``."""
    log_every: int = 100
    """Gradient steps per logged loss value (and per progress-bar tick)."""


@dataclass(frozen=True)
class CollectCfg:
    """Robot-target interaction that produces the samples (Section III-B)."""

    pursuit_prob: float = 0.5
    """Chance that a new plan is pursuit of the target rather than a uniformly random command
    (pursuit makes reactive targets react)."""
    replan_prob: float = 0.1
    """Chance, at each camera frame, that the robot draws a new plan (else it keeps its plan,
    so its velocity at t says something about its next 0.5 s)."""
    episode_s: float = 2.5
    """Length of each interaction episode; short episodes re-place the robot often."""
    init_distance_min_m: float = 0.5
    """Closest robot placement around the target."""
    init_distance_max_m: float = 2.5
    """Farthest robot placement around the target."""

    def interaction_world(self, world: WorldCfg) -> WorldCfg:
        """``world`` with this collection's episode length and robot placement."""
        episode = world.episode.replace(
            duration_s=self.episode_s,
            init_distance_min_m=self.init_distance_min_m,
            init_distance_max_m=self.init_distance_max_m,
        )
        return world.replace(episode=episode)

    envs_per_chunk: int = 100
    """Environments simulated together; each plays one full episode (1000 steps at 20 s)."""


def validate(predictor: PredictorCfg, train: TrainCfg, collect: CollectCfg) -> None:
    """Raise ConfigError naming the first field that cannot work (call at the boundary)."""

    checks = [
        (predictor.kind in FEATURES, "kind", f"choose one of {', '.join(FEATURES)}"),
        (
            predictor.frame in FEATURES.get(predictor.kind, {}),
            "frame",
            "choose world, relative or egocentric",
        ),
        (all(h > 0 for h in predictor.hidden), "hidden", "layer widths must be positive"),
        (train.updates >= train.log_every > 0, "train.updates", "need updates >= log_every > 0"),
        (train.batch_size > 0, "train.batch_size", "must be positive"),
        (train.lr > 0, "train.lr", "must be positive"),
        (0 <= collect.pursuit_prob <= 1, "collect.pursuit_prob", "must lie in [0, 1]"),
        (0 <= collect.replan_prob <= 1, "collect.replan_prob", "must lie in [0, 1]"),
        (collect.episode_s >= 1.0, "collect.episode_s", "use at least 1 s (two camera frames)"),
        (
            0 <= collect.init_distance_min_m <= collect.init_distance_max_m,
            "collect.init_distance_min_m/max_m",
            "need 0 <= min <= max",
        ),
        (collect.envs_per_chunk > 0, "collect.envs_per_chunk", "must be positive"),
    ]
    for ok, field, fix in checks:
        if not ok:
            raise ConfigError(f"predictor config: {field}: {fix}")
