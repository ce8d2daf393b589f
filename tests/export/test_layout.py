"""Layouts of the exported graphs: every input slot has a unit and a meaning."""

import jax
import pytest

from dyncatch.export.layout import command_layout, entries, policy_layout, predictor_layout
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.features import FEATURES
from dyncatch.predictor.model import Predictor
from dyncatch.rl.methods import METHODS
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import ACTION_DIM


@pytest.mark.parametrize(
    ("kind", "frame"), [(k, f) for k in FEATURES for f in FEATURES[k]], ids=lambda v: v
)
def test_every_predictor_layout_has_units_and_meanings(kind, frame):
    predictor = Predictor.for_world(PredictorCfg(kind=kind, frame=frame, hidden=(8,)), WorldCfg())
    layout = predictor_layout(predictor)
    assert all(e["unit"] and e["doc"] for e in layout)
    assert layout[-1]["offset"] + layout[-1]["size"] == predictor.input_dim


def test_a_name_without_a_unit_or_a_meaning_is_refused():
    with pytest.raises(ValueError, match="unit suffix"):
        entries([("speed", 1)], {"speed": "how fast"})
    with pytest.raises(ValueError, match="undocumented"):
        entries([("speed_mps", 1)], {})


# (name, offset, size) of every slot, worked out by hand from the fields' shapes: the
# default (the paper's s, IV-A) and with the staleness inputs (``staleness_observation``).
OBS_SLOTS = [
    ("robot_vel_body_mps", 0, 2),
    ("robot_yaw_rate_rps", 2, 1),
    ("target_obs_body_m", 3, 2),
    ("scan_m", 5, 8),
]
VELOCITY_SLOTS = [("target_vel_body_mps", 13, 2), ("target_vel_defined", 15, 1)]
STALE_OBS_SLOTS = [
    ("robot_vel_body_mps", 0, 2),
    ("robot_yaw_rate_rps", 2, 1),
    ("target_obs_body_m", 3, 2),
    ("time_since_seen_s", 5, 1),
    ("visible", 6, 1),
    ("scan_m", 7, 8),
]
STALE_VELOCITY_SLOTS = [("target_vel_body_mps", 15, 2), ("target_vel_defined", 17, 1)]
STALE = WorldCfg().replace(observation=WorldCfg().observation.replace(staleness_inputs=True))


@pytest.mark.parametrize(
    ("method", "world", "slots"),
    [
        ("rl", WorldCfg(), OBS_SLOTS),
        ("gt_rl", WorldCfg(), OBS_SLOTS + VELOCITY_SLOTS),
        ("rl", STALE, STALE_OBS_SLOTS),
        ("gt_rl", STALE, STALE_OBS_SLOTS + STALE_VELOCITY_SLOTS),
    ],
    ids=["rl", "gt_rl", "rl-staleness", "gt_rl-staleness"],
)
def test_the_policy_layout_covers_the_input_vector(method, world, slots):
    layout = policy_layout(METHODS[method].obs_fn(), world)
    assert [(e["name"], e["offset"], e["size"]) for e in layout] == slots
    assert {e["unit"] for e in layout} >= {"m", "m/s", "rad/s"}
    if world.observation.staleness_inputs:
        assert {e["unit"] for e in layout} >= {"s", "1 (0 or 1)"}


@pytest.mark.parametrize("method", ["rl", "gt_rl"])
def test_the_policy_layout_follows_the_worlds_scan(method):
    # Issue 29: a 32-ray world's policy input is 5 + 32 (+ 3) wide, not the 8-ray default's.
    world = WorldCfg().for_scene("woods_plane")
    env = JaxCatchEnv(world)
    state = env.reset(jax.random.key(0))
    obs_fn = METHODS[method].obs_fn()
    x = obs_fn(state, env.observe(state))
    layout = policy_layout(obs_fn, world)
    assert x.shape == (5 + 32 + (3 if METHODS[method].velocity_input else 0),)
    assert sum(e["size"] for e in layout) == x.shape[0]
    assert next(e for e in layout if e["name"] == "scan_m")["size"] == 32


def test_the_command_has_one_named_slot_per_action():
    assert [e["name"] for e in command_layout()] == ["vx_mps", "vy_mps", "yaw_rate_rps"]
    assert len(command_layout()) == ACTION_DIM
