"""Save/load round trip, and one-line errors for mismatched, corrupt or missing checkpoints."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from dyncatch.predictor import checkpoint
from dyncatch.predictor.checkpoint import CheckpointError
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.features import History
from dyncatch.predictor.model import Predictor, predict
from dyncatch.predictor.tracker.config import TrackerCfg
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.sim.config import ArenaCfg, EpisodeCfg, SensorCfg, WorldCfg

PREDICTOR = Predictor.for_world(PredictorCfg(kind="self_aware", hidden=(32, 16)), WorldCfg())


def random_histories(n: int) -> History:
    k = jax.random.split(jax.random.key(7), 6)
    u = lambda key, shape, hi: jax.random.uniform(key, (n, *shape), maxval=hi)
    return History(u(k[0], (2,), 16.0), u(k[1], (2,), 16.0), u(k[2], (3,), 3.0),
                   u(k[3], (3,), 3.0), u(k[4], (2,), 2.0), u(k[5], (), 2.0))  # fmt: skip


@pytest.fixture
def saved(tmp_path):
    params = PREDICTOR.init(jax.random.key(0))
    params["in_mean"] = params["in_mean"] + 0.5  # not the init value, so it must be stored
    path = tmp_path / "p.safetensors"
    checkpoint.save(path, PREDICTOR, params, info={"error_mps": 0.1})
    return path, params


def test_round_trip_gives_identical_predictions(saved):
    path, params = saved
    predictor, loaded = checkpoint.load(path, expected=PREDICTOR)
    assert predictor == PREDICTOR
    h = random_histories(64)
    batched = jax.jit(jax.vmap(predict, in_axes=(None, None, 0)), static_argnums=0)
    before = batched(PREDICTOR, params, h)
    after = batched(predictor, loaded, h)
    np.testing.assert_array_equal(np.asarray(before), np.asarray(after))
    assert checkpoint.read_info(path) == {"error_mps": 0.1}
    assert not list(path.parent.glob("*.tmp"))  # the temporary file was renamed away


def test_mismatched_config_names_the_field(saved):
    path, _ = saved
    other = Predictor.for_world(PredictorCfg(kind="self_aware", hidden=(64, 16)), WorldCfg())
    with pytest.raises(CheckpointError, match=r"hidden.*retrain") as err:
        checkpoint.load(path, expected=other)
    assert "\n" not in str(err.value)


def test_corrupt_file_is_a_one_line_error(saved):
    path, _ = saved
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(CheckpointError, match="corrupt") as err:
        checkpoint.load(path)
    assert "\n" not in str(err.value)
    path.write_bytes(b"\x10\x00\x00\x00\x00\x00\x00\x00not json at all!")
    with pytest.raises(CheckpointError, match="corrupt"):
        checkpoint.load(path)


def test_missing_file_says_to_train(tmp_path):
    with pytest.raises(FileNotFoundError, match="train one first"):
        checkpoint.load(tmp_path / "none.safetensors")


def test_a_run_folder_names_the_file_to_give(saved):
    """`dyncatch predictor train --out DIR` writes DIR/predictor.safetensors; DIR itself
    given where the file is expected says so."""
    path, _ = saved
    with pytest.raises(FileNotFoundError, match=rf"is a folder \(it holds {path.name}\)"):
        checkpoint.load(path.parent)


def test_the_world_quantities_come_from_the_world_and_are_recorded(saved):
    path, _ = saved
    # The default world: a 16 m arena, a 2 Hz camera (0.5 s between frames).
    predictor, _ = checkpoint.load_any(path, WorldCfg())
    assert (predictor.arena_size_m, predictor.frame_dt_s) == (16.0, 0.5)
    world = WorldCfg(arena=ArenaCfg(size_m=20.0), sensor=SensorCfg(rate_hz=4.0))
    assert Predictor.for_world(PREDICTOR.cfg, world).frame_dt_s == 0.25


@pytest.mark.parametrize(
    ("world", "field"),
    [
        (WorldCfg(arena=ArenaCfg(size_m=20.0)), "arena_size_m"),
        (WorldCfg(sensor=SensorCfg(rate_hz=4.0)), "frame_dt_s"),
    ],
)
def test_a_predictor_in_another_world_is_refused(saved, world, field):
    path, _ = saved
    with pytest.raises(CheckpointError, match=rf"another world: {field}.*retrain") as err:
        checkpoint.load_any(path, world)
    assert "\n" not in str(err.value)


def test_a_tracker_in_another_control_rate_is_refused(tmp_path):
    tracker = Tracker.for_world(TrackerCfg(hidden=(8,)), WorldCfg())
    assert tracker.control_dt_s == 0.02  # 50 Hz
    path = tmp_path / "t.safetensors"
    checkpoint.save(path, tracker, tracker.init(jax.random.key(0)))
    assert checkpoint.load_any(path, WorldCfg())[0] == tracker
    with pytest.raises(CheckpointError, match=r"control_dt_s 0.02 \(the world: 0.01\)"):
        checkpoint.load_any(path, WorldCfg(episode=EpisodeCfg(control_hz=100)))
