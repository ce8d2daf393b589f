"""``benchmarks/score_table.py``: predictor score's rows as a matrix, evaders by folder."""

import json

import pytest

from .benchmark_scripts import load_benchmark

score_table = load_benchmark("score_table")


def _row(trained_on, t_params, behavior, params, kind, error, samples=10):
    return {
        "trained_on": trained_on,
        "trained_on_params": t_params,
        "behavior": behavior,
        "behavior_params": params,
        "kind": kind,
        "error_mps": error,
        "eval_samples": samples,
    }


EV = {"evader_checkpoint": "/runs/ev_a/", "evader_sample": False}


def test_a_matrix_with_evaders_named_by_folder_and_the_diagonal_marked(tmp_path, capsys):
    rows = [
        _row("reactive", {"evade_radius_m": 3.0}, "reactive", {}, "vanilla", 0.3204, 7),
        _row("reactive", {}, "learned", EV, "vanilla", 0.8),
        _row("learned", EV, "learned", EV, "self_aware", 0.25),
    ]
    text = score_table.matrix(rows)
    assert text.splitlines()[:4] == [
        "| trained on | kind | reactive | ev_a |",
        "|---|---|---:|---:|",
        "| reactive | vanilla | **0.320** | 0.800 |",
        "| ev_a | self_aware | - | **0.250** |",
    ]
    assert "Held-out samples: reactive 7, ev_a 10." in text
    path = tmp_path / "rows.jsonl"
    path.write_text("".join(json.dumps(r) + "\n" for r in rows))
    assert score_table.main([str(path), "--out", str(tmp_path / "t.md")]) == 0
    assert capsys.readouterr().out == text == (tmp_path / "t.md").read_text()


def test_a_league_is_named_by_its_members():
    params = {"league_behaviors": ["reactive"], "league_evaders": ["/r/ev_a", "/r/ev_b/"]}
    assert score_table.target_name("league", params) == "league(reactive+ev_a+ev_b)"
    assert score_table.target_name("circle", {"circle_radius_m": 5.0}) == "circle"


def test_a_cell_scored_twice_is_refused():
    row = _row("circle", {}, "bounce", {}, "vanilla", 0.3)
    with pytest.raises(ValueError, match="twice"):
        score_table.matrix([row, row])
