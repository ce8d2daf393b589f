"""``dyncatch predictor train|table`` end to end on tiny budgets."""

from __future__ import annotations

import json

from dyncatch.cli.main import main
from dyncatch.predictor import checkpoint

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


def test_table_json_has_one_row_per_cell(tmp_path, capsys):
    argv = ["predictor", "table", "--json", "--behaviors", "circle", "--budgets", "6250", "12500"]
    assert main([*argv, "--out", str(tmp_path), *TINY]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    cells = {(r["behavior"], r["kind"], r["budget_steps"]) for r in rows}
    assert cells == {("circle", k, n) for k in ("vanilla", "self_aware") for n in (6250, 12500)}
    assert all(set(r) == {"behavior", "kind", "budget_steps", "error_mps"} for r in rows)
    assert all(0 <= r["error_mps"] < 5 for r in rows)
    assert {p.name for p in tmp_path.iterdir()} == {"table_ii.md", "table_ii.csv", "table_ii.png"}


def test_a_budget_below_one_episode_is_a_one_line_error(tmp_path, capsys):
    argv = ["predictor", "table", "--budgets", "10", "--out", str(tmp_path)]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "budget 10 steps is below one episode (125)" in err and "\n" not in err
