"""The stage list: each stage reads only what an earlier one wrote, the log's "stage i/N"
comes from the list, and the printed estimate is the sum of the stages' estimates."""

import dataclasses
import time

import pytest

from dyncatch.bench.speed_probe import REFERENCE, MachineSpeed
from dyncatch.policies.registry import BASELINES
from dyncatch.reproduce import pipeline
from dyncatch.reproduce.plan import PROFILES, Plan
from dyncatch.reproduce.presentation import PRESENTATION, paper_claims, reproduced_methods
from dyncatch.reproduce.stages import STAGES, estimate_s, stages_of
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.methods import METHODS
from dyncatch.utils.files import read_json, write_json


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
    # (policy, behaviour) of a grid (5 s) and per (policy, scene, behaviour) of Fig. 9 (6 s;
    # blend and seeds share one). A training sample at 128-128-64 (the standard, 13 inputs:
    # 1 397 120 FLOPs), one seed at a time (the default): (4.8 us + 5.9e-12 s x 1 397 120)
    # x 0.937 = 12.221 us, + 1.83 us with a learned predictor; a 4 M-step run has 245
    # iterations of 16 384 samples and 26 periodic evaluations of 200 episodes (5 200:
    # 11.544 s at 2.22 s per 1000, 19.448 s at 3.74). The S seeds of a (method, behaviour):
    # S x (48.885 s + 11.544 s) + 13 s, with a predictor S x (56.205 s + 19.448 s) + 13 s.
    # Full (5 methods, 4 trained, 2 baselines, 10 seeds, 300 episodes = 0.45 + 0.3 x 1.08 =
    # 0.774 s a cell): training 4 behaviours x (rl, gt_rl 617.29 s + p_rl, sp_rl 769.53 s)
    # x 2 = 11 094.6 s; Table I 52 policies x 6 speeds x
    # 2 rows x 0.774 + 7 x 2 x 5 = 553; Fig. 6 circle and bounce (reactive, random_reactive
    # are Table I's) 2 x (52 x 0.774 + 7 x 5) = 150.5; transfer 3 columns x (50 x 0.774 +
    # 5 x 5) = 191.1; Fig. 9 per (scene, behaviour), 500 episodes of 40 s: sp_rl 10 seeds x
    # (0.45 + 0.5 x 4.7) + sp_rl+blend 10 x (0.45 + 0.5 x 16.1) + 2 baselines x 8.5 + 3
    # compilations x 6 = 148.0, x 24 = 3 552; predictors 2 kinds x 4 x 2 M x 8 s/M + 4 x 2
    # = 136, Table II 128, videos 4 x 8 + 6 x 8. Quick (one seed, 200 episodes = 0.666 s a
    # cell): training 0.5 M samples (31 iterations, 5 evaluations) 2 x (6.111 + 2.22 + 13)
    # + 2 x (7.026 + 3.74 + 13) = 90.19; Table I 7 x 6 x 0.666 + 7 x 5 = 63.0; Fig. 9 (100
    # episodes) 0.45 + 0.47 + 0.45 + 1.61 + 2 x 2.06 + 3 x 6 = 25.1; predictors 4 + 2 + 4 (4 M
    # Table II steps: 32); videos 8 + 8. Power (rl, sp_rl; 30 seeds; 2 behaviours): training
    # 2 x (1 825.9 + 2 282.6) = 8 216.9; Table I 62 x 2 x 2 x 0.774 + 4 x 2 x 5 = 232;
    # predictors 2 x 16 + 2 x 2.
    [("full", 15885.16303744), ("quick", 236.264596992), ("power", 8484.89527808)],
)
def test_the_estimate_is_the_one_printed_before_the_stage_list(profile, seconds):
    plan = PROFILES[profile]
    assert estimate_s(plan) == pytest.approx(seconds, rel=1e-12)
    assert f"{estimate_s(plan) / 60:.0f}" == f"{seconds / 60:.0f}"
    tracked = Plan(methods=tuple(m for m in METHODS if not METHODS[m].memory))
    assert estimate_s(tracked) == pytest.approx(21544.4507968, rel=1e-12)
    # The two memory methods: two more trained methods at the same constants.
    assert estimate_s(Plan(methods=tuple(METHODS))) == pytest.approx(31792.90631552, rel=1e-12)
    plain = dataclasses.replace(PROFILES["quick"], videos=False, fig9=False)
    assert estimate_s(plain) == pytest.approx(195.164596992, rel=1e-12)


def test_the_constants_give_back_the_measurements_they_come_from():
    """Each evaluation constant solves measured stage times (estimate.py's docstrings):
    the model, applied to the measured work, gives those times back."""
    from dyncatch.reproduce import estimate as e

    cell = lambda episodes: e.EST_EVAL_S_PER_CELL + episodes / 1000 * e.EST_EVAL_S_PER_1000_EPISODES  # noqa: E731
    # The quick run's sp_rl Table I job: 6 cells x 200 episodes, no compilation: 4 s.
    assert 6 * cell(200) == pytest.approx(4.0, abs=0.05)
    # The full run's Table I: 204 cells x 1000 episodes, 84 compilations: 12.2 min.
    assert 204 * cell(1000) + 84 * e.EST_EVAL_COMPILE_S == pytest.approx(732, rel=0.02)
    # The quick run's Table I jobs with a compilation: 7-9 s.
    assert 7.0 <= 6 * cell(200) + e.EST_EVAL_COMPILE_S <= 9.0

    # The power run's groups on random_reactive (30 seeds x 4 M at 128-128-64 as one vmap-ped
    # computation, uncontended): rl 2 334 s, sp_rl 2 792 s, within 1 % (the constants were
    # fit to them).
    power = dataclasses.replace(PROFILES["power"], vmap_seeds=True)
    assert e.group_s(power, "rl") == pytest.approx(2334, rel=0.01)
    assert e.group_s(power, "sp_rl") == pytest.approx(2792, rel=0.01)
    # A training run of the quick profile (0.5 M samples at 128-128-64): 21-24 s (rl 21.3 s,
    # the predictor methods 23.8 s); a vmap-ped group of the 3-seed full run at an older
    # commit (3 seeds x 4 M at 256-256-128, 15 inputs then): 551-582 s, the estimate 510 s
    # (rl, 7 % under) to 556 s (sp_rl).
    wide = PPOCfg(hidden_sizes=(256, 256, 128))
    quick = PROFILES["quick"]
    full = dataclasses.replace(PROFILES["full"], seeds=3, ppo=wide, vmap_seeds=True)
    assert 21 <= e.group_s(quick, "rl") <= e.group_s(quick, "sp_rl") <= 24
    assert 0.9 * 551 <= e.group_s(full, "rl") <= e.group_s(full, "sp_rl") <= 582
    # One seed's rate over a vmap-ped group's, from the benchmark the group cost comes from:
    # 83 730 samples/s at 1 seed, 67 568 at 10, 62 130 at 30.
    one = dataclasses.replace(PROFILES["full"], seeds=1)
    for seeds, measured in ((10, 67568), (30, 62130)):
        group = dataclasses.replace(one, seeds=seeds, vmap_seeds=True)
        ratio = e.samples_per_s(group) / e.samples_per_s(one)
        assert ratio == pytest.approx(measured / 83730, rel=0.01)

    # Fig. 9's rates, from benchmarks/fig9_episode_cost.py (sp_rl in room_8, 500 episodes
    # of 40 s): 4.65 and 4.75 s plain, 16.0 and 16.1 s blended per 1000 episodes.
    assert 4.65 <= e.EST_SCENE_S_PER_1000_EPISODES[False] <= 4.75
    assert 16.0 <= e.EST_SCENE_S_PER_1000_EPISODES[True] <= 16.1

    # The scene compilation was fit on older code at the rates measured then (13 and 18 s):
    # the quick run's Fig. 9 jobs (100 episodes), sp_rl plain and blended 10 s, a baseline
    # blended 8 s; the full run's Fig. 9, 24 x (3 seeds plain and blended, 2 baselines) at
    # 500 episodes and 96 compilations, 37.3 min less its 6 videos.
    def then(blend: bool, episodes: int) -> float:
        return e.EST_EVAL_S_PER_CELL + episodes / 1000 * (18.0 if blend else 13.0)

    compiled = e.EST_SCENE_COMPILE_S
    assert then(False, 100) + then(True, 100) + compiled == pytest.approx(10, abs=0.5)
    assert then(True, 100) + compiled == pytest.approx(8, abs=0.5)
    per = 3 * then(False, 500) + 3 * then(True, 500) + 2 * then(True, 500)
    assert 24 * per + 96 * compiled == pytest.approx(37.3 * 60 - 6 * e.EST_VIDEO_S, rel=0.02)


def test_training_time_scales_with_the_networks_flops():
    """Half the FLOPs per sample: the per-sample time less by half its FLOP part only."""
    from dyncatch.reproduce.estimate import samples_per_s

    full = PROFILES["full"]
    wide = dataclasses.replace(full, ppo=PPOCfg(hidden_sizes=(256, 256, 128)))
    small = dataclasses.replace(full, ppo=dataclasses.replace(full.ppo, hidden_sizes=(64, 64)))
    # 259 584 FLOPs a sample at 64-64 (13 inputs): (4.8 us + 5.9e-12 s x 259 584) x 0.937
    # = 5.933 us; 5 470 000 at 256-256-128: 34.74 us.
    assert 1 / samples_per_s(small) == pytest.approx(5.9327e-6, rel=1e-4)
    assert samples_per_s(small) > 5 * samples_per_s(wide)
    # The plan's own world sets the input width: with the staleness inputs (15 inputs,
    # 1 406 848 FLOPs) (4.8 us + 5.9e-12 s x 1 406 848) x 0.937 = 12.275 us a sample.
    obs = dataclasses.replace(full.world.observation, staleness_inputs=True)
    fed = dataclasses.replace(full, world=dataclasses.replace(full.world, observation=obs))
    assert 1 / samples_per_s(fed) == pytest.approx(12.2751e-6, rel=1e-4)


def test_the_estimate_counts_the_transfer_and_power_stages():
    full = PROFILES["full"]
    by = {s.name: s.estimate(full) for s in stages_of(full)}
    # 5 methods x 10 seeds at 300 episodes (0.774 s a cell) and 5 compilations, 3 columns.
    assert by["transfer"] == pytest.approx(3 * (5 * 10 * 0.774 + 5 * 5))
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
    # The machine probe (bench.speed_probe) stubbed: a machine twice as slow to compute and
    # twice as fast to compile as the reference.
    speed = MachineSpeed(compute=2.0, compile=0.5)
    monkeypatch.setattr(pipeline, "probe_speed", lambda: (speed, {"probe_wall_s": 4.2}))
    logs = []
    pipeline.run(plan, "dyncatch reproduce", logs.append)
    stage_lines = [line.split("] ", 1)[1] for line in logs if "stage " in line]
    n = len(fake)
    assert stage_lines == [f"stage {i}/{n}: {s.title} (done)" for i, s in enumerate(fake, 1)]
    assert got == {s.name: s.name for s in fake}
    first = logs[0].split("] ", 1)[1]
    assert first == (
        f"estimated wall time for the whole plan: {estimate_s(plan) / 60:.0f} min on the "
        "reference machine (the idle 2-core Xeon the estimate was fit on); this machine takes "
        "2.00x its time to compute and 0.50x to compile (a 4 s probe), so here about "
        f"{estimate_s(plan, speed) / 60:.0f} min (finished stages are skipped)"
    )
    # Without the probe (or in a merge of parts, which ran elsewhere) the reference alone.
    logs.clear()
    monkeypatch.setattr(pipeline, "probe_speed", lambda: pytest.fail("probed"))
    pipeline.run(dataclasses.replace(plan, probe_machine=False), "dyncatch reproduce", logs.append)
    assert logs[0].endswith("fit on) (finished stages are skipped)")


def test_the_estimate_scales_compute_and_compilation_apart():
    """On a machine of ``MachineSpeed(c, k)`` each stage takes c x its work plus k x its
    compilations: the estimate is linear in the two factors, and the reference machine's
    (1, 1) is the estimate itself."""
    from dyncatch.reproduce import estimate as e

    for plan in (PROFILES["full"], PROFILES["quick"], PROFILES["power"]):
        for stage in stages_of(plan):
            work = stage.estimate(plan, MachineSpeed(compute=1.0, compile=0.0))
            compiles = stage.estimate(plan, MachineSpeed(compute=0.0, compile=1.0))
            assert stage.estimate(plan) == pytest.approx(work + compiles, rel=1e-12)
            assert stage.estimate(plan, MachineSpeed(1.7, 0.6)) == pytest.approx(
                1.7 * work + 0.6 * compiles, rel=1e-12
            )
            assert stage.estimate(plan, REFERENCE) == stage.estimate(plan)
    # The compilations are the counted programs at their constants: a training group one,
    # a Table I row one per method and baseline.
    full = PROFILES["full"]
    only_compiling = MachineSpeed(compute=0.0, compile=1.0)
    assert e.group_s(full, "rl", only_compiling) == e.EST_TRAIN_COMPILE_S
    programs = (len(full.method_names) + len(BASELINES)) * len(full.table_i_rows)
    assert e.table_i_s(full, only_compiling) == pytest.approx(programs * e.EST_EVAL_COMPILE_S)
    assert e.table_ii_s(full, only_compiling) == 0.0  # data collection and updates only


def test_the_wall_clock_adds_a_killed_invocations_time(tmp_path):
    """wall.json holds the earlier invocations' total plus this one's, and is rewritten
    while the invocation runs, so one that is killed (never exits) still counts."""
    path = tmp_path / "wall.json"
    write_json(path, {"this_invocation_s": 90.0, "total_s": 100.0})
    clock = pipeline.WallClock(path, every_s=0.01).__enter__()  # never exited: "killed"
    first = read_json(path)
    assert first["total_s"] == pytest.approx(100.0 + first["this_invocation_s"])
    deadline = time.monotonic() + 10.0
    while read_json(path)["this_invocation_s"] <= first["this_invocation_s"]:
        assert time.monotonic() < deadline, "the clock's thread never rewrote wall.json"
        time.sleep(0.01)
    clock._stop.set()
    clock._thread.join()
    killed = read_json(path)["total_s"]
    with pipeline.WallClock(path) as again:
        assert again.previous_s == killed
    final = read_json(path)
    assert final["total_s"] == pytest.approx(killed + final["this_invocation_s"])


def test_the_wall_clock_adds_each_stages_time_over_invocations(tmp_path, monkeypatch):
    """A stage's seconds are its own (from ``enter`` to the next), summed with the earlier
    invocations'; the report sets them beside the estimate."""
    from dyncatch.reproduce.report import stage_times_markdown

    now = [0.0]
    monkeypatch.setattr(pipeline.time, "perf_counter", lambda: now[0])
    path = tmp_path / "wall.json"
    write_json(path, {"this_invocation_s": 50.0, "total_s": 50.0, "stages_s": {"training": 40.0}})
    with pipeline.WallClock(path, every_s=3600) as clock:
        now[0] = 5.0
        clock.enter("training")
        now[0] = 65.0
        assert read_json(path)["stages_s"] == {"training": 40.0}  # not yet rewritten
        assert clock.tick()["stages_s"] == {"training": 100.0}  # the stage still running
        clock.enter("table_i")
        now[0] = 95.0
    wall = read_json(path)
    assert wall["stages_s"] == {"training": 100.0, "table_i": 30.0}
    assert wall["total_s"] == 145.0 and wall["this_invocation_s"] == 95.0
    wall["stages_estimate_s"] = {"training": 120.0, "table_i": 30.0, "fig9": 60.0}
    table = stage_times_markdown(wall)
    assert "| training | 2.0 min | 1.7 min | 0.83 |" in table
    assert "| fig9 | 1.0 min | - | - |" in table
    assert "| **whole run** | 3.5 min | 2.4 min | 0.69 |" in table


def test_every_method_is_presented_and_the_claims_are_the_papers():
    assert list(PRESENTATION) == list(METHODS)
    assert set(METHODS) - set(reproduced_methods()) == {"st_rl", "st_fp", "rnn_rl", "rnn_sp_rl"}
    assert paper_claims() == (("sp_fp", "rl"), ("sp_rl", "rl"), ("sp_rl", "p_rl"),
                              ("sp_rl", "sp_fp"))  # fmt: skip
    assert ("st_rl", "sp_rl") in paper_claims(METHODS)
