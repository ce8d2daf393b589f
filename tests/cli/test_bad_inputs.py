"""Bad inputs at every edge: each is one line on stderr naming the field or the file, a
non-zero exit, no traceback, and existing files left as they were."""

from __future__ import annotations

import json

import numpy as np
import pytest

from dyncatch.cli.main import main
from dyncatch.rl.runner import CHECKPOINT, TrainRunCfg, header_of
from dyncatch.utils.tree_io import save_tree

TRAIN = "train --method rl --total-steps 2048 --ppo.num-envs 64 --ppo.num-steps 32 --eval-every 0"
EVAL = "eval pursuit --episodes 4"


def fake_run(folder, edit=None, flip=False):
    """A run folder whose checkpoint has a real header (``edit``-ed) and one tensor."""
    header = json.loads(json.dumps(header_of(TrainRunCfg(method="rl"))))
    if edit:
        edit(header)
    path = save_tree(folder / CHECKPOINT, {"params": np.arange(8, dtype=np.float32)}, header)
    if flip:
        data = bytearray(path.read_bytes())
        data[-2] ^= 1
        path.write_bytes(bytes(data))
    return folder


def no_world(h):
    del h["world"]


def fast_target(h):
    h["world"]["target"]["speed_max_mps"] = "fast"


def bad_json(folder, name):
    (folder / name).write_text('{"total_s": ')


CASES = [
    (f"{EVAL} --speeds nan", "--speeds nan"),
    (f"{EVAL} --speeds inf", "--speeds inf"),
    (f"{EVAL} --speeds 1e9", "--speeds 1000000000.0"),
    (f"{EVAL} --speeds -1", "--speeds -1.0"),
    ("demo --speeds-mps nan --out {tmp}/demo", "--speeds-mps nan"),
    ("reproduce --quick --speeds-mps inf --out {tmp}/rep", "--speeds-mps inf"),
    (f"{EVAL} --world.episode.duration-s 1e-9", "episode.duration_s"),
    (f"{EVAL} --world.episode.duration-s inf", "episode.duration_s"),
    (f"{EVAL} --world.arena.size-m inf", "arena.size_m"),
    (f"{EVAL} --world.base.max-forward-mps inf", "base.max_forward_mps"),
    (f"{EVAL} --world.target.speed-max-mps nan", "target.speed_max_mps"),
    (f"{TRAIN} --ppo.hidden-sizes 0 --out {{tmp}}/t", "ppo.hidden_sizes"),
    (f"{TRAIN} --ppo.ent-coef nan --out {{tmp}}/t", "ppo.ent_coef"),
    (f"{TRAIN} --ppo.learning-rate inf --out {{tmp}}/t", "ppo.learning_rate"),
    (f"{TRAIN} --out {{tmp}}/afile", "afile is a file"),
    ("demo --episodes 2 --out {tmp}/afile", "afile is a file"),
    ("reproduce --quick --out {tmp}/afile", "afile is a file"),
    ("export {tmp}/flip --out {tmp}/afile", "afile is a file"),
    ("eval {tmp}/noworld --episodes 4", "noworld/checkpoint.safetensors: its header has no 'wor"),
    ("export {tmp}/noworld --out {tmp}/x", "noworld/checkpoint.safetensors: its header has no"),
    ("eval {tmp}/fast --episodes 4", "fast/checkpoint.safetensors: header world.target.speed_max"),
    ("eval {tmp}/flip --episodes 4", "flip/checkpoint.safetensors: corrupt checkpoint"),
    ("export {tmp}/flip --out {tmp}/x", "flip/checkpoint.safetensors: corrupt checkpoint"),
]  # fmt: skip


@pytest.mark.parametrize(("argv", "expected"), CASES, ids=[c[0][:60] for c in CASES])
def test_bad_input_is_one_line_naming_it(argv, expected, tmp_path, capsys):
    (tmp_path / "afile").write_text("keep me")
    fake_run(tmp_path / "noworld", edit=no_world)
    fake_run(tmp_path / "fast", edit=fast_target)
    fake_run(tmp_path / "flip", flip=True)
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    code = main(argv.format(tmp=tmp_path).split())
    err = capsys.readouterr().err
    assert code != 0
    assert err.count("\n") == 1 and expected in err and "Traceback" not in err, err
    assert {p: p.read_bytes() for p in before} == before


def test_damaged_files_read_back_name_the_file(tmp_path):
    from dyncatch.reproduce.layout import Plan, check_plan
    from dyncatch.rl.logging import CsvLogger
    from dyncatch.utils.files import read_json

    bad_json(tmp_path, "wall.json")
    with pytest.raises(ValueError, match=r"wall\.json: not valid JSON .*; delete it"):
        read_json(tmp_path / "wall.json")
    bad_json(tmp_path, "plan.json")
    with pytest.raises(ValueError, match=r"plan\.json: not valid JSON .*choose another --out"):
        check_plan(tmp_path, Plan())
    (tmp_path / "metrics.csv").write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ValueError, match=r"metrics\.csv: not a metrics\.csv"):
        CsvLogger(tmp_path, resume_iteration=3)
    (tmp_path / "metrics.csv").write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match=r"metrics\.csv: line 2 does not match"):
        CsvLogger(tmp_path, resume_iteration=3)
    (tmp_path / "metrics.csv").write_text("iteration,env_steps,loss\n1,64,abc\n")
    with pytest.raises(ValueError, match=r"line 2, column loss: 'abc' is not a number"):
        CsvLogger(tmp_path, resume_iteration=3)
