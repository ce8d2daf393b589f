"""The self-aware tracker: its constant-turn base, its memory, its accuracy on a predictable
path, its uncertainty, its calibration on reactive targets, and its checkpoint."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.predictor.checkpoint import CheckpointError, load, load_any, save
from dyncatch.predictor.config import CollectCfg
from dyncatch.predictor.tracker.config import TrackerCfg, TrackerDataCfg, TrackerTrainCfg
from dyncatch.predictor.tracker.data import collect_track
from dyncatch.predictor.tracker.memory import Memory
from dyncatch.predictor.tracker.model import Tracker, constant_turn
from dyncatch.predictor.tracker.train import (
    error_by_time_since_sighting,
    evaluate_tracker,
    fit_tracker,
    per_sample,
)
from dyncatch.sim.config import WorldCfg

DT_S = 0.02


def _memory(points, ages) -> Memory:
    return Memory(
        sight_m=jnp.asarray(points, jnp.float32),
        robot_pose=jnp.zeros((3, 3)),
        age_s=jnp.asarray(ages, jnp.float32),
        valid=jnp.ones(3, bool),
        last_tss_s=jnp.zeros(()),
    )


class TestConstantTurn:
    def test_three_sightings_with_a_gap_give_the_circle_exactly(self):
        # A 5 m circle at 1.5 m/s counter-clockwise (0.3 rad/s), seen at t = -1.5, -0.5 and
        # 0 s (one frame missed): 0.8 s later it is at angle 0.3 * 0.8 = 0.24 rad.
        r, w = 5.0, 0.3
        at = lambda t: (r * math.cos(w * t), r * math.sin(w * t))  # noqa: E731
        memory = _memory([at(0.0), at(-0.5), at(-1.5)], [0.0, 0.5, 1.5])
        pos, vel, turn = constant_turn(memory, jnp.asarray(0.8), DT_S, 2.0)
        np.testing.assert_allclose(pos, at(0.8), atol=1e-4)
        speed = r * w
        np.testing.assert_allclose(
            vel, (-speed * math.sin(0.24), speed * math.cos(0.24)), atol=1e-4
        )
        assert float(turn) == pytest.approx(w, abs=1e-5)

    def test_two_sightings_extrapolate_at_constant_velocity_and_one_holds(self):
        memory = _memory([(2.0, 1.0), (1.0, 1.0), (0.0, 0.0)], [0.0, 0.5, 0.0])
        memory = memory.replace(valid=jnp.array([True, True, False]))
        pos, vel, turn = constant_turn(memory, jnp.asarray(0.25), DT_S, 2.0)
        np.testing.assert_allclose(vel, (2.0, 0.0), atol=1e-6)  # 1 m in 0.5 s
        np.testing.assert_allclose(pos, (2.5, 1.0), atol=1e-6)
        assert float(turn) == 0.0
        only = memory.replace(valid=jnp.array([True, False, False]))
        pos, vel, _ = constant_turn(only, jnp.asarray(0.25), DT_S, 2.0)
        np.testing.assert_allclose(pos, (2.0, 1.0))
        np.testing.assert_allclose(vel, (0.0, 0.0))


@pytest.fixture(scope="module")
def circle():
    """A small tracker trained on circle targets (20 k interaction steps, 500 updates) and
    held-out circle episodes sampled at every control step (50 Hz)."""
    world = WorldCfg().with_behavior("circle")
    tracker = Tracker.for_world(TrackerCfg(hidden=(32, 32)), world)
    collect = CollectCfg(episode_s=4.0, envs_per_chunk=25)
    train, _ = collect_track(jax.random.key(0), world, collect, tracker, 20_000)
    held_out, _ = collect_track(jax.random.key(1), world, collect, tracker, 4_000)
    cfg = TrackerTrainCfg(updates=500, batch_size=256)
    params, _ = fit_tracker(tracker, cfg, train, len(train.x), jax.random.key(2))
    return tracker, params, held_out


def test_the_memory_places_every_sighting_where_it_was(circle):
    """End to end through the sensor's frame: at a delivery (no latency) the newest
    remembered sighting is the target itself, and with three sightings on a circle the
    constant-turn base (built from the older rows, their frames and ages) is exact."""
    _, _, held = circle
    true = held.label[:, :2]
    fresh = held.since_sighting_s < 1e-6
    assert fresh.sum() > 50
    np.testing.assert_allclose(held.hold_m[fresh], true[fresh], atol=1e-4)
    three = held.remembered == 3
    assert three.mean() > 0.2
    base_error = np.linalg.norm(held.base[three, :2] - true[three], axis=-1)
    assert float(np.median(base_error)) < 1e-3


def test_on_circle_targets_the_50hz_position_error_is_below_5_cm(circle):
    tracker, params, held = circle
    error = per_sample(tracker, params, held)["position_error_m"]
    three = held.remembered == 3  # the turn is observable from three sightings
    assert float(error[three].mean()) < 0.05
    scores = evaluate_tracker(tracker, params, held)
    assert scores["position_error_m"] < scores["hold_position_error_m"]


def test_uncertainty_grows_while_unseen_and_shrinks_at_a_sighting(circle):
    tracker, params, held = circle
    bins = [b for b in error_by_time_since_sighting(tracker, params, held) if b["samples"] >= 50]
    # Within a camera period (the next frame is due) the spread rises bin by bin; after a
    # missed frame (1-2 s unseen) it is above all of those. Not bin by bin beyond the period:
    # over 5 data seeds at this budget the longer-gap bins dipped in 4 (0.375 then 0.358 m at
    # 1-1.5 and 1.5-2 s, also with 4x the updates). An assertion over every bin up to 2 s
    # passed on one simulator random stream by chance and failed on the next (2026-12-02).
    period_s = 1.0 / WorldCfg().sensor.rate_hz
    within = [b["pos_std_m"] for b in bins if b["hi_s"] <= period_s + 1e-9]
    unseen = [b["pos_std_m"] for b in bins if b["lo_s"] >= 1.0 and b["hi_s"] <= 2.0]
    assert len(within) >= 4 and len(unseen) >= 1
    assert all(b > a for a, b in zip(within, within[1:], strict=False)), within
    assert min(unseen) > max(within), (within, unseen)
    std = per_sample(tracker, params, held)["pos_std_m"]
    tau, env = held.since_sighting_s, held.env_index
    # A sighting: the clock restarts within one episode. Where the estimate was already at
    # the floor (three sightings of a circle) there is nothing to shrink.
    at = np.nonzero((tau[1:] < tau[:-1]) & (env[1:] == env[:-1]))[0]
    at = at[std[at] > 2 * tracker.cfg.min_pos_std_m]
    assert len(at) >= 10
    assert float(np.mean(std[at + 1] < std[at])) >= 0.95


@pytest.mark.extended
def test_held_out_reactive_coverage95_is_calibrated_and_halves_the_hold_error():
    """The issue's targets at 1.8 m/s: coverage95 in [0.90, 0.98] and position_error_m <=
    0.5 x hold_position_error_m (2 M steps, the budget docs/tracker.md measured them at, the
    default tracker). At 1 M steps coverage95 sits on the band's edge: 0.906, 0.917, 0.893
    over data seeds 0, 1, 2 on one simulator random stream and 0.898, 0.893, 0.894 on the
    next; at 2 M 0.930, 0.919, 0.929 (2026-12-02)."""
    world = WorldCfg().with_behavior("reactive").with_speed(1.8)
    tracker = Tracker.for_world(TrackerCfg(), world)
    data = TrackerDataCfg()
    train, _ = collect_track(
        jax.random.key(0), world, data.collect, tracker, 2_000_000, data.sample_every_steps
    )
    held, _ = collect_track(jax.random.key(1), world, data.collect, tracker, 100_000)
    params, _ = fit_tracker(tracker, TrackerTrainCfg(), train, len(train.x), jax.random.key(2))
    scores = evaluate_tracker(tracker, params, held)
    assert 0.90 <= scores["coverage95"] <= 0.98, scores
    assert scores["position_error_m"] <= 0.5 * scores["hold_position_error_m"], scores


def test_a_tracker_checkpoint_round_trips_and_is_not_a_frame_predictor(tmp_path):
    tracker = Tracker.for_world(TrackerCfg(hidden=(8,)), WorldCfg())
    params = tracker.init(jax.random.key(0))
    params["in_mean"] = jnp.arange(tracker.input_dim, dtype=jnp.float32)
    path = tmp_path / "tracker.safetensors"
    save(path, tracker, params, info={"coverage95": 0.95})
    got, got_params = load_any(path)
    assert got == tracker
    for a, b in zip(jax.tree.leaves(params), jax.tree.leaves(got_params), strict=True):
        np.testing.assert_array_equal(a, b)
    with pytest.raises(CheckpointError, match="dyncatch.predictor/1"):
        load(path)
    assert not list(tmp_path.glob("*.tmp"))
