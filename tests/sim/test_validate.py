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
    ],
)
def test_bad_values_name_their_field(cfg, field):
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        validate_world(cfg)


def test_defaults_are_valid():
    assert validate_world(CFG) is CFG
