"""The fidelity study's settings and its summary arithmetic (benchmarks/fidelity_study.py)."""

import importlib.util
from pathlib import Path

import pytest

from dyncatch.reproduce.readings import READINGS, setting_name

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "fidelity_study.py"
_spec = importlib.util.spec_from_file_location("fidelity_study", _PATH)
study = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(study)


def test_every_setting_names_known_readings_once():
    names = [setting_name(s) for s in study.SETTINGS]
    assert len(set(names)) == len(names)
    assert names[0] == "default"  # the standard setting
    for setting in study.SETTINGS[1:]:
        on_baseline = setting[: len(study.BASELINE)] == study.BASELINE
        assert on_baseline or setting in study.CANDIDATES, setting
        assert all(r in READINGS for r in setting), setting


def cell(method, success, time_s, seeds):
    return {
        "behavior": "reactive",
        "method": method,
        "speed_mps": 1.8,
        "episodes": 500,
        "success_rate": success,
        "catch_time_s": time_s,
        "per_seed_success": seeds,
        "per_seed_catch_time_s": [time_s - 0.5, time_s + 0.5],
    }


def test_the_verdict_names_the_best_rival_and_the_share_sp_rl_recovers():
    cells = [
        cell("rl", 0.50, 15.0, [0.4, 0.6]),
        cell("p_rl", 0.70, 13.0, [0.6, 0.8]),
        cell("sp_rl", 0.80, 12.0, [0.79, 0.81]),
        cell("gt_rl", 1.00, 9.0, [1.0, 1.0]),
    ]
    (row,) = study.verdicts({"table_i": {"cells": cells}})
    assert row["best_non_oracle"] == "sp_rl"
    assert row["oracle_gap_success"]["difference"] == pytest.approx(0.20)
    assert row["oracle_gap_time"]["difference"] == pytest.approx(3.0)
    assert row["sp_rl_vs_rl_time"]["difference"] == pytest.approx(3.0)
    # (0.8 - 0.5) / (1.0 - 0.5) and (15 - 12) / (15 - 9).
    assert row["sp_rl_share_of_oracle"] == {
        "success": pytest.approx(0.6),
        "catch_time": pytest.approx(0.5),
    }


def test_no_share_where_the_oracle_has_no_advantage():
    same = study.oracle_share(cell("rl", 1.0, 8.0, [1, 1]), cell("sp_rl", 1.0, 8.0, [1, 1]),
                              cell("gt_rl", 1.0, 8.0, [1, 1]))  # fmt: skip
    assert same == {"success": None, "catch_time": None}
