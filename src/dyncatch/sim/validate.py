"""Checks of a world config at the boundary (CLI, files), with messages that name the fix."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable

from dyncatch.sim.behaviors import BEHAVIORS, get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SCENES


class ConfigError(ValueError):
    """A config value that cannot work; the message names the field and what to do."""


MAX_SPEED_MPS = 100.0
"""The fastest target speed accepted (m/s): far beyond any animal the model stands for,
and below the speeds at which one control step (0.02 s) crosses the arena."""


def non_finite_fields(cfg, prefix: str = "") -> Iterable[tuple[str, float]]:
    """(dotted name, value) of every float field of a nested config that is NaN, or
    infinite where its default is finite (a field whose default is inf means "no limit")."""
    default = type(cfg)()
    for f in dataclasses.fields(cfg):
        value, base = getattr(cfg, f.name), getattr(default, f.name)
        name = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(value):
            yield from non_finite_fields(value, name + ".")
        elif isinstance(value, float) and not isinstance(base, bool):
            if math.isnan(value) or (math.isinf(value) and not math.isinf(base)):
                yield name, value


def validate_speeds(speeds: Iterable[float], flag: str) -> tuple[float, ...]:
    """Target speeds of a command-line list, checked: finite, in [0, MAX_SPEED_MPS]."""
    speeds = tuple(speeds)
    for v in speeds:
        if not 0 <= v <= MAX_SPEED_MPS:  # False for NaN too
            raise ConfigError(
                f"{flag} {v}: give target speeds in m/s between 0 and {MAX_SPEED_MPS:g}"
            )
    if not speeds:
        raise ConfigError(f"{flag}: give at least one target speed in m/s")
    return speeds


def validate_world(cfg: WorldCfg) -> WorldCfg:
    """Return ``cfg`` unchanged, or raise ConfigError naming the first bad field."""
    for name, value in non_finite_fields(cfg):
        raise ConfigError(
            f"bad world config: {name}: must be a finite number, got {value}; give a finite value"
        )
    t, s, e, b, a = cfg.target, cfg.sensor, cfg.episode, cfg.base, cfg.arm
    period_s = s.period_s if s.rate_hz > 0 else float("inf")
    checks = [
        (
            cfg.scene.name in SCENES,
            "scene.name",
            f"unknown scene {cfg.scene.name!r}; choose one of {', '.join(SCENES)}",
        ),
        (cfg.scene.scan_rays >= 1, "scene.scan_rays", "need at least one ray"),
        (cfg.scene.scan_range_m > 0, "scene.scan_range_m", "must be positive"),
        (
            t.behavior in BEHAVIORS,
            "target.behavior",
            f"unknown behavior {t.behavior!r}; choose one of {', '.join(sorted(BEHAVIORS))}",
        ),
        (
            cfg.arena.size_m > 2 * (b.radius_m + 1.0),
            "arena.size_m",
            f"{cfg.arena.size_m} m is too small; use more than {2 * b.radius_m + 2:.2f}",
        ),
        (
            0 <= t.speed_min_mps <= t.speed_max_mps,
            "target.speed_min_mps/speed_max_mps",
            f"need 0 <= min <= max, got {t.speed_min_mps} and {t.speed_max_mps}",
        ),
        (
            t.speed_max_mps <= MAX_SPEED_MPS,
            "target.speed_max_mps",
            f"{t.speed_max_mps} m/s is too fast; use at most {MAX_SPEED_MPS:g}",
        ),
        (t.max_turn_rate_rps > 0, "target.max_turn_rate_rps", "must be positive"),
        # The active behaviour checks its own parameters (the others are not used).
        *(get_behavior(t.behavior).validate(cfg) if t.behavior in BEHAVIORS else []),
        (
            s.rate_hz > 0 and s.rate_hz <= e.control_hz,
            "sensor.rate_hz",
            f"must lie in (0, control_hz={e.control_hz}]",
        ),
        (0 < s.fov_rad <= 6.2832, "sensor.fov_rad", "must lie in (0, 2*pi]"),
        (s.range_m > 0, "sensor.range_m", "must be positive"),
        (a.aim in ("true", "sighting"), "arm.aim", "must be true or sighting"),
        (
            0 <= s.latency_s < period_s,
            "sensor.latency_s",
            f"must lie in [0, one camera period = {period_s:.3f} s)",
        ),
        (s.noise_m >= 0, "sensor.noise_m", "must be >= 0"),
        (
            e.control_hz > 0 and e.physics_substeps >= 1,
            "episode.control_hz/physics_substeps",
            "must be positive",
        ),
        (
            e.duration_s * e.control_hz >= 1,
            "episode.duration_s",
            f"{e.duration_s} s is shorter than one control step; use at least {e.dt_s:g}",
        ),
        (
            0 < e.init_distance_min_m <= e.init_distance_max_m,
            "episode.init_distance_*",
            "need 0 < min <= max",
        ),
        (b.lag_s > 0, "base.lag_s", "must be positive"),
        (b.max_speed_mps > 0, "base.max_speed_mps", "must be positive (inf: no limit)"),
        (
            b.max_lateral_accel_mps2 > 0 and b.max_yaw_accel_rps2 > 0,
            "base.max_lateral_accel_mps2/max_yaw_accel_rps2",
            "must be positive (inf: no limit)",
        ),
        (
            min(b.max_forward_mps, b.max_backward_mps, b.max_lateral_mps, b.max_yaw_rate_rps) >= 0,
            "base.max_*",
            "limits must be >= 0",
        ),
        (
            len(a.joint_min_rad) == 6 and len(a.joint_max_rad) == 6 and len(a.stow_rad) == 6,
            "arm.joint_min_rad/joint_max_rad/stow_rad",
            "need six values each",
        ),
        (
            all(lo < hi for lo, hi in zip(a.joint_min_rad, a.joint_max_rad, strict=False)),
            "arm.joint_min_rad/joint_max_rad",
            "each lower limit must be below its upper limit",
        ),
        (a.ik_damping > 0, "arm.ik_damping", "must be positive"),
        (a.catch_radius_m > 0, "arm.catch_radius_m", "must be positive"),
    ]
    # The active scene checks its own constants (layout, terrain), as a behaviour does.
    scene = SCENES.get(cfg.scene.name)
    if scene is not None:
        checks += scene.validate(cfg)
    if scene is not None and scene.layout is not None:
        checks += [
            (cfg.avoid.lookahead_m >= 0, "avoid.lookahead_m", "must be >= 0"),
            (cfg.avoid.directions >= 1, "avoid.directions", "need at least one"),
        ]
    for ok, field, why in checks:
        if not ok:
            raise ConfigError(f"bad world config: {field}: {why}")
    return cfg
