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
    # seeds share one): full Table I 204 cells x 3 s + 14 x 20 s, Fig. 6 34 x 3 s + 14 x 20 s,
    # Fig. 9 24 (of 96) fewer compilations than with a program per row.
    [("full", 8165.636363636364), ("quick", 642.7090909090908)],
)
def test_the_estimate_is_the_one_printed_before_the_stage_list(profile, seconds):
    plan = PROFILES[profile]
    assert estimate_s(plan) == pytest.approx(seconds, rel=1e-12)
    assert f"{estimate_s(plan) / 60:.0f}" == f"{seconds / 60:.0f}"
    tracked = Plan(methods=tuple(m for m in METHODS if not METHODS[m].memory))
    assert estimate_s(tracked) == pytest.approx(10436.545454545456, rel=1e-12)
    # The two memory methods: two more trained methods at the same constants.
    assert estimate_s(Plan(methods=tuple(METHODS))) == pytest.approx(14502.363636363636, rel=1e-12)
    plain = dataclasses.replace(PROFILES["quick"], videos=False, fig9=False)
    assert estimate_s(plain) == pytest.approx(550.3090909090909, rel=1e-12)


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
