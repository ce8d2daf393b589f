"""A plan split into parts, one per trained behaviour: the parts' jobs are the whole plan's
jobs, each once, and a merge of finished parts is the whole run (tests/cli/test_reproduce.py
merges a tiny reproduction)."""

import dataclasses

import pytest

from dyncatch.reproduce.parts import part_plan, part_plans
from dyncatch.reproduce.plan import PROFILES, Plan
from dyncatch.reproduce.stages import stages_of
from dyncatch.reproduce.validate import validate_plan


def _jobs(plan: Plan, out) -> list[str]:
    return [job.name for stage in stages_of(plan) for job in stage.jobs(plan, out)]


@pytest.mark.parametrize("vmap_seeds", [False, True])
def test_the_parts_jobs_are_the_whole_plans_each_once(tmp_path, vmap_seeds):
    whole = dataclasses.replace(PROFILES["full"], seeds=2, vmap_seeds=vmap_seeds)
    parts = part_plans(whole)
    assert list(parts) == list(whole.behaviors)
    validate_plan(whole)
    names = []
    for behavior, p in parts.items():
        part_jobs = _jobs(p, tmp_path)
        # Fig. 9's scene videos are filmed in the part of the whole plan's filmed behaviour
        # only (the others' are not merged).
        if behavior != whole.fig9_columns[0]:
            part_jobs = [n for n in part_jobs if not n.startswith("fig9 video")]
        names += part_jobs
    whole_jobs = _jobs(whole, tmp_path)
    assert sorted(names) == sorted(whole_jobs)
    assert len(set(whole_jobs)) == len(whole_jobs)


def test_a_part_keeps_its_behaviours_outputs_and_the_shared_ones_once():
    whole = PROFILES["full"]
    reactive, circle = part_plan(whole, "reactive"), part_plan(whole, "circle")
    assert reactive.behaviors == ("reactive",) and reactive.table_i_rows == ("reactive",)
    assert reactive.transfer_behaviors == whole.transfer_behaviors and not reactive.table_ii
    assert circle.table_i_rows == () and circle.transfer_behaviors == () and circle.table_ii
    assert circle.fig6_columns == ("circle",) and circle.fig9_columns == ("circle",)
    assert reactive.to_json()["seeds"] == whole.seeds and reactive.part is None
    # A plan of one behaviour is its own part.
    one = Plan(behaviors=("reactive",), table_i_behaviors=None)
    assert part_plan(one, "reactive").to_json() == one.to_json()
    with pytest.raises(ValueError, match="--part straight is not trained on"):
        part_plan(whole, "straight")


def test_a_part_recorded_before_a_field_existed_is_found_and_another_value_refused(tmp_path):
    """``--merge-parts`` names a part by its plan.json: one recorded before
    ``world.base.max_speed_mps`` existed (the field missing, the code's default since) is
    still its behaviour's part; with the field at another value it is no part of the plan."""
    import json

    from dyncatch.reproduce.parts import _which_part, part_plans

    plan = dataclasses.replace(PROFILES["power"], seeds=2)
    parts = part_plans(plan)
    recorded = parts["random_reactive"].to_json()
    del recorded["world"]["base"]["max_speed_mps"]
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    assert _which_part(tmp_path, parts) == "random_reactive"
    recorded["world"]["base"]["max_speed_mps"] = 1.5
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    with pytest.raises(ValueError, match="is no part of this plan.*world.base.max_speed_mps"):
        _which_part(tmp_path, parts)


def test_a_part_without_table_i_draws_no_table_i_figure(tmp_path):
    from dyncatch.reproduce.report import plot_table_i

    circle = part_plan(PROFILES["full"], "circle")
    plot_table_i([], circle.table_i_rows, tmp_path / "table_i.png")
    assert circle.table_i_rows == () and not (tmp_path / "table_i.png").exists()
