"""Target behaviours: the circle holds its radius, bounce mirrors, reactive flees and dodges."""

import math

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim import env
from dyncatch.sim.behaviors import (
    BEHAVIORS,
    CircleState,
    GammaState,
    NoState,
    RandomReactiveState,
    get_behavior,
)
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import wrap_angle

from .helpers import fixed_rollout, place, world_xy

CFG = WorldCfg()
STILL = jnp.zeros(3)


def _start(cfg, seed=0, robot_xy=None, robot_yaw=None, target_xy=None, heading=None):
    """A reset state with the bodies placed at world positions."""
    s = jax.jit(env.reset)(jax.random.key(seed), cfg)
    return place(s, robot_xy=robot_xy, robot_yaw=robot_yaw, target_xy=target_xy, heading=heading)


def test_registry_names_every_behavior():
    assert sorted(BEHAVIORS) == [
        "bounce",
        "circle",
        "commanded",
        "league",
        "learned",
        "random_reactive",
        "reactive",
    ]
    try:
        get_behavior("zigzag")
    except ValueError as err:
        assert "zigzag" in str(err) and "reactive" in str(err)
    else:
        raise AssertionError("unknown behaviour accepted")


def test_circle_keeps_its_radius_for_a_whole_episode():
    cfg = CFG.with_behavior("circle").with_speed(1.8)
    # Robot parked in a corner so that it never catches the target.
    s = _start(cfg, robot_xy=(0.5, 0.5))
    states, _, _ = fixed_rollout(s, STILL, cfg, 1000)
    xy = world_xy(states, states.target.xy_m)
    r = jnp.linalg.norm(xy - 0.5 * cfg.arena.size_m, axis=-1)
    assert float(jnp.abs(r - cfg.target.circle_radius_m).max()) < 0.05
    # It travels at 1.8 m/s along the circle: 36 m of arc is 7.2 rad of angle.
    ang = jnp.unwrap(jnp.arctan2(*(xy - 8.0).T[::-1]))
    assert abs(abs(float(ang[-1] - ang[0])) - 36.0 / 5.0) < 0.1


def test_bounce_mirrors_off_a_wall_and_keeps_its_speed():
    cfg = CFG.with_behavior("bounce").with_speed(1.0)
    # Heading 30 deg below +x toward the right wall, 0.5 m away.
    heading = -math.pi / 6
    s = _start(cfg, robot_xy=(1.0, 1.0), target_xy=(15.4, 8.0), heading=heading)
    states, _, _ = fixed_rollout(s, STILL, cfg, 100)
    h = states.target.heading_rad
    # Before the wall: unchanged; after: x-component flipped, y-component kept.
    assert abs(float(h[0]) - heading) < 1e-5
    np.testing.assert_allclose(
        [float(jnp.cos(h[-1])), float(jnp.sin(h[-1]))],
        [-math.cos(heading), math.sin(heading)],
        atol=1e-5,
    )
    xy = world_xy(states, states.target.xy_m)
    assert float(xy[:, 0].max()) <= cfg.arena.size_m - cfg.target.radius_m + 1e-5
    # Two seconds at 1 m/s travel 2 m of path whatever the bounce.
    step = jnp.linalg.norm(jnp.diff(xy, axis=0), axis=-1)
    assert float(step.sum()) > 1.9


def test_reactive_flees_a_still_robot():
    cfg = CFG.with_behavior("reactive").with_speed(1.0)
    start = cfg.target.evade_radius_m + 1.0  # beyond r_ev: pure flight, no dodge
    s = _start(
        cfg, robot_xy=(4.0, 8.0), robot_yaw=0.0, target_xy=(4.0 + start, 8.0), heading=math.pi
    )
    states, _, infos = fixed_rollout(s, STILL, cfg, 100)
    # It turns around (at 10 rad/s, within a third of a second) and runs off along +x,
    # wobbling by gamma ~ U(-22.5, 22.5) deg: x advances by at least cos(22.5 deg) per metre.
    assert float(infos["distance_m"][-1]) > start + 1.4
    assert float(world_xy(states, states.target.xy_m)[-1, 0]) > 4.0 + start + 1.4


def test_reactive_dodges_to_its_own_side_when_the_robot_is_close():
    cfg = CFG.with_behavior("reactive").with_speed(1.5)
    beh = get_behavior("reactive")
    s = _start(cfg, robot_xy=(6.0, 8.0), robot_yaw=0.0, target_xy=(7.0, 8.2))
    flee = math.atan2(0.2, 1.0)  # target is left of the robot's heading: beta > 0
    keys = jax.random.split(jax.random.key(3), 2000)
    heads = jax.vmap(lambda k: beh.desired_heading(s.target, s.robot, cfg, k)[0])(keys)
    offsets = np.asarray(heads) - flee
    # Mean offset is +alpha; the spread is gamma's uniform range.
    assert abs(offsets.mean() - cfg.target.evade_angle_rad) < 0.02
    assert offsets.max() <= cfg.target.evade_angle_rad + cfg.target.gamma_max_rad + 1e-5
    assert offsets.min() >= cfg.target.evade_angle_rad - cfg.target.gamma_max_rad - 1e-5
    # Mirror image: a target right of the heading dodges right.
    s2 = _start(cfg, robot_xy=(6.0, 8.0), robot_yaw=0.0, target_xy=(7.0, 7.8))
    heads2 = jax.vmap(lambda k: beh.desired_heading(s2.target, s2.robot, cfg, k)[0])(keys)
    assert abs((np.asarray(heads2) + flee).mean() + cfg.target.evade_angle_rad) < 0.02
    # Far away (beyond r_ev) there is no dodge at all.
    s3 = _start(cfg, robot_xy=(2.0, 8.0), robot_yaw=0.0, target_xy=(7.0, 9.0))
    heads3 = jax.vmap(lambda k: beh.desired_heading(s3.target, s3.robot, cfg, k)[0])(keys)
    assert abs(float(jnp.mean(heads3)) - math.atan2(1.0, 5.0)) < 0.02


def test_circle_state_is_a_direction_of_plus_or_minus_one_that_never_changes():
    cfg = CFG.with_behavior("circle").with_speed(1.0)
    keys = jax.random.split(jax.random.key(11), 64)
    starts = jax.vmap(env.reset, in_axes=(0, None))(keys, cfg)
    assert isinstance(starts.target.behavior_state, CircleState)
    directions = np.asarray(starts.target.behavior_state.direction)
    assert set(directions.tolist()) == {-1.0, 1.0}  # a fair coin: both show up in 64 draws
    # The start heading is the tangent in that direction: +90 deg from the radial for +1.
    rel = world_xy(starts, starts.target.xy_m) - 0.5 * cfg.arena.size_m
    radial = jnp.arctan2(rel[:, 1], rel[:, 0])
    turn = np.asarray(wrap_angle(starts.target.heading_rad - radial))
    np.testing.assert_allclose(turn, directions * math.pi / 2, atol=1e-5)
    s = _start(cfg, seed=5, robot_xy=(0.5, 0.5))
    states, _, _ = fixed_rollout(s, STILL, cfg, 200)
    kept = np.asarray(states.target.behavior_state.direction)
    np.testing.assert_array_equal(kept, float(s.target.behavior_state.direction))
    # And the target really goes round that way: the polar angle moves with the direction.
    ang = np.unwrap(np.arctan2(*(np.asarray(world_xy(states, states.target.xy_m)) - 8.0).T[::-1]))
    assert np.sign(ang[-1] - ang[0]) == kept[0]


def test_stateless_behaviors_carry_an_empty_state():
    s = jax.jit(env.reset)(jax.random.key(0), CFG.with_behavior("bounce"))
    assert isinstance(s.target.behavior_state, NoState)
    assert jax.tree.leaves(s.target.behavior_state) == []


def test_reactive_carries_its_gamma_none_drawn_at_reset():
    s = jax.jit(env.reset)(jax.random.key(0), CFG.with_behavior("reactive"))
    assert isinstance(s.target.behavior_state, GammaState)
    assert float(s.target.behavior_state.gamma_rad) == int(s.target.behavior_state.left_steps) == 0


def test_random_reactive_adds_held_offsets():
    cfg = CFG.with_behavior("random_reactive").with_speed(1.0)
    s = _start(cfg, robot_xy=(2.0, 8.0), robot_yaw=0.0, target_xy=(7.0, 8.0))
    first = s.target.behavior_state
    assert isinstance(first, RandomReactiveState)
    assert float(first.offset_rad) == float(first.next_change_in_s) == 0.0  # drawn at step 1
    states, _, _ = fixed_rollout(s, STILL, cfg, 500)
    st = states.target.behavior_state
    offsets, next_in, hold = (
        np.asarray(x) for x in (st.offset_rad, st.next_change_in_s, st.hold_left_s)
    )
    changes = np.count_nonzero(np.diff(offsets))
    # Mean interval 1 s: about 10 changes in 10 s (Poisson, so allow a wide band).
    assert 3 <= changes <= 20
    assert np.abs(offsets).max() <= cfg.target.random_turn_max_rad + 1e-6
    # A new offset comes with a fresh hold of random_turn_hold_s and a positive interval.
    drawn = np.flatnonzero(np.diff(offsets)) + 1
    np.testing.assert_allclose(hold[drawn], cfg.target.random_turn_hold_s)
    assert (next_in[drawn] > 0).all()
    # Between draws both clocks run down by one control step.
    calm = np.setdiff1d(np.arange(1, len(offsets)), drawn)
    dt = cfg.episode.dt_s
    np.testing.assert_allclose(np.diff(hold)[calm - 1], -dt, atol=1e-5)
    np.testing.assert_allclose(np.diff(next_in)[calm - 1], -dt, atol=1e-5)
