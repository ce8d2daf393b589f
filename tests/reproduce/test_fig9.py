"""The Fig. 9 stage at a tiny size: its cells agree with a direct evaluation, and it writes
its table, figure and GIF; the paper's values stand beside ours."""

import dataclasses
import json

import jax
import pytest

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.blend import blended
from dyncatch.policies.registry import BASELINES
from dyncatch.reproduce import fig9, fig9_report
from dyncatch.reproduce.executors import SerialExecutor
from dyncatch.reproduce.paper import PAPER_FIG9_SCENES, PAPER_FIG9_SUCCESS
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.stages import estimate_s
from dyncatch.reproduce.validate import validate_plan

PLAN = Plan(
    quick=True,
    fig9_scenes=("room_4",),
    fig9_behaviors=("reactive",),
    fig9_episodes=4,
    fig9_duration_s=1.0,
)
# One row keeps the test to one compiled evaluation; the learned rows need trained runs
# (the tiny reproduction leaves Fig. 9 off).
ROWS = (fig9.row_named("pursuit+blend"),)
EXECUTOR = SerialExecutor(log=lambda msg: None)


@pytest.fixture(scope="module")
def stage(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig9")
    validate_plan(PLAN)
    EXECUTOR.run(fig9.cell_jobs(PLAN, out, ROWS))
    assert fig9.cell_jobs(PLAN, out, ROWS) == []  # finished: read back
    return out, fig9.cell_rows(PLAN, out, ROWS)


def test_cells_agree_with_a_direct_evaluation(stage):
    _, rows = stage
    assert [(r["scene"], r["behavior"], r["method"]) for r in rows] == [
        ("room_4", "reactive", "pursuit+blend"),
    ]
    speed = PLAN.fig9_speed_mps
    assert speed == 1.8  # the paper's high speed, fixed, and recorded in each cell
    world = fig9.scene_world(PLAN.world, "room_4", "reactive", PLAN.fig9_duration_s, speed)
    assert world.episode.duration_s == 1.0 and world.scene.name == "room_4"
    assert world.target.speed_min_mps == world.target.speed_max_mps == 1.8
    assert [r["speed_mps"] for r in rows] == [1.8]
    policy = blended(BASELINES["pursuit"](world), world)
    key = fig9.cell_key("room_4", "reactive")
    direct = jax.device_get(run_episodes(policy, key, world, 4, contact_tol_m=fig9.CONTACT_TOL_M))
    assert rows[0]["success_rate"] == pytest.approx(direct["success"].mean())
    assert rows[0]["contacts_per_episode"] == pytest.approx(direct["contacts"].mean())
    for r in rows:
        assert 0.0 <= r["catch_time_s"] <= 1.0 + 1e-6 and r["contacts_per_episode"] >= 0.0


def test_table_and_figure_are_written(stage):
    out, rows = stage
    cells = fig9.summarize(rows)
    assert {c["method"] for c in cells} == {"pursuit+blend"}
    assert all(c["ci_over"] == "episodes" and c["seeds"] == 0 for c in cells)
    path = out / "fig9.png"
    fig9_report.plot(cells, PLAN.fig9_scenes, PLAN.fig9_behaviors, path)
    assert path.stat().st_size > 0
    text = "\n".join(fig9_report.markdown({"cells": cells, "videos": []}, PLAN))
    assert "| pursuit (scripted) + blend |" in text and "### reactive" in text
    paper = fig9_report.paper_json()
    assert {(p["scene"], p["behavior"]) for p in paper["success"]} == set(PAPER_FIG9_SUCCESS)
    json.dumps(paper)


@pytest.mark.extended  # a second compiled rollout and a GIF: about 15 s more on 2 cores
def test_a_gif_per_scene(stage):
    out, _ = stage
    EXECUTOR.run(fig9.video_jobs(PLAN, out, row="pursuit+blend"))
    clips = fig9.videos(PLAN, out)
    assert (out / "videos" / "fig9_room_4.gif").stat().st_size > 0
    assert [c["scene"] for c in clips] == ["room_4"]
    text = "\n".join(fig9_report.markdown({"cells": [], "videos": clips}, PLAN))
    assert "fig9_room_4.gif" in text


def test_rows_follow_the_plan_and_names_round_trip():
    """A method beyond the paper that PPO trains (st_rl) gains a blended row when the plan
    selects it; st_fp (gt_rl's policy) and the default plan's methods add none."""
    assert fig9.rows_of(Plan()) == fig9.FIG9_ROWS
    assert Plan().fig9_scenes == PAPER_FIG9_SCENES  # the paper's six, in one place
    tracked = Plan(methods=("rl", "p_rl", "sp_fp", "sp_rl", "gt_rl", "st_fp", "st_rl"))
    assert fig9.rows_of(tracked) == (*fig9.FIG9_ROWS, fig9.Fig9Row("st_rl", True))
    assert estimate_s(tracked) > estimate_s(Plan())
    for row in fig9.rows_of(tracked):
        assert fig9.row_named(row.name) == row
    with pytest.raises(ValueError, match="POLICY\\+blend"):
        fig9.row_named("sp_rl+fast")


def test_a_policys_rows_and_seeds_are_one_job_and_finished_cells_none(tmp_path):
    """A job per (scene, behaviour, policy): sp_rl with and without the blend over its seeds
    shares one compiled program; a written cell file leaves its job."""
    plan = Plan(seeds=2, fig9_scenes=("room_4",), fig9_behaviors=("reactive",))
    jobs = fig9.cell_jobs(plan, tmp_path, fig9.FIG9_ROWS)
    assert [j.name for j in jobs] == [
        "fig9: sp_rl, sp_rl+blend seeds 0, 1 in room_4 on reactive",
        "fig9: pursuit+blend in room_4 on reactive",
        "fig9: intercept+blend in room_4 on reactive",
    ]
    first = jobs[0].cells[0]
    assert (first.row, first.deployed.blend, first.deployed.policy.seed) == ("sp_rl", False, 0)
    assert first.deployed.speed_mps == 1.8 and first.trained_on == "reactive"
    assert first.deployed.policy.run.parent.parent.name == "reactive"  # its own behaviour
    drawn = dataclasses.replace(plan, fig9_speed_mps=None)  # the named variant
    assert fig9.cell_jobs(drawn, tmp_path, fig9.FIG9_ROWS)[0].cells[0].deployed.speed_mps is None
    world = fig9.scene_world(plan.world, "room_4", "reactive", None, None)
    assert world.target.speed_min_mps < world.target.speed_max_mps
    first.path.parent.mkdir(parents=True)
    first.path.write_text("{}")
    again = fig9.cell_jobs(plan, tmp_path, fig9.FIG9_ROWS)
    assert [(c.row, c.deployed.policy.seed) for c in again[0].cells] == [
        ("sp_rl", 1),
        ("sp_rl+blend", 0),
        ("sp_rl+blend", 1),
    ]
