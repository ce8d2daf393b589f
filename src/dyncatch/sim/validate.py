"""Checks of a world config at the boundary (CLI, files), with messages that name the fix."""

from __future__ import annotations

from dyncatch.sim.behaviors import BEHAVIORS, get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SCENES


class ConfigError(ValueError):
    """A config value that cannot work; the message names the field and what to do."""


def validate_world(cfg: WorldCfg) -> WorldCfg:
    """Return ``cfg`` unchanged, or raise ConfigError naming the first bad field."""
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
        (e.duration_s > 0, "episode.duration_s", "must be positive"),
        (
            0 < e.init_distance_min_m <= e.init_distance_max_m,
            "episode.init_distance_*",
            "need 0 < min <= max",
        ),
        (b.lag_s > 0, "base.lag_s", "must be positive"),
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
