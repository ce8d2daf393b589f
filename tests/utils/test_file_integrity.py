"""Checkpoints carry a checksum of their tensors; configs read back from files are typed;
atomically written files get the mode a plain open would."""

from __future__ import annotations

import os
import stat

import jax
import jax.numpy as jnp
import pytest

from dyncatch.predictor import checkpoint
from dyncatch.predictor.checkpoint import CheckpointError
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.model import Predictor
from dyncatch.rl.config import PPOCfg
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.config_io import ConfigDictError, from_dict, to_json
from dyncatch.utils.files import check_out_dir
from dyncatch.utils.tree_io import TreeFileError, load_tree, save_tree

TREE = {"w": jnp.arange(6.0).reshape(2, 3), "b": jnp.ones(4, jnp.int32)}


def flip_last_data_byte(path):
    data = bytearray(path.read_bytes())
    data[-3] ^= 0x01  # the last tensor's bytes; the header (at the start) stays intact
    path.write_bytes(bytes(data))


def test_a_damaged_data_byte_is_refused_naming_the_file(tmp_path):
    path = save_tree(tmp_path / "c.safetensors", TREE, {"x": 1})
    tree, header = load_tree(path, TREE)
    assert header == {"x": 1} and (tree["w"] == TREE["w"]).all()
    flip_last_data_byte(path)
    with pytest.raises(TreeFileError, match=r"c\.safetensors: corrupt checkpoint .*checksum"):
        load_tree(path, TREE)


def test_a_damaged_predictor_checkpoint_is_refused(tmp_path):
    predictor = Predictor.for_world(PredictorCfg(kind="vanilla", hidden=(8,)), WorldCfg())
    path = tmp_path / "p.safetensors"
    checkpoint.save(path, predictor, predictor.init(jax.random.key(0)))
    checkpoint.load(path, predictor)
    flip_last_data_byte(path)
    with pytest.raises(CheckpointError, match=r"p\.safetensors is corrupt .*checksum"):
        checkpoint.load(path, predictor)


def test_atomic_writes_honour_the_umask(tmp_path):
    old = os.umask(0o022)
    try:
        path = save_tree(tmp_path / "c.safetensors", TREE, {})
        assert stat.S_IMODE(path.stat().st_mode) == 0o644
        os.umask(0o077)
        path = save_tree(tmp_path / "d.safetensors", TREE, {})
        assert stat.S_IMODE(path.stat().st_mode) == 0o600
    finally:
        os.umask(old)


@pytest.mark.parametrize(
    ("field", "value", "message"),
    [
        (("target", "speed_max_mps"), "fast", r"speed_max_mps is 'fast', expected a number"),
        (("scene", "scan_rays"), 2.5, r"world\.scene\.scan_rays is 2\.5, expected an integer"),
        (("scene", "name"), 3, r"world\.scene\.name is 3, expected a string"),
        (("arm", "stow_rad"), [0.0, "x"], r"world\.arm\.stow_rad\[1\] is 'x', expected a number"),
        (("target",), 1.0, r"world\.target: expected an object"),
    ],
)  # fmt: skip
def test_from_dict_type_checks_every_field(field, value, message):
    d = to_json(WorldCfg())
    node = d
    for name in field[:-1]:
        node = node[name]
    node[field[-1]] = value
    with pytest.raises(ConfigDictError, match=message):
        from_dict(WorldCfg, d, "world")


def test_from_dict_round_trips_and_reads_integers_as_floats():
    assert from_dict(WorldCfg, to_json(WorldCfg())) == WorldCfg()
    assert from_dict(PPOCfg, to_json(PPOCfg())) == PPOCfg()
    assert from_dict(PPOCfg, {"gamma": 1}).gamma == 1.0
    assert isinstance(from_dict(PPOCfg, {"gamma": 1}).gamma, float)
    with pytest.raises(ConfigDictError, match="ppo.num_envs is True, expected an integer"):
        from_dict(PPOCfg, {"num_envs": True}, "ppo")


def test_an_out_folder_that_is_a_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("keep")
    with pytest.raises(ValueError, match=r"--out .*f is a file, not a folder"):
        check_out_dir(tmp_path / "f")
    with pytest.raises(ValueError, match=r"is inside .*f, which is a file"):
        check_out_dir(tmp_path / "f" / "sub")
    assert check_out_dir(tmp_path / "new") == tmp_path / "new"
    assert (tmp_path / "f").read_text() == "keep"
