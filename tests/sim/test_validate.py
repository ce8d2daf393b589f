"""Bad world configs fail at the boundary with the field named."""

import pytest

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import ConfigError, validate_world

CFG = WorldCfg()


@pytest.mark.parametrize(
    ("cfg", "field"),
    [
        (CFG.with_behavior("zigzag"), "target.behavior"),
        (CFG.with_speed(-1.0), "target.speed_min_mps"),
        (CFG.replace(sensor=CFG.sensor.replace(latency_s=0.6)), "sensor.latency_s"),
        (CFG.replace(arena=CFG.arena.replace(size_m=1.0)), "arena.size_m"),
        (CFG.replace(sensor=CFG.sensor.replace(rate_hz=0.0)), "sensor.rate_hz"),
        (CFG.replace(base=CFG.base.replace(max_lateral_accel_mps2=-3.0)), "base.max_lateral"),
        (CFG.replace(base=CFG.base.replace(max_speed_mps=0.0)), "base.max_speed_mps"),
        (
            CFG.replace(base=CFG.base.replace(max_yaw_accel_rps2=0.0)),
            "base.max_lateral_accel_mps2/max_yaw",
        ),
    ],
)
def test_bad_values_name_their_field(cfg, field):
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        validate_world(cfg)


def test_defaults_are_valid():
    assert validate_world(CFG) is CFG


def _target(**fields):
    return CFG.replace(target=CFG.target.replace(**fields))


def test_the_active_behavior_checks_its_own_fields():
    too_big = _target(circle_radius_m=8.0)  # a 16 m circle does not fit a 16 m arena
    with pytest.raises(ConfigError, match=r"target\.circle_radius_m"):
        validate_world(too_big.with_behavior("circle"))
    # The circle's radius is no concern of the other behaviours.
    for name in ("bounce", "reactive", "random_reactive"):
        assert validate_world(too_big.with_behavior(name)).target.behavior == name
    # random_reactive reuses reactive's parameters, and so reactive's checks.
    negative = _target(evade_radius_m=-1.0)
    for name in ("reactive", "random_reactive"):
        with pytest.raises(ConfigError, match=r"target\.evade_radius_m"):
            validate_world(negative.with_behavior(name))
    assert validate_world(negative.with_behavior("circle")).target.evade_radius_m == -1.0
