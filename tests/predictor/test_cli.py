"""``dyncatch predictor train|table|score`` end to end on tiny budgets."""

from __future__ import annotations

import csv
import json

from dyncatch.cli.main import main
from dyncatch.predictor import checkpoint
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT, save_evader

from ..sim.helpers import away_net

TINY = ["--train.updates", "200", "--train.log-every", "100", "--eval-steps", "2500"]


def test_train_writes_a_loadable_checkpoint_and_a_loss_log(tmp_path, capsys):
    out = tmp_path / "run"
    argv = ["predictor", "train", "--behavior", "circle", "--kind", "vanilla", "--steps", "12500"]
    assert main([*argv, "--hidden", "16", "--out", str(out), *TINY]) == 0
    metrics = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert metrics["budget_steps"] == 12500 and metrics["train_samples"] > 0
    predictor, _ = checkpoint.load(out / "predictor.safetensors")
    assert predictor.cfg.kind == "vanilla" and predictor.cfg.hidden == (16,)
    lines = (out / "loss.csv").read_text().splitlines()
    assert lines[0] == "update,loss_mps" and [ln.split(",")[0] for ln in lines[1:]] == [
        "100",
        "200",
    ]
    assert list((out / "tb").iterdir())  # a TensorBoard event file
    # Scored in its own world with its seed and held-out steps: its own error, to the bit;
    # on another target: that target's row, naming the one it was trained on. Several
    # predictors are scored on one collection: the same file twice gives one error twice.
    ckpt = str(out / "predictor.safetensors")
    assert main(["predictor", "score", ckpt, "--behavior", "circle", "--eval-steps", "2500"]) == 0
    own = json.loads(capsys.readouterr().out)
    assert own["error_mps"] == metrics["error_mps"] and own["kind"] == "vanilla"
    assert own["eval_samples"] == metrics["eval_samples"]
    argv = ["predictor", "score", ckpt, ckpt, "--behavior", "bounce", "--eval-steps", "2500"]
    assert main(argv) == 0
    rows = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert len(rows) == 2 and rows[0] == rows[1]
    other = rows[0]
    assert (other["behavior"], other["trained_on"]) == ("bounce", "circle")
    assert other["trained_on_params"] == {"circle_radius_m": 5.0}
    assert 0 <= other["error_mps"] < 5 and other["error_mps"] != own["error_mps"]
    # A folder, or a world the predictor's inputs were not scaled for, is a one-line error.
    assert main(["predictor", "score", str(out)]) == 2
    assert "give the predictor's checkpoint file" in capsys.readouterr().err
    assert main(["predictor", "score", ckpt, "--world.arena.size-m", "20"]) == 2
    assert "--world.arena.size-m" in capsys.readouterr().err


def test_table_json_has_one_row_per_cell(tmp_path, capsys):
    argv = ["predictor", "table", "--json", "--behaviors", "circle", "--budgets", "6250", "12500"]
    assert main([*argv, "--out", str(tmp_path), *TINY]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    cells = {(r["behavior"], r["kind"], r["budget_steps"]) for r in rows}
    assert cells == {("circle", k, n) for k in ("vanilla", "self_aware") for n in (6250, 12500)}
    keys = {"behavior", "behavior_params", "kind", "budget_steps", "error_mps"}
    assert all(set(r) == keys for r in rows)
    assert rows[0]["behavior_params"] == {"circle_radius_m": 5.0}
    assert all(0 <= r["error_mps"] < 5 for r in rows)
    assert {p.name for p in tmp_path.iterdir()} == {"table_ii.md", "table_ii.csv", "table_ii.png"}


def test_a_budget_below_one_episode_is_a_one_line_error(tmp_path, capsys):
    argv = ["predictor", "table", "--budgets", "10", "--out", str(tmp_path)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "budget 10 steps is below one episode (125)" in err and "\n" not in err


class TestLearnedEvader:
    """A predictor of a ``learned`` evader names the evader file its data came from: two
    evaders share the behaviour name, so the name alone does not say what it learned."""

    def test_train_records_the_evader(self, tmp_path, capsys):
        evader = str(save_evader(tmp_path / EVADER_CHECKPOINT, away_net()))
        out = tmp_path / "run"
        argv = ["predictor", "train", "--behavior", "learned", "--kind", "vanilla"]
        argv += ["--world.target.evader-checkpoint", evader, "--steps", "12500"]
        assert main([*argv, "--hidden", "16", "--out", str(out), *TINY]) == 0
        metrics = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        want = {"evader_checkpoint": evader, "evader_sample": False}
        assert metrics["behavior"] == "learned" and metrics["behavior_params"] == want
        assert checkpoint.read_info(out / "predictor.safetensors")["behavior_params"] == want
        assert metrics["train_samples"] > 0 and 0 <= metrics["error_mps"] < 5

    def test_table_rows_and_csv_name_the_evader(self, tmp_path, capsys):
        evader = str(save_evader(tmp_path / EVADER_CHECKPOINT, away_net()))
        argv = ["predictor", "table", "--json", "--behaviors", "learned", "--budgets", "6250"]
        argv += ["--world.target.evader-checkpoint", evader, "--world.target.evader-sample"]
        assert main([*argv, "--out", str(tmp_path / "t"), *TINY]) == 2  # the net has no std
        assert "evader_sample" in capsys.readouterr().err
        argv = argv[:-1]
        assert main([*argv, "--out", str(tmp_path / "t"), *TINY]) == 0
        rows = json.loads(capsys.readouterr().out)["rows"]
        want = {"evader_checkpoint": evader, "evader_sample": False}
        assert [r["behavior_params"] for r in rows] == [want, want]
        with (tmp_path / "t" / "table_ii.csv").open() as f:
            assert [json.loads(r["behavior_params"]) for r in csv.DictReader(f)] == [want, want]
