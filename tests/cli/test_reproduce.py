"""``dyncatch reproduce --quick`` at a tiny size: every file, sane values, resume, refusals."""

import json

import pytest

from dyncatch.cli.main import main
from dyncatch.reproduce.plan import ALL_BEHAVIORS, EVALUATED, LEARNED

TINY = [
    "--quick",
    "--behaviors", "reactive",
    "--train-steps", "256",
    "--episodes", "8",
    "--speeds-mps", "0.8", "1.8",
    "--predictor-steps", "2500",
    "--predictor-updates", "20",
    "--table-ii-budgets", "2500",
    "--table-ii-eval-steps", "2500",
    "--ppo.num-envs", "16",
    "--ppo.num-steps", "16",
    "--ppo.num-minibatches", "2",
    "--ppo.update-epochs", "1",
    "--ppo.hidden-sizes", "16",
    # Short episodes keep evaluation and the videos small; the pipeline is the same.
    "--world.episode.duration-s", "2.0",
]  # fmt: skip


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("quick") / "results"
    assert main(["reproduce", "--out", str(out), *TINY]) == 0
    return out


def test_every_table_and_figure_is_written(quick):
    for name in (
        "report.md",
        "results.json",
        "plan.json",
        "figures/fig5_learning_curves.png",
        "figures/fig6_high_speed.png",
        "figures/table_i.png",
        "table_ii/table_ii.md",
        "table_ii/table_ii.png",
        *(f"videos/sp_rl_{b}.gif" for b in ALL_BEHAVIORS),
    ):
        assert (quick / name).stat().st_size > 0, name
    report = (quick / "report.md").read_text()
    for heading in ("Table I: reactive", "Table II", "Fig. 5", "Fig. 6", "ordering"):
        assert heading in report, heading
    assert "paper" in report and "different" not in report.lower() or "JAX simulator" in report


def test_results_json_values_are_sane(quick):
    r = json.loads((quick / "results.json").read_text())
    cells = r["table_i"]["cells"]
    methods = {c["method"] for c in cells}
    assert methods == {*EVALUATED, "pursuit", "intercept"}
    assert len(cells) == len(methods) * 2  # two speeds, one behaviour
    for c in cells:
        lo, hi = c["success_ci95"]
        assert 0.0 <= lo <= c["success_rate"] <= hi <= 1.0
        assert 0.0 < c["catch_time_s"] <= 2.0 + 1e-6  # the 2 s episode limit
    assert len(r["table_i"]["average"]) == len(methods)
    assert {c["behavior"] for c in r["fig6"]["cells"]} == set(ALL_BEHAVIORS)
    assert len(r["training"]) == len(LEARNED)
    assert {c["claim"] for c in r["ordering_checks"]} == {
        "sp_rl > rl",
        "sp_rl > p_rl",
        "sp_rl > sp_fp",
        "sp_fp > rl",
    }
    assert all(row["error_mps"] >= 0 for row in r["table_ii"])
    assert len(r["videos"]) == len(ALL_BEHAVIORS)


def test_rerun_skips_finished_stages_and_other_plans_are_refused(quick, capsys):
    stamp = {p: p.stat().st_mtime_ns for p in (quick / "eval").rglob("*.json")}
    assert main(["reproduce", "--out", str(quick), *TINY]) == 0
    assert {p: p.stat().st_mtime_ns for p in (quick / "eval").rglob("*.json")} == stamp
    capsys.readouterr()
    assert main(["reproduce", "--out", str(quick), *TINY, "--seeds", "2"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "seeds" in err and "--out" in err


def test_bad_flags_are_one_line_errors(tmp_path, capsys):
    for argv, needle in (
        (["--seeds", "0"], "--seeds"),
        (["--behaviors", "teleport"], "--behaviors"),
        (["--train-steps", "10"], "--train-steps"),
    ):
        assert main(["reproduce", "--quick", "--out", str(tmp_path / "x"), *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and needle in err, err


def test_profiles_keep_their_network_unless_a_flag_changes_it():
    from dyncatch.cli.reproduce import ReproduceCmd, plan_of
    from dyncatch.rl.config import PPOCfg

    quick = plan_of(ReproduceCmd(quick=True))
    assert quick.ppo.hidden_sizes == (128, 128, 64) and quick.train_steps == 800_000
    assert plan_of(ReproduceCmd()).ppo.hidden_sizes == (256, 256, 128)
    changed = plan_of(ReproduceCmd(quick=True, ppo=PPOCfg(num_envs=256), seeds=2))
    assert changed.ppo.hidden_sizes == (128, 128, 64)
    assert changed.ppo.num_envs == 256 and changed.seeds == 2
    wider = plan_of(ReproduceCmd(quick=True, ppo=PPOCfg(hidden_sizes=(64, 64))))
    assert wider.ppo.hidden_sizes == (64, 64)
