"""The stage list: each stage reads only what an earlier one wrote, the log's "stage i/N"
comes from the list, and the printed estimate is the sum of the stages' estimates."""

import dataclasses

import pytest

from dyncatch.reproduce import pipeline
from dyncatch.reproduce.plan import PROFILES, Plan
from dyncatch.reproduce.presentation import PRESENTATION, paper_claims, reproduced_methods
from dyncatch.reproduce.stages import STAGES, estimate_s, stages_of
from dyncatch.rl.methods import METHODS


def test_every_input_is_an_earlier_stages_output():
    written: set[str] = set()
    for stage in STAGES:
        missing = [i for i in stage.inputs if i not in written]
        assert not missing, (stage.name, missing)
        written |= set(stage.outputs)
    assert len({s.name for s in STAGES}) == len(STAGES)


def test_switched_off_stages_leave_the_list():
    names = lambda plan: [s.name for s in stages_of(plan)]  # noqa: E731
    assert names(Plan()) == [s.name for s in STAGES]
    assert "fig9_videos" not in names(Plan(videos=False))
    assert not {"fig9", "fig9_videos"} & set(names(Plan(fig9=False)))


@pytest.mark.parametrize(
    ("profile", "seconds"),
    # The constants and counts summed per stage; evaluation counts its compilations, one per
    # (policy, behaviour) of a grid and per (policy, scene, behaviour) of Fig. 9 (blend and
    # seeds share one). A training sample at 256-256-128: (4.8 us + 5.9e-12 s x 5 467 904
    # FLOPs) x 1.2 = 44.47 us. Full (5 methods, 4 trained, 2 baselines, 10 seeds, 300
    # episodes = 0.9 s a cell): training 4 x 4 behaviours x 10 seeds x 4 M x 44.47 us + 16
    # groups x 20 s = 28 783 s; Table I 52 policies x 6 speeds x 2 rows x 0.9 + 7 x 2 x 20
    # = 842; Fig. 6 circle and bounce (reactive, random_reactive are Table I's) 2 x (52 x
    # 0.9 + 7 x 20) = 374; transfer 3 columns x (50 x 0.9 + 5 x 20) = 435; Fig. 9 22 cells
    # x 24 (scene, behaviour) x 3 s + 72 compilations x 20 = 3 024; predictors 248, Table II
    # 128, videos 40 + 60. Power (rl, sp_rl; 30 seeds; 2 behaviours): training 120 x 4 M x
    # 44.47 us + 4 x 20 = 21 427; Table I 62 x 2 x 2 x 0.9 + 4 x 2 x 20 = 383; predictors 92.
    [("full", 33932.766604799996), ("quick", 429.04096768), ("power", 21902.124953600003)],
)
def test_the_estimate_is_the_one_printed_before_the_stage_list(profile, seconds):
    plan = PROFILES[profile]
    assert estimate_s(plan) == pytest.approx(seconds, rel=1e-12)
    assert f"{estimate_s(plan) / 60:.0f}" == f"{seconds / 60:.0f}"
    tracked = Plan(methods=tuple(m for m in METHODS if not METHODS[m].memory))
    assert estimate_s(tracked) == pytest.approx(42978.408256, rel=1e-12)
    # The two memory methods: two more trained methods at the same constants.
    assert estimate_s(Plan(methods=tuple(METHODS))) == pytest.approx(60355.6915584, rel=1e-12)
    plain = dataclasses.replace(PROFILES["quick"], videos=False, fig9=False)
    assert estimate_s(plain) == pytest.approx(346.64096768, rel=1e-12)


def test_training_time_scales_with_the_networks_flops():
    """Half the FLOPs per sample: the per-sample time less by half its FLOP part only."""
    from dyncatch.reproduce.estimate import samples_per_s, training_s

    full = PROFILES["full"]
    small = dataclasses.replace(full, ppo=dataclasses.replace(full.ppo, hidden_sizes=(64, 64)))
    # 264 448 FLOPs a sample at 64-64: (4.8 us + 5.9e-12 s x 264 448) x 1.2 = 7.632 us.
    assert 1 / samples_per_s(small) == pytest.approx(7.6322e-6, rel=1e-4)
    assert training_s(small) < training_s(full) / 5


def test_the_estimate_counts_the_transfer_and_power_stages():
    full = PROFILES["full"]
    by = {s.name: s.estimate(full) for s in stages_of(full)}
    assert by["transfer"] == pytest.approx(3 * (5 * 10 * 0.9 + 5 * 20))
    no_transfer = dataclasses.replace(full, transfer_behaviors=())
    assert estimate_s(full) - estimate_s(no_transfer) == pytest.approx(by["transfer"])
    power = PROFILES["power"]
    assert [s.name for s in stages_of(power)] == ["predictors", "training", "table_i", "fig6"]
    assert power.training_runs == 2 * 2 * 30


@pytest.mark.parametrize("profile", ["full", "quick", "power"])
def test_the_profiles_validate_and_keep_the_protocol(profile):
    from dyncatch.reproduce.validate import validate_plan

    plan = validate_plan(PROFILES[profile])
    assert plan.profile == profile
    shown = (*plan.table_i_rows, *plan.fig6_columns, *(plan.fig9_columns * plan.fig9))
    assert set(shown) <= set(plan.behaviors)  # every policy on its own behaviour
    if profile == "full":
        assert set(plan.behaviors) == {"circle", "bounce", "reactive", "random_reactive"}
        assert plan.seeds >= 10 and plan.fig9_speed_mps == 1.8
        assert plan.transfer_from == "reactive" and plan.transfer_behaviors
    if profile == "power":
        assert plan.method_names == ("rl", "sp_rl") and 20 <= plan.seeds <= 30
        assert plan.speeds_mps == (1.6, 1.8)
    if profile == "quick":
        assert plan.behaviors == ("reactive",) and not plan.transfer_behaviors
    with pytest.raises(ValueError, match="not trained on"):
        validate_plan(dataclasses.replace(plan, fig6_behaviors=("straight",)))


def test_the_log_numbers_the_stages_from_the_list(tmp_path, monkeypatch):
    """With every stage finished (no jobs), the run logs 'stage i/N' for each stage of the
    plan and hands each stage's result on by its name."""
    plan = Plan(out=tmp_path, videos=False)
    got = {}
    fake = [
        dataclasses.replace(s, jobs=lambda p, o: [], collect=lambda p, o, n=s.name: n)
        for s in stages_of(plan)
    ]
    monkeypatch.setattr(pipeline, "stages_of", lambda p: tuple(fake))
    monkeypatch.setattr(
        pipeline.summary, "results", lambda p, o, outputs, c, k: got.update(outputs) or {}
    )
    monkeypatch.setattr(pipeline, "render_report", lambda r, p: "")
    logs = []
    pipeline.run(plan, "dyncatch reproduce", logs.append)
    stage_lines = [line.split("] ", 1)[1] for line in logs if "stage " in line]
    n = len(fake)
    assert stage_lines == [f"stage {i}/{n}: {s.title} (done)" for i, s in enumerate(fake, 1)]
    assert got == {s.name: s.name for s in fake}


def test_every_method_is_presented_and_the_claims_are_the_papers():
    assert list(PRESENTATION) == list(METHODS)
    assert set(METHODS) - set(reproduced_methods()) == {"st_rl", "st_fp", "rnn_rl", "rnn_sp_rl"}
    assert paper_claims() == (("sp_fp", "rl"), ("sp_rl", "rl"), ("sp_rl", "p_rl"),
                              ("sp_rl", "sp_fp"))  # fmt: skip
    assert ("st_rl", "sp_rl") in paper_claims(METHODS)
