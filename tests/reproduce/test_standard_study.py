"""The standard-setting study's half-gap test, on hand-worked numbers
(benchmarks/standard_study.py)."""

import importlib.util
from pathlib import Path

import pytest

_PATH = Path(__file__).resolve().parents[2] / "benchmarks" / "standard_study.py"
_spec = importlib.util.spec_from_file_location("standard_study", _PATH)
study = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(study)


def _cell(times):
    return {"catch_time_s": sum(times) / len(times), "per_seed_catch_time_s": times}


def test_half_gap_is_the_midpoint_minus_the_tracker_with_a_welch_interval():
    st, sp, gt = _cell([9.0, 10.0, 11.0]), _cell([11.0, 12.0, 13.0]), _cell([6.0, 7.0, 8.0])
    got = study.half_gap(st, sp, gt)
    # D = (12 + 7) / 2 - 10 = -0.5; var = 1/3 + (1/3 + 1/3) / 4 = 0.5; t(2) = 4.303
    half = 4.303 * 0.5**0.5
    assert got["difference"] == pytest.approx(-0.5)
    assert got["ci95"] == pytest.approx([-0.5 - half, -0.5 + half], abs=1e-3)
    assert got["verdict"].startswith("unresolved")
    closer = study.half_gap(_cell([7.0, 7.1, 7.2]), sp, gt)
    assert closer["verdict"] == "more than half closed"
    assert study.half_gap(_cell([8.0]), sp, gt)["ci95"] is None


def test_the_study_trains_every_compared_method_seeds_one_by_one():
    args = study.argparse.Namespace(out=Path("x"), seeds=3, train_steps=4_000_000, episodes=500)
    argv = study.study_argv(args)
    methods = argv[argv.index("--methods") + 1 : argv.index("--seeds")]
    assert set(methods) >= {"sp_rl", "gt_rl", "st_rl", "rl"}
    assert "--no-vmap-seeds" in argv and "--no-fig9" in argv
