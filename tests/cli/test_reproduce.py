"""``dyncatch reproduce --quick`` at a tiny size: every file, values that agree with an
independent evaluation, resume, refusals, and a behaviour registered at run time that shows
up in every table, figure and CLI choice with no other edit."""

import json
import os
import shutil

import jax
import pytest

from dyncatch.cli.main import main, parse
from dyncatch.policies.registry import BASELINES
from dyncatch.reproduce.presentation import PRESENTATION, paper_claims, reproduced_methods
from dyncatch.rl.methods import trained_methods
from dyncatch.sim.behaviors import BEHAVIORS, Behavior, registered_behavior

# A throw-away behaviour: straight lines at the speed cap, sliding along walls. Registering
# it is the only edit; the reproduction trains on it and every stage lists it.
STRAIGHT = Behavior(
    desired_heading=lambda target, robot, cfg, key: (target.heading_rad, target.behavior_state),
    doc="straight lines, sliding along walls (test only)",
)

TINY = [
    "--quick",
    "--behaviors", "straight",
    # Fig. 6 defaults to the behaviours trained on (each policy on its own), Table II to
    # every registered behaviour (checked below without a run): one row keeps the test
    # small. The quick profile has no transfer table (tests/reproduce/test_jobs.py has).
    "--table-ii-behaviors", "straight",
    "--train-steps", "256",
    "--episodes", "8",
    "--speeds-mps", "0.8", "1.8",
    "--predictor-steps", "2500",
    "--predictor-updates", "20",
    "--table-ii-budgets", "2500",
    "--table-ii-eval-steps", "2500",
    # 8 environments (one iteration of 8 x 32): the gated reset and arm step trace one
    # compact sub-batch besides the whole batch, not two as with 16.
    "--ppo.num-envs", "8",
    "--ppo.num-steps", "32",
    "--ppo.num-minibatches", "2",
    "--ppo.update-epochs", "1",
    "--ppo.hidden-sizes", "16",
    # Short episodes keep evaluation and the videos small; the pipeline is the same.
    "--world.episode.duration-s", "2.0",
    # Fig. 9 is tested at a tiny size on its own (tests/reproduce/test_fig9.py).
    "--no-fig9",
]  # fmt: skip
UNPROBED = [*TINY, "--no-probe-machine"]
"""The tiny plan without the machine probe (about 5 s): the module's fixture probes once."""


def straight():
    """The throw-away behaviour, registered for a ``with`` block."""
    return registered_behavior("straight", STRAIGHT)


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("quick") / "results"
    with straight():
        assert main(["reproduce", "--out", str(out), *TINY]) == 0
    return out


def test_every_table_and_figure_is_written(quick):
    behaviors = ["straight"]
    filmed = [name for name in reproduced_methods() if PRESENTATION[name].filmed]
    for name in (
        "report.md",
        "results.json",
        "plan.json",
        "figures/fig5_learning_curves.png",
        "figures/fig6_high_speed.png",
        "figures/table_i.png",
        "table_ii/table_ii.md",
        "table_ii/table_ii.png",
        *(f"videos/{m}_{b}.gif" for m in filmed for b in behaviors),
    ):
        assert (quick / name).stat().st_size > 0, name
    report = (quick / "report.md").read_text()
    for heading in ("Table I: straight", "Table II", "Fig. 5", "Fig. 6", "ordering"):
        assert heading in report, heading
    assert "not the paper's Isaac Gym set-up" in report
    # The report opens with the primary endpoints: none of the declared ones is on straight.
    assert report.index("## Primary endpoints") < report.index("## Table I")
    assert "No primary endpoint in this plan's speeds" in report
    assert "## Secondary checks" in report and "p (Holm)" in report
    r = json.loads((quick / "results.json").read_text())
    assert r["plan"]["primary_endpoints"] and not r["primary_endpoints"]["measured"]
    secondary = [c for c in r["ordering_checks"] + r["headroom"] if c["role"] == "secondary"]
    assert {c["family_size"] for c in secondary} == {len(secondary)}
    assert r["robust_summary"] == [] and r["improvement_probabilities"] == []  # one seed
    # The methods of a default reproduction, not the opt-in ones (st_rl, st_fp).
    for name in reproduced_methods():
        label = PRESENTATION[name].label
        assert f"| {label} |" in report, label
    table_ii = (quick / "table_ii" / "table_ii.md").read_text()
    assert "| straight | vanilla |" in table_ii and "| straight | self_aware |" in table_ii
    # The machine was probed (bench.speed_probe): its factors, and each stage's estimate
    # scaled by them beside the reference machine's, in results.json and the report.
    wall = r["wall"]
    speed = wall["machine_speed"]
    assert speed["compute"] > 0 and speed["compile"] > 0
    assert wall["machine_probe"]["compute_s"] > 0 and wall["machine_probe"]["compile_s"] > 0
    assert wall["stages_estimate_here_s"].keys() == wall["stages_estimate_s"].keys()
    assert "measured / estimate here |" in report and "This machine's probe" in report


def test_results_json_agrees_with_an_independent_evaluation(quick, capsys):
    r = json.loads((quick / "results.json").read_text())
    assert (r["scene"], r["setting"]) == (r["plan"]["world"]["scene"]["name"], "default")
    cells = r["table_i"]["cells"]
    assert {c["method"] for c in cells} == {*reproduced_methods(), *BASELINES}
    assert {c["behavior"] for c in cells} == {"straight"}
    assert len(cells) == (len(reproduced_methods()) + len(BASELINES)) * 2  # two speeds
    # A baseline cell equals `dyncatch eval` run by hand in the plan's world.
    plan_world = ["--world.episode.duration-s", "2.0"]
    argv = ["eval", "pursuit", "--behavior", "straight", "--speeds", "0.8", "1.8"]
    capsys.readouterr()
    with straight():
        assert main([*argv, "--episodes", "8", "--json", *plan_world]) == 0
    by_hand = json.loads(capsys.readouterr().out)["rows"]
    mine = sorted((c for c in cells if c["method"] == "pursuit"), key=lambda c: c["speed_mps"])
    assert [c["success_rate"] for c in mine] == [row["success_rate"] for row in by_hand]
    assert [c["catch_time_s"] for c in mine] == pytest.approx(
        [row["catch_time_s"] for row in by_hand]
    )
    # The plan's 2 s episodes: nothing is slower than the limit, and a failure counts as it.
    for c in cells:
        assert c["catch_time_s"] <= 2.0 + 1e-6
        if c["success_rate"] == 0.0:
            assert c["catch_time_s"] == pytest.approx(2.0)
    assert {c["behavior"] for c in r["fig6"]["cells"]} == {"straight"}
    assert [(t["behavior"], t["method"]) for t in r["training"]] == [
        ("straight", m) for m in trained_methods(reproduced_methods())
    ]
    assert {c["claim"] for c in r["ordering_checks"]} == {f"{a} > {b}" for a, b in paper_claims()}
    assert {(row["behavior"], row["kind"]) for row in r["table_ii"]} >= {
        ("straight", "vanilla"),
        ("straight", "self_aware"),
    }
    assert r["plan"]["world"]["episode"]["duration_s"] == 2.0
    assert r["plan"]["behaviors"] == ["straight"]


def test_rerun_resumes_and_other_plans_or_worlds_are_refused(quick, capsys):
    stamp = {p: p.stat().st_mtime_ns for p in (quick / "eval").rglob("*.json")}
    with straight():
        assert main(["reproduce", "--out", str(quick), *UNPROBED]) == 0
        assert {p: p.stat().st_mtime_ns for p in (quick / "eval").rglob("*.json")} == stamp
        for extra, needle in (
            (["--seeds", "2"], "seeds (1 -> 2)"),
            (["--world.target.evade-radius-m", "1.5"], "world.target.evade_radius_m (3.0 -> 1.5)"),
        ):
            capsys.readouterr()
            assert main(["reproduce", "--out", str(quick), *TINY, *extra]) == 2
            err = capsys.readouterr().err.strip()
            assert err.count("\n") == 0 and needle in err and "--out" in err, err


def test_a_behaviour_registered_at_run_time_is_a_cli_choice(capsys):
    with pytest.raises(SystemExit):
        main(["reproduce", "--quick", "--behaviors", "straight"])
    assert "random_reactive" in capsys.readouterr().err
    with straight():
        _, plan = parse(["reproduce", "--quick", "--behaviors", "straight"])
        assert plan.behaviors == ("straight",) and "straight" in plan.table_ii_rows
        # Fig. 6 and the videos cover the behaviours trained on (each policy on its own),
        # and Table II every registered behaviour, in every profile.
        _, full = parse(["reproduce", "--behaviors", "straight"])
        assert full.fig6_columns == ("straight",) and "straight" in full.table_ii_rows
        _, cfg = parse(["train", "--behavior", "straight"])
        assert cfg.world.target.behavior == "straight"
        _, table = parse(["predictor", "table", "--budgets", "2500"])
        assert "straight" in table.behaviors
    assert "straight" not in parse(["predictor", "table"])[1].behaviors


def test_bad_flags_are_refused_naming_the_flag(tmp_path, capsys):
    for argv, needle in (
        (["--seeds", "0"], "--seeds"),
        (["--ray-address", "auto"], "--executor ray"),
        (["--ray-workers", "2"], "--ray-workers"),
        (["--train-steps", "10"], "--train-steps"),
        (["--world.target.circle-radius-m", "20"], "circle_radius_m"),
    ):
        assert main(["reproduce", "--quick", "--out", str(tmp_path / "x"), *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and needle in err, err
    assert not (tmp_path / "x").exists()  # nothing written for a refused plan
    with pytest.raises(SystemExit):
        main(["reproduce", "--quick", "--behaviors", "teleport"])
    err = capsys.readouterr().err
    assert "teleport" in err and "reactive" in err


def test_a_profile_sets_defaults_and_every_flag_given_overrides_it():
    quick = parse(["reproduce", "--quick"])[1]
    assert quick.ppo.hidden_sizes == (128, 128, 64) and quick.train_steps == 500_000
    assert parse(["reproduce"])[1].ppo.hidden_sizes == (128, 128, 64)
    changed = parse(["reproduce", "--quick", "--ppo.num-envs", "256", "--seeds", "2"])[1]
    assert (changed.ppo.num_envs, changed.seeds, changed.train_steps) == (256, 2, 500_000)
    wide = parse(["reproduce", "--quick", "--ppo.hidden-sizes", "256", "256", "128"])[1]
    assert wide.ppo.hidden_sizes == (256, 256, 128) and wide.quick
    # A flag equal to the library default still overrides the profile (it was lost before).
    full_steps = parse(["reproduce", "--quick", "--train-steps", "4000000"])[1]
    assert full_steps.train_steps == 4_000_000 and full_steps.quick
    power = parse(["reproduce", "--power", "--seeds", "20"])[1]
    assert power.profile == "power" and power.method_names == ("rl", "sp_rl")
    assert (power.seeds, power.speeds_mps, power.fig9) == (20, (1.6, 1.8), False)


def test_the_throwaway_behaviour_steps_like_a_registered_one():
    from dyncatch.sim import env
    from dyncatch.sim.config import WorldCfg

    with straight():
        cfg = WorldCfg().with_behavior("straight").with_speed(1.0)
        s = env.reset(jax.random.key(0), cfg)
        s2 = jax.jit(env.step)(s, jax.numpy.zeros(3), cfg)[0]
        # Stored positions are relative to the robot: compare world positions.
        world = lambda st: st.target.xy_m + st.origin_xy_m  # noqa: E731
        moved = float(jax.numpy.linalg.norm(world(s2) - world(s)))
        assert moved == pytest.approx(1.0 * 0.02, abs=1e-5)  # one 20 ms step at 1 m/s
    assert "straight" not in BEHAVIORS


def test_executor_ray_without_ray_names_the_extra(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(__import__("sys").modules, "ray", None)  # import ray -> ImportError
    assert main(["reproduce", "--quick", "--out", str(tmp_path / "x"), "--executor", "ray"]) == 2
    err = capsys.readouterr().err
    assert "dyncatch[ray]" in err and "--executor ray" in err, err


# Fields of results.json that differ between two runs of one plan by their nature: the
# command line (--executor ray) and wall seconds (of the whole reproduction, of a training
# run and of a predictor's training). Everything else, commit and machine included, is equal.
UNEQUAL = ("command", "wall")


def _comparable(results: dict) -> dict:
    r = {k: v for k, v in results.items() if k not in UNEQUAL}
    r["training"] = [
        {**t, "wall_s": None, "to_0.9": {**t["to_0.9"], "time_s": None}} for t in r["training"]
    ]
    r["predictors"] = [{**p, "seconds": None} for p in r["predictors"]]
    return r


def _report_lines(path) -> list[str]:
    skip = ("- command:", "- wall time:")
    lines, section = [], ""
    for line in path.read_text().splitlines():
        section = line if line.startswith("## ") else section
        if line.startswith(skip) or section == "## Wall time by stage":
            continue
        # The Fig. 5 table's last three columns are wall seconds.
        fig5_row = section.startswith("## Fig. 5") and line.startswith("| straight |")
        lines.append(line.rsplit("|", 4)[0] if fig5_row else line)
    return lines


def _dies_once(marker: str) -> None:
    """A job whose first attempt kills its worker process (as a lost node would)."""
    if not os.path.exists(marker):
        open(marker, "w").close()
        os._exit(1)
    with open(marker, "a") as f:
        f.write("done")


def _write_niceness(path: str) -> None:
    with open(path, "w") as f:
        f.write(str(os.nice(0)))


def _raises(marker: str) -> None:
    with open(marker, "a") as f:
        f.write("x")
    raise RuntimeError("a bug")


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray of 2 workers started by the executor, kept for the module: the grid
    below reuses it instead of starting its own."""
    import ray

    from dyncatch.reproduce.executors import RayExecutor

    logs: list[str] = []
    executor = RayExecutor(workers=2, log=logs.append)
    assert ray.cluster_resources()["CPU"] == 2
    yield executor, logs
    executor.close()


def test_a_dead_ray_worker_is_retried_and_a_failing_job_keeps_the_others(local_ray, tmp_path):
    from tests.reproduce.test_executors import Call

    executor, logs = local_ray
    died, failed = str(tmp_path / "died"), str(tmp_path / "failed")
    with pytest.raises(RuntimeError, match=r"(?s)1 job\(s\) failed.*raises: .*a bug"):
        executor.run([Call("dies once", _dies_once, (died,)), Call("raises", _raises, (failed,))])
    # The killed attempt was re-run to the end; the raising job ran once, not retried.
    assert open(died).read() == "done"
    assert open(failed).read() == "x"
    assert "done: dies once" in logs and "failed: raises" in logs


def test_a_local_rays_workers_run_at_the_drivers_niceness(local_ray, tmp_path):
    """The driver's, not 15 below it (Ray's default), at which any other busy process
    starves the jobs."""
    from tests.reproduce.test_executors import Call

    executor, _ = local_ray
    path = str(tmp_path / "nice")
    executor.run([Call("niceness", _write_niceness, (path,))])
    assert int(open(path).read()) == os.nice(0)


def test_a_ray_grid_gives_the_serial_report(quick, local_ray, tmp_path):
    """The tiny reproduction again on the local Ray, with one job of each kind left to do:
    a predictor, a training run, evaluation cells (one of them of the retrained run)."""
    from dyncatch.reproduce.layout import cell_path, predictor_dir, run_dir

    out = tmp_path / "ray"
    shutil.copytree(quick, out)
    shutil.rmtree(predictor_dir(out, "straight", "vanilla"))
    shutil.rmtree(run_dir(out, "straight", "rl", 0))
    for method, seed in (("rl", 0), ("pursuit", None)):
        cell_path(out, "table_i", "straight", method, seed).unlink()
    for name in ("results.json", "report.md", "wall.json"):
        (out / name).unlink()
    with straight():
        assert main(["reproduce", "--out", str(out), *UNPROBED, "--executor", "ray"]) == 0
    serial = json.loads((quick / "results.json").read_text())
    ray = json.loads((out / "results.json").read_text())
    assert _comparable(ray) == _comparable(serial)
    assert _report_lines(out / "report.md") == _report_lines(quick / "report.md")
    # The retrained run wrote what the serial one did: a checkpoint, logs and done marker.
    for name in ("checkpoint.safetensors", "metrics.csv", "tb", "done.json"):
        assert (run_dir(out, "straight", "rl", 0) / name).exists(), name


def test_a_merge_of_finished_parts_is_the_whole_run_without_checkpoints(quick, tmp_path, capsys):
    """The tiny plan has one behaviour, so its one part is the whole plan: merging the
    finished run (whose checkpoints the merge leaves behind) runs no job and writes the
    same results; the wall time is the parts' sum. A folder of another plan, or an
    unfinished part, is refused naming the flag."""
    out = tmp_path / "merged"
    with straight():
        assert main(["reproduce", "--out", str(out), *TINY, "--merge-parts", str(quick)]) == 0
    assert not list(out.rglob("checkpoint.safetensors")) and not list(out.rglob("tb"))
    merged = json.loads((out / "results.json").read_text())
    whole = json.loads((quick / "results.json").read_text())
    assert _comparable(merged) == _comparable(whole)
    assert _report_lines(out / "report.md") == _report_lines(quick / "report.md")
    [part] = json.loads((out / "parts.json").read_text())
    assert part["behavior"] == "straight" and part["wall_s"] == pytest.approx(
        json.loads((quick / "wall.json").read_text())["total_s"]
    )
    assert merged["wall"]["total_s"] >= part["wall_s"]
    capsys.readouterr()
    with straight():
        other = [*TINY, "--episodes", "9", "--merge-parts", str(quick)]
        assert main(["reproduce", "--out", str(tmp_path / "x"), *other]) == 2
        assert "is no part of this plan" in capsys.readouterr().err
        unfinished = tmp_path / "unfinished"
        shutil.copytree(quick, unfinished)
        (unfinished / "results.json").unlink()
        args = [*TINY, "--merge-parts", str(unfinished)]
        assert main(["reproduce", "--out", str(tmp_path / "y"), *args]) == 2
        assert "part straight is unfinished" in capsys.readouterr().err
