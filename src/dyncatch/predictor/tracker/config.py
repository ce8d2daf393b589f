"""Configs of the self-aware tracker (``docs/tracker.md``): its memory and network, the
interaction data it learns from, and its training."""

from __future__ import annotations

from dataclasses import dataclass, field

from dyncatch.predictor.config import CollectCfg
from dyncatch.sim.validate import ConfigError

CHI2_2D_95 = 5.991464547107979
"""The 0.95 quantile of chi^2 with 2 degrees of freedom: a 2-D Gaussian's 95 % region is
``d^T Sigma^-1 d <= CHI2_2D_95`` (coverage95)."""


@dataclass(frozen=True)
class TrackerCfg:
    """The tracker: a memory of the last sightings and an MLP with a Gaussian head."""

    memory: int = 3
    """Sightings remembered (the newest and the ones before, consecutive or not); three
    make a turning rate observable (a circle), two only a velocity."""
    hidden: tuple[int, ...] = (128, 128)
    """Hidden layer widths of the MLP."""
    min_pos_std_m: float = 0.01
    """Floor of the position standard deviation: a sighting is exact with the default
    noise-free camera, and an unbounded NLL would chase sigma -> 0 there."""
    min_vel_std_mps: float = 0.02
    """Floor of the velocity standard deviation, for the same reason."""
    max_turn_rps: float = 2.0
    """Cap of the constant-turn extrapolation's turn rate (the base the network corrects):
    a 5 m circle at 1.8 m/s turns at 0.36 rad/s; a reactive target's jitter between frames
    would otherwise spin the base."""
    max_log_std: float = 3.0
    """Cap of the predicted log standard deviations (e^3: 20 m, 20 m/s), so early
    training cannot overflow."""


@dataclass(frozen=True)
class TrackerTrainCfg:
    """Gaussian negative log-likelihood of position and velocity, Adam, random minibatches."""

    updates: int = 6000
    """Gradient steps (the predictor's default)."""
    batch_size: int = 512
    """Samples per gradient step (drawn with replacement)."""
    lr: float = 1e-3
    """Adam learning rate at the start; cosine-decayed to ``lr * final_lr_frac``."""
    final_lr_frac: float = 0.05
    """Learning rate at the end, as a fraction of ``lr``."""
    vel_weight: float = 1.0
    """Weight of the velocity NLL against the position NLL."""
    log_every: int = 100
    """Gradient steps per logged loss value."""


@dataclass(frozen=True)
class TrackerDataCfg:
    """Interaction episodes sampled at the control rate (every step is a sample, sightings
    or not), the robot driven as in the predictor's collection."""

    collect: CollectCfg = field(default_factory=lambda: CollectCfg(episode_s=10.0))
    """Robot plans and placement; 10 s episodes (the predictor's are 2.5 s) so that long
    stretches without a sighting are in the data."""
    sample_every_steps: int = 5
    """Keep every n-th control step of the training episodes (neighbouring steps are
    nearly the same sample); held-out episodes keep every step (the 50 Hz error)."""


def validate_tracker(cfg: TrackerCfg, train: TrackerTrainCfg, data: TrackerDataCfg) -> None:
    """Raise ConfigError naming the first field that cannot work (call at the boundary)."""

    checks = [
        (cfg.memory >= 3, "tracker.memory", "remember at least 3 (a turn rate needs them)"),
        (all(h > 0 for h in cfg.hidden), "tracker.hidden", "layer widths must be positive"),
        (cfg.min_pos_std_m > 0, "tracker.min_pos_std_m", "must be positive"),
        (cfg.min_vel_std_mps > 0, "tracker.min_vel_std_mps", "must be positive"),
        (train.updates >= train.log_every > 0, "train.updates", "need updates >= log_every > 0"),
        (train.batch_size > 0, "train.batch_size", "must be positive"),
        (data.sample_every_steps >= 1, "data.sample_every_steps", "must be >= 1"),
        (data.collect.episode_s >= 1.0, "data.collect.episode_s", "use at least 1 s"),
    ]
    for ok, name, fix in checks:
        if not ok:
            raise ConfigError(f"tracker config: {name}: {fix}")
