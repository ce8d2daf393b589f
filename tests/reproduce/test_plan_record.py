"""Resuming a reproduction: the recorded plan.json against the plan asked for now."""

import dataclasses
import json

import pytest

from dyncatch.reproduce.layout import check_plan
from dyncatch.reproduce.plan import Plan


def _record(tmp_path, plan: Plan) -> dict:
    check_plan(tmp_path, plan)
    return json.loads((tmp_path / "plan.json").read_text())


def test_a_field_added_since_at_its_default_resumes_and_is_recorded(tmp_path):
    plan = Plan(seeds=2)
    recorded = _record(tmp_path, plan)
    del recorded["world"]["scene"]["scan_range_m"]  # as if the field came later
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    check_plan(tmp_path, plan)
    assert json.loads((tmp_path / "plan.json").read_text()) == plan.to_json()


def test_a_field_added_since_away_from_its_default_is_refused(tmp_path):
    recorded = _record(tmp_path, Plan(seeds=2))
    del recorded["world"]["scene"]["scan_range_m"]
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    world = Plan().world
    moved = Plan(seeds=2, world=world.replace(scene=world.scene.replace(scan_range_m=4.0)))
    with pytest.raises(ValueError, match=r"world\.scene\.scan_range_m \(None -> 4\.0\)"):
        check_plan(tmp_path, moved)


def test_a_changed_or_removed_field_is_refused(tmp_path):
    recorded = _record(tmp_path, Plan(seeds=2))
    with pytest.raises(ValueError, match=r"seeds \(2 -> 3\)"):
        check_plan(tmp_path, Plan(seeds=3))
    recorded["gone_field"] = 1
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    with pytest.raises(ValueError, match=r"gone_field \(1 -> None\)"):
        check_plan(tmp_path, Plan(seeds=2))


def test_who_runs_the_jobs_is_not_recorded_and_a_serial_folder_resumes_on_ray(tmp_path):
    recorded = _record(tmp_path, Plan(seeds=2, vmap_seeds=True))
    not_recorded = {"executor", "ray_address", "ray_workers", "ray_gpus_per_job", "out"}
    assert not not_recorded & set(recorded)
    assert recorded["vmap_seeds"] is True  # float-level differences: recorded
    ray = Plan(seeds=2, vmap_seeds=True, executor="ray", ray_address="auto", ray_gpus_per_job=0.5)
    check_plan(tmp_path, ray)
    with pytest.raises(ValueError, match=r"vmap_seeds \(True -> False\)"):
        check_plan(tmp_path, Plan(seeds=2, vmap_seeds=False))


def test_a_plan_recorded_before_vmap_seeds_resumes_only_one_seed_at_a_time(tmp_path):
    recorded = _record(tmp_path, Plan(seeds=2))
    del recorded["vmap_seeds"]  # recorded before the field: its seeds were trained one by one
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    with pytest.raises(ValueError, match=r"vmap_seeds \(None -> True\)"):
        check_plan(tmp_path, Plan(seeds=2, vmap_seeds=True))
    check_plan(tmp_path, Plan(seeds=2))
    assert json.loads((tmp_path / "plan.json").read_text())["vmap_seeds"] is False


@pytest.mark.parametrize("fig9", [False, True])
def test_a_plan_recorded_before_fig9_resumes_with_the_stage_off_or_on(tmp_path, fig9):
    """Before the field no Fig. 9 ran (off); turning the stage on only adds its files."""
    recorded = _record(tmp_path, Plan(seeds=2))
    del recorded["fig9"]
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    check_plan(tmp_path, Plan(seeds=2, fig9=fig9))
    assert json.loads((tmp_path / "plan.json").read_text())["fig9"] is fig9


def test_a_plan_recorded_before_fig9_speed_resumes_only_with_the_drawn_variant(tmp_path):
    """Before ``fig9_speed_mps`` Fig. 9 drew its speed per episode: its cells are not the
    fixed-speed ones, so only the drawn variant (None) reuses them."""
    recorded = _record(tmp_path, Plan(seeds=2))
    assert recorded["fig9_speed_mps"] == 1.8
    del recorded["fig9_speed_mps"]
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    with pytest.raises(ValueError, match=r"fig9_speed_mps \(None -> 1\.8\)"):
        check_plan(tmp_path, Plan(seeds=2))
    check_plan(tmp_path, Plan(seeds=2, fig9_speed_mps=None))
    assert json.loads((tmp_path / "plan.json").read_text())["fig9_speed_mps"] is None


def test_another_protocol_is_refused(tmp_path):
    _record(tmp_path, Plan(seeds=2))
    with pytest.raises(ValueError, match=r"behaviors"):
        check_plan(tmp_path, Plan(seeds=2, behaviors=("reactive", "random_reactive")))
    with pytest.raises(ValueError, match=r"transfer_behaviors"):
        check_plan(tmp_path, Plan(seeds=2, transfer_behaviors=()))


def _staleness(plan: Plan, on: bool) -> Plan:
    world = plan.world
    return dataclasses.replace(
        plan, world=world.replace(observation=world.observation.replace(staleness_inputs=on))
    )


def test_a_plan_recorded_with_the_staleness_inputs_is_refused_under_the_new_default(tmp_path):
    """Issue 32 made the paper's observation the default: a folder recorded with the
    staleness inputs resumes only with them, and a re-run without them names the field."""
    assert Plan().world.observation.staleness_inputs is False
    _record(tmp_path, _staleness(Plan(seeds=2), True))
    with pytest.raises(ValueError, match=r"world\.observation\.staleness_inputs \(True -> False\)"):
        check_plan(tmp_path, Plan(seeds=2))
    check_plan(tmp_path, _staleness(Plan(seeds=2), True))


@pytest.mark.parametrize("lost", ["observation", "staleness_inputs"])
def test_a_plan_recorded_before_the_staleness_field_resumes_only_with_the_inputs(tmp_path, lost):
    """Before ``observation.staleness_inputs`` existed every observation fed them: such a
    plan is read as True (``LEGACY_WORLD``), not as today's default."""
    recorded = _record(tmp_path, _staleness(Plan(seeds=2), True))
    if lost == "observation":
        del recorded["world"]["observation"]
    else:
        del recorded["world"]["observation"]["staleness_inputs"]
    (tmp_path / "plan.json").write_text(json.dumps(recorded))
    with pytest.raises(ValueError, match=r"world\.observation\.staleness_inputs \(None -> False\)"):
        check_plan(tmp_path, Plan(seeds=2))
    check_plan(tmp_path, _staleness(Plan(seeds=2), True))
    recorded = json.loads((tmp_path / "plan.json").read_text())
    assert recorded["world"]["observation"]["staleness_inputs"] is True
