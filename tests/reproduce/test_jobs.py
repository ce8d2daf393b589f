"""The jobs a stage hands its executor: only what is unfinished, seeds grouped for one
vmap-ped run unless ``--no-vmap-seeds``, and nothing at all when everything is done."""

import json

import pytest

from dyncatch.reproduce.layout import cell_path, run_dir
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.stages import _train_job, evaluate_grid, policies, train_policies
from dyncatch.rl.methods import trained_methods


class Recorder:
    """An executor that only records the jobs it is given."""

    def __init__(self):
        self.jobs = []

    def run(self, jobs):
        self.jobs += list(jobs)


def _finish(out, behavior, method, seed):
    d = run_dir(out, behavior, method, seed)
    d.mkdir(parents=True)
    (d / "done.json").write_text("{}")


def test_unfinished_seeds_of_a_method_are_one_group(tmp_path):
    plan = Plan(seeds=3, behaviors=("reactive",))
    first, *others = trained_methods()
    _finish(tmp_path, "reactive", first, 1)
    ex = Recorder()
    train_policies(plan, tmp_path, ex)
    assert [j.args[2:] for j in ex.jobs] == [
        ("reactive", first, (0, 2)),
        *(("reactive", m, (0, 1, 2)) for m in others),
    ]
    assert all(j.fn is _train_job for j in ex.jobs)
    assert ex.jobs[0].name == f"train {first} on reactive, seeds 0, 2"


def test_without_vmap_seeds_each_seed_is_its_own_job(tmp_path):
    plan = Plan(seeds=2, behaviors=("reactive",), vmap_seeds=False)
    ex = Recorder()
    train_policies(plan, tmp_path, ex)
    assert [j.args[4] for j in ex.jobs] == [(0,), (1,)] * len(trained_methods())


def test_finished_work_makes_no_job_and_is_read_back(tmp_path):
    plan = Plan(seeds=1, behaviors=("reactive",))
    for m in trained_methods():
        _finish(tmp_path, "reactive", m, 0)
    ex = Recorder()
    train_policies(plan, tmp_path, ex)
    assert ex.jobs == []
    # Evaluation: one cell list missing -> one job; the rest is read from the files.
    rows = {}
    for method, seed in policies(plan):
        row = {"method": method, "speed_mps": 1.0, "success_rate": 0.5}
        rows[method] = row
        path = cell_path(tmp_path, "fig6", "reactive", method, seed)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps([row]))
    missing = cell_path(tmp_path, "fig6", "reactive", "pursuit", None)
    missing.unlink()
    with pytest.raises(FileNotFoundError):  # the recorder ran nothing: still missing
        evaluate_grid(plan, tmp_path, "fig6", ("reactive",), (1.0,), ex)
    assert [j.name for j in ex.jobs] == ["fig6: pursuit on reactive"]
    missing.write_text(json.dumps([rows["pursuit"]]))
    ex.jobs.clear()
    got = evaluate_grid(plan, tmp_path, "fig6", ("reactive",), (1.0,), ex)
    assert ex.jobs == []
    assert [r["method"] for r in got] == [m for m, _ in policies(plan)]
    assert {r["trained_on"] for r in got} == {"reactive"}


def test_a_column_not_trained_on_plays_the_first_behaviours_policy_in_its_own_world(
    tmp_path, monkeypatch
):
    """Transfer (Fig. 6's columns beyond the trained behaviours): the policy and predictor
    come from the first trained behaviour's run, and the episodes are the column's."""
    import types

    import dyncatch.rl.policy as rl_policy
    from dyncatch.policies.registry import BASELINES
    from dyncatch.reproduce.stages import _eval_job
    from dyncatch.sim.config import WorldCfg

    world = WorldCfg()
    world = world.replace(episode=world.episode.replace(duration_s=1.0))
    plan = Plan(seeds=1, behaviors=("reactive",), episodes=4, world=world)
    loaded = []

    def fake_load_run(run, as_method=None, predictor=None):
        loaded.append((run, as_method, predictor))
        return types.SimpleNamespace(policy=BASELINES["pursuit"](world), world=world)

    monkeypatch.setattr(rl_policy, "load_run", fake_load_run)
    _eval_job(plan, tmp_path, "fig6", "circle", "sp_rl", 0, (1.2,))
    run, as_method, predictor = loaded[0]
    assert run == run_dir(tmp_path, "reactive", "sp_rl", 0)
    assert as_method == "sp_rl" and "reactive" in str(predictor)
    rows = json.loads(cell_path(tmp_path, "fig6", "circle", "sp_rl", 0).read_text())
    assert [(r["behavior"], r["speed_mps"], r["episodes"]) for r in rows] == [("circle", 1.2, 4)]
    for method, seed in policies(plan):  # the other cells, as finished
        path = cell_path(tmp_path, "fig6", "circle", method, seed)
        if not path.exists():
            path.write_text(json.dumps([{"method": method}]))
    got = evaluate_grid(plan, tmp_path, "fig6", ("circle",), (1.2,), Recorder())
    assert {r["trained_on"] for r in got} == {"reactive"}


def test_fig6_takes_table_i_cells_where_it_has_them_and_evaluates_the_rest(tmp_path):
    from dyncatch.reproduce.stages import fig6_evaluated_columns, fig6_grid

    plan = Plan(seeds=1, behaviors=("reactive",), speeds_mps=(1.4, 1.8),
                fig6_behaviors=("reactive", "circle"))  # fmt: skip
    assert fig6_evaluated_columns(plan) == ("circle",)
    table_i = [
        {"behavior": "reactive", "method": m, "speed_mps": v, "success_rate": v / 2}
        for m, _ in policies(plan)
        for v in (1.4, 1.8)
    ]
    for method, seed in policies(plan):
        path = cell_path(tmp_path, "fig6", "circle", method, seed)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps([{"behavior": "circle", "method": method, "speed_mps": 1.8}]))
    ex = Recorder()
    rows = fig6_grid(plan, tmp_path, table_i, ex)
    assert ex.jobs == []  # reactive is Table I's; circle's cells exist
    assert [(r["behavior"], r["speed_mps"]) for r in rows] == [("reactive", 1.8)] * len(
        policies(plan)
    ) + [("circle", 1.8)] * len(policies(plan))
    assert [r["success_rate"] for r in rows[: len(policies(plan))]] == [0.9] * len(policies(plan))
    # At a speed Table I does not have, every column is evaluated.
    assert fig6_evaluated_columns(Plan(fig6_speed_mps=1.7, fig6_behaviors=("reactive",))) == (
        "reactive",
    )
