"""The behaviour registry: TargetCfg composed from each behaviour's config, run-time entries."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
import tyro
from flax import struct

from dyncatch.sim import env
from dyncatch.sim.behaviors import (
    BEHAVIORS,
    Behavior,
    CircleCfg,
    RandomReactiveCfg,
    ReactiveCfg,
    TargetBodyCfg,
    TargetCfg,
    register_behavior,
    registered_behavior,
    unregister_behavior,
)
from dyncatch.sim.behaviors.compose import compose_target_cfg
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world

from .helpers import fixed_rollout, place, world_xy

# Every numeric field of the composed TargetCfg with its documented default, in field order
# (docs/model.md: the paper's 1.8 m/s cap, eq. 11-12's 3 m and 60 deg, gamma_max 22.5 deg).
DEFAULTS = {
    "speed_min_mps": 0.0,
    "speed_max_mps": 1.8,
    "max_turn_rate_rps": 10.0,
    "radius_m": 0.1,
    "height_m": 0.15,
    "circle_radius_m": 5.0,
    "evade_radius_m": 3.0,
    "evade_angle_rad": math.radians(60.0),
    "gamma_max_rad": math.radians(22.5),
    "gamma_hold_s": 0.0,
    "random_turn_max_rad": math.radians(90.0),
    "random_turn_mean_interval_s": 1.0,
    "random_turn_hold_s": 0.5,
}
BODY = ("behavior", "speed_min_mps", "speed_max_mps", "max_turn_rate_rps", "radius_m", "height_m")


def _names(cls):
    return [f.name for f in dataclasses.fields(cls)]


def _heads_plus_x(target, robot, cfg, key):
    del robot, cfg, key
    return jnp.zeros(()), target.behavior_state


PLUS_X = Behavior(desired_heading=_heads_plus_x, doc="always heads along +x")


class TestComposedTargetCfg:
    def test_has_the_body_then_every_behaviours_fields_in_order(self):
        assert _names(TargetCfg) == [
            *BODY,
            "circle_radius_m",
            "evade_radius_m",
            "evade_angle_rad",
            "gamma_max_rad",
            "gamma_hold_s",
            "beta_reading",
            "random_turn_max_rad",
            "random_turn_mean_interval_s",
            "random_turn_hold_s",
            "evader_checkpoint",
            "evader_sample",
            "league_behaviors",
            "league_evaders",
            "league_scripted_share",
            "league_weights",
        ]
        assert BEHAVIORS["learned"].param_names == ("evader_checkpoint", "evader_sample")
        assert BEHAVIORS["commanded"].param_names == ()
        assert BEHAVIORS["circle"].param_names == ("circle_radius_m",)
        assert BEHAVIORS["bounce"].param_names == ()
        assert BEHAVIORS["random_reactive"].param_names[:5] == tuple(_names(ReactiveCfg))

    def test_is_an_instance_of_every_behaviours_cfg_with_the_same_defaults(self):
        target = WorldCfg().target
        for cls in (TargetBodyCfg, CircleCfg, ReactiveCfg, RandomReactiveCfg):
            assert isinstance(target, cls)
            # Each behaviour's own config, made alone, has the defaults the composition holds.
            own = {f.name: getattr(cls(), f.name) for f in dataclasses.fields(cls)}
            own.pop("behavior", None)
            own.pop("beta_reading", None)  # static, a string: checked below
            assert own == pytest.approx({k: DEFAULTS[k] for k in own})
        assert {k: getattr(target, k) for k in DEFAULTS} == pytest.approx(DEFAULTS)
        assert target.beta_reading == ReactiveCfg().beta_reading == "bearing"

    def test_behavior_is_static_and_the_parameters_are_leaves(self):
        leaves, treedef = jax.tree.flatten(WorldCfg().target)
        # The 13 numbers of DEFAULTS in field order; the behaviour name and the beta reading
        # are in the treedef.
        assert leaves == pytest.approx(list(DEFAULTS.values()))
        assert "reactive" in str(treedef) and "bearing" in str(treedef)

    def test_the_cli_and_headers_keep_the_target_dot_field_names(self):
        world = tyro.cli(WorldCfg, args=["--target.evade-radius-m", "1.5"])
        assert world.target.evade_radius_m == 1.5 and world.target.circle_radius_m == 5.0
        header = dataclasses.asdict(world)["target"]
        assert header["evade_radius_m"] == 1.5 and set(header) == set(_names(TargetCfg))

    def test_two_defaults_for_one_field_are_refused(self):
        @struct.dataclass
        class WideCircleCfg:
            circle_radius_m: float = 7.0
            """Another default for the circle's radius."""

        clash = Behavior(desired_heading=_heads_plus_x, cfg_cls=WideCircleCfg)
        with pytest.raises(TypeError, match=r"circle_radius_m.*CircleCfg.*5\.0.*WideCircleCfg"):
            compose_target_cfg([BEHAVIORS["circle"], clash], doc="")
        same = Behavior(desired_heading=_heads_plus_x, cfg_cls=CircleCfg)
        assert _names(compose_target_cfg([BEHAVIORS["circle"], same], doc="")) == [
            *BODY,
            "circle_radius_m",
        ]


class TestRunTimeRegistration:
    def test_a_parameterless_behaviour_steps_under_jit_and_is_removed_afterwards(self):
        before = dict(BEHAVIORS)
        with registered_behavior("plus_x", PLUS_X):
            assert BEHAVIORS["plus_x"] is PLUS_X
            cfg = validate_world(WorldCfg().with_behavior("plus_x").with_speed(1.0))
            s = jax.jit(env.reset)(jax.random.key(0), cfg)
            s = place(s, robot_xy=(0.5, 0.5), target_xy=(4.0, 8.0), heading=2.0)
            states, _, _ = fixed_rollout(s, jnp.zeros(3), cfg, 50)
        assert BEHAVIORS == before and "plus_x" not in BEHAVIORS
        h = np.asarray(states.target.heading_rad)
        xy = np.asarray(world_xy(states, states.target.xy_m))
        # From 2 rad, turning at 10 rad/s (0.2 rad a step), it points along +x after 10 steps.
        np.testing.assert_allclose(h[:3], [1.8, 1.6, 1.4], atol=1e-5)
        np.testing.assert_allclose(h[10:], 0.0, atol=1e-6)
        # Then 1 m/s along +x: 0.02 m a step, y unchanged.
        np.testing.assert_allclose(np.diff(xy[10:, 0]), 0.02, atol=1e-5)
        np.testing.assert_allclose(np.diff(xy[10:, 1]), 0.0, atol=1e-6)

    def test_body_cfg_as_cfg_cls_registers_too(self):
        with registered_behavior("plus_x", dataclasses.replace(PLUS_X, cfg_cls=TargetBodyCfg)):
            assert "plus_x" in BEHAVIORS
        assert "plus_x" not in BEHAVIORS

    def test_a_field_unknown_to_target_cfg_is_refused_by_name(self):
        @struct.dataclass
        class SpiralCfg:
            spiral_pitch_m: float = 0.5
            """Growth of the radius per turn."""

        spiral = Behavior(desired_heading=_heads_plus_x, cfg_cls=SpiralCfg)
        with pytest.raises(ValueError, match=r"target\.spiral_pitch_m.*BEHAVIORS in "):
            register_behavior("spiral", spiral)
        assert "spiral" not in BEHAVIORS

    def test_a_known_field_with_another_default_is_refused(self):
        @struct.dataclass
        class WideCircleCfg:
            circle_radius_m: float = 7.0
            """Another default for the circle's radius."""

        wide = Behavior(desired_heading=_heads_plus_x, cfg_cls=WideCircleCfg)
        with pytest.raises(ValueError, match=r"target\.circle_radius_m \(default 7\.0"):
            register_behavior("wide_circle", wide)

    def test_a_taken_name_is_refused_unless_replaced(self):
        with pytest.raises(ValueError, match="'circle' is already registered.*replace=True"):
            register_behavior("circle", PLUS_X)
        assert BEHAVIORS["circle"] is not PLUS_X
        original = BEHAVIORS["circle"]
        with registered_behavior("circle", PLUS_X, replace=True):
            assert BEHAVIORS["circle"] is PLUS_X
        assert BEHAVIORS["circle"] is original

    def test_unregister_removes_run_time_entries_only(self):
        register_behavior("plus_x", PLUS_X)
        try:
            assert "plus_x" in BEHAVIORS
        finally:
            unregister_behavior("plus_x")
        assert "plus_x" not in BEHAVIORS
        with pytest.raises(ValueError, match="built in"):
            unregister_behavior("reactive")
        with pytest.raises(ValueError, match="not registered"):
            unregister_behavior("plus_x")


class TestParams:
    """``Behavior.params``: a behaviour's own fields, what a record of its data must name."""

    def test_reactive_gives_its_eq_12_constants(self):
        params = BEHAVIORS["reactive"].params(WorldCfg().target)
        assert params == {
            "evade_radius_m": 3.0,
            "evade_angle_rad": pytest.approx(math.pi / 3),
            "gamma_max_rad": pytest.approx(math.pi / 8),
            "gamma_hold_s": 0.0,
            "beta_reading": "bearing",
        }

    def test_bounce_has_none(self):
        assert BEHAVIORS["bounce"].params(WorldCfg().target) == {}

    def test_learned_names_its_evader_and_tuples_become_lists(self):
        t = WorldCfg().target.replace(evader_checkpoint="runs/e0", league_evaders=("a", "b"))
        assert BEHAVIORS["learned"].params(t) == {
            "evader_checkpoint": "runs/e0",
            "evader_sample": False,
        }
        assert BEHAVIORS["league"].params(t)["league_evaders"] == ["a", "b"]
