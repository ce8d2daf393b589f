"""The jobs a stage hands its executor: only what is unfinished, seeds grouped for one
vmap-ped run unless ``--no-vmap-seeds``, and nothing at all when everything is done. Each
job is a small typed spec: it pickles without the plan."""

import dataclasses
import json
import pickle

import pytest

from dyncatch.reproduce.jobs import EvalJob, TrainJob
from dyncatch.reproduce.layout import cell_path, fig6_evaluated_columns, run_dir
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.presentation import reproduced_methods
from dyncatch.reproduce.stages import (
    fig6_jobs,
    fig6_rows,
    grid_jobs,
    grid_rows,
    policies,
    predictor_jobs,
    train_jobs,
)
from dyncatch.reproduce.validate import validate_plan
from dyncatch.rl.methods import trained_methods

TRAINED = trained_methods(reproduced_methods())


def _finish(out, behavior, method, seed):
    d = run_dir(out, behavior, method, seed)
    d.mkdir(parents=True)
    (d / "done.json").write_text("{}")


def _seeds(job: TrainJob) -> tuple:
    first = job.runs[0]
    return first.world.target.behavior, first.method, tuple(c.seed for c in job.runs)


def test_unfinished_seeds_of_a_method_are_one_group(tmp_path):
    plan = Plan(seeds=3, behaviors=("reactive",), vmap_seeds=True)
    first, *others = TRAINED
    _finish(tmp_path, "reactive", first, 1)
    jobs = train_jobs(plan, tmp_path)
    assert [_seeds(j) for j in jobs] == [
        ("reactive", first, (0, 2)),
        *(("reactive", m, (0, 1, 2)) for m in others),
    ]
    assert all(isinstance(j, TrainJob) for j in jobs)
    assert jobs[0].name == f"train {first} on reactive, seeds 0, 2"
    # Each run is the config `dyncatch train` would get; resume is read when the job starts.
    run = jobs[0].runs[1]
    assert (run.seed, run.out, run.total_steps, run.resume) == (
        2,
        run_dir(tmp_path, "reactive", first, 2),
        plan.train_steps,
        False,
    )
    assert run.world == plan.world and run.ppo == plan.ppo


def test_without_vmap_seeds_each_seed_is_its_own_job(tmp_path):
    """One by one is the default (faster on 2 CPU cores: reproduce/estimate.py)."""
    plan = Plan(seeds=2, behaviors=("reactive",))
    assert not plan.vmap_seeds
    jobs = train_jobs(plan, tmp_path)
    assert [_seeds(j)[2] for j in jobs] == [(0,), (1,)] * len(TRAINED)


def test_a_job_pickles_small_and_without_the_plan(tmp_path):
    plan = Plan(seeds=3)
    evaluations = grid_jobs(plan, tmp_path, "t", ("reactive",), (1.8,))
    for job in [*train_jobs(plan, tmp_path), *evaluations]:
        blob = pickle.dumps(job)
        assert pickle.loads(blob).name == job.name
        assert b"dyncatch.reproduce.plan" not in blob, job.name
    eval_job = grid_jobs(plan, tmp_path, "t", ("reactive",), (1.8,))[0]
    assert isinstance(eval_job, EvalJob)
    # A method's cells (its 3 seeds, one compiled program) carry names, paths and numbers.
    assert [c.policy.seed for c in eval_job.cells] == [0, 1, 2]
    assert eval_job.name == f"t: {eval_job.cells[0].policy.name} seeds 0, 1, 2 on reactive"
    assert len(pickle.dumps(eval_job)) < 1500


def test_finished_work_makes_no_job_and_is_read_back(tmp_path):
    plan = Plan(seeds=1, behaviors=("reactive",))
    for m in TRAINED:
        _finish(tmp_path, "reactive", m, 0)
    assert train_jobs(plan, tmp_path) == []
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
    jobs = grid_jobs(plan, tmp_path, "fig6", ("reactive",), (1.0,))
    assert [j.name for j in jobs] == ["fig6: pursuit on reactive"]
    with pytest.raises(FileNotFoundError):  # nothing ran: still missing
        grid_rows(plan, tmp_path, "fig6", ("reactive",))
    missing.write_text(json.dumps([rows["pursuit"]]))
    assert grid_jobs(plan, tmp_path, "fig6", ("reactive",), (1.0,)) == []
    got = grid_rows(plan, tmp_path, "fig6", ("reactive",))
    assert [r["method"] for r in got] == [m for m, _ in policies(plan)]
    assert {r["trained_on"] for r in got if r["seed"] is not None} == {"reactive"}
    assert {r["trained_on"] for r in got if r["seed"] is None} == {None}  # baselines


def test_the_transfer_table_plays_reactive_trained_policies_in_the_columns_world(
    tmp_path, monkeypatch
):
    """Transfer (an extra table, not Fig. 6): the policy and predictor come from
    ``transfer_from``'s run, the episodes are the column's, and only trained methods play."""
    import types

    import dyncatch.reproduce.jobs as jobs_module
    from dyncatch.policies.registry import BASELINES
    from dyncatch.sim.config import WorldCfg

    world = WorldCfg()
    world = world.replace(episode=world.episode.replace(duration_s=1.0))
    plan = Plan(seeds=1, behaviors=("circle", "reactive"), episodes=4, world=world)
    assert plan.transfer_from == "reactive"
    loaded = []

    def fake_load_run(run, as_method=None, predictor=None):
        loaded.append((run, as_method, predictor))
        return types.SimpleNamespace(policy=BASELINES["pursuit"](world), world=world)

    monkeypatch.setattr(jobs_module, "load_run", fake_load_run)
    jobs = grid_jobs(plan, tmp_path, "transfer", ("circle",), (1.2,))
    assert all(c.policy.learned for j in jobs for c in j.cells)  # no baselines
    (job,) = [j for j in jobs if j.cells[0].policy.name == "sp_rl"]
    assert [c.policy.seed for c in job.cells] == [0]
    job()
    run, as_method, predictor = loaded[0]
    assert run == run_dir(tmp_path, "reactive", "sp_rl", 0)
    assert as_method == "sp_rl" and "reactive" in str(predictor)
    rows = json.loads(cell_path(tmp_path, "transfer", "circle", "sp_rl", 0).read_text())
    assert [(r["behavior"], r["speed_mps"], r["episodes"]) for r in rows] == [("circle", 1.2, 4)]
    for method, seed in policies(plan, "transfer"):  # the other cells, as finished
        path = cell_path(tmp_path, "transfer", "circle", method, seed)
        if not path.exists():
            path.write_text(json.dumps([{"method": method}]))
    got = grid_rows(plan, tmp_path, "transfer", ("circle",))
    assert {r["trained_on"] for r in got} == {"reactive"}
    assert len(got) == len(plan.method_names)


def test_a_tiny_plan_trains_per_behaviour_and_fig6_reads_each_behaviours_own_runs(tmp_path):
    """The paper's protocol: a run and a predictor per (method, behaviour), and each Fig. 6
    column's policies are that behaviour's (recorded as ``trained_on``)."""
    plan = Plan(seeds=2, behaviors=("circle", "reactive"), speeds_mps=(1.8,),
                table_i_behaviors=("reactive",))  # fmt: skip
    assert plan.fig6_columns == ("circle", "reactive")
    assert fig6_evaluated_columns(plan) == ("circle",)  # reactive: Table I's cells
    runs = {c.out for j in train_jobs(plan, tmp_path) for c in j.runs}
    assert runs == {run_dir(tmp_path, b, m, s) for b in plan.behaviors for m in TRAINED
                    for s in range(2)}  # fmt: skip
    for job in fig6_jobs(plan, tmp_path):
        for c in job.cells:
            if c.policy.learned:
                assert c.policy.run.parent.parent.name == "circle"
                assert c.policy.predictor is None or "circle" in c.policy.predictor.parent.name
    for b, table in (("circle", "fig6"), ("reactive", "table_i")):
        _write_cells(tmp_path, table, b, plan, lambda m, b=b: [
            {"behavior": b, "method": m, "speed_mps": 1.8, "success_rate": 0.5}
        ])  # fmt: skip
    rows = fig6_rows(plan, tmp_path)
    assert {(r["behavior"], r["trained_on"]) for r in rows if r["seed"] is not None} == {
        ("circle", "circle"),
        ("reactive", "reactive"),
    }
    # A column not trained on is refused, never filled with another behaviour's policies.
    with pytest.raises(ValueError, match="not trained on"):
        fig6_jobs(dataclasses.replace(plan, fig6_behaviors=("bounce",)), tmp_path)


def _write_cells(out, table, behavior, plan, rows_of):
    for method, seed in policies(plan):
        path = cell_path(out, table, behavior, method, seed)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(rows_of(method)))


def test_fig6_takes_table_i_cells_where_it_has_them_and_evaluates_the_rest(tmp_path):
    plan = Plan(seeds=1, behaviors=("reactive", "circle"), speeds_mps=(1.4, 1.8),
                table_i_behaviors=("reactive",))  # fmt: skip
    assert fig6_evaluated_columns(plan) == ("circle",)
    _write_cells(tmp_path, "table_i", "reactive", plan, lambda m: [
        {"behavior": "reactive", "method": m, "speed_mps": v, "success_rate": v / 2}
        for v in (1.4, 1.8)
    ])  # fmt: skip
    _write_cells(tmp_path, "fig6", "circle", plan, lambda m: [
        {"behavior": "circle", "method": m, "speed_mps": 1.8}
    ])  # fmt: skip
    assert fig6_jobs(plan, tmp_path) == []  # reactive is Table I's; circle's cells exist
    rows = fig6_rows(plan, tmp_path)
    n = len(policies(plan))
    assert [(r["behavior"], r["speed_mps"]) for r in rows] == [("reactive", 1.8)] * n + [
        ("circle", 1.8)
    ] * n
    assert [r["success_rate"] for r in rows[:n]] == [0.9] * n
    # At a speed Table I does not have, every column is evaluated.
    assert fig6_evaluated_columns(Plan(fig6_speed_mps=1.7, fig6_behaviors=("reactive",))) == (
        "reactive",
    )


def test_a_second_seed_set_trains_and_evaluates_its_own_seeds(tmp_path):
    """``--first-seed 10``: runs 10 and 11, predictors seeded 10, cells of seeds 10 and 11."""
    plan = Plan(seeds=2, first_seed=10, behaviors=("reactive",), vmap_seeds=False)
    assert [_seeds(j)[2] for j in train_jobs(plan, tmp_path)] == [(10,), (11,)] * len(TRAINED)
    assert {c.seed for j in predictor_jobs(plan, tmp_path) for c in (j.cfg,)} == {10}
    evaluated = {s for m, s in policies(plan) if s is not None}
    assert evaluated == {10, 11}
    with pytest.raises(ValueError, match="--first-seed"):
        validate_plan(dataclasses.replace(plan, first_seed=-1))
