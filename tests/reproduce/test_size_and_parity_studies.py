"""The network-size and parity studies' criteria on hand-made results
(benchmarks/network_size_study.py, benchmarks/parity_study.py,
benchmarks/parity_second_set.py)."""

from pathlib import Path

import pytest

from dyncatch.cli.main import parse
from dyncatch.reproduce.validate import validate_plan

from .benchmark_scripts import load_benchmark

size_study = load_benchmark("network_size_study")
parity_study = load_benchmark("parity_study")
second_set = load_benchmark("parity_second_set")

SEEDS = (-0.02, -0.01, 0.0, 0.01, 0.02)


def _results(methods, behaviors, success_of, plateau=0.95):
    cells = [
        {
            "behavior": b,
            "method": m,
            "speed_mps": v,
            "per_seed_success": [success_of(m, b) + d for d in SEEDS],
        }  # fmt: skip
        for b in behaviors
        for m in methods
        for v in (1.6, 1.8)
    ]
    training = [{"method": m, "final_eval_success_rate": plateau, "wall_s": 60.0}
                for m in methods]  # fmt: skip
    return {"table_i": {"cells": cells}, "training": training}


def test_the_smallest_size_within_the_margin_for_every_method_is_the_standard():
    def at(shift_rl):
        return _results(size_study.METHODS, size_study.BEHAVIORS,
                        lambda m, b: 0.8 + (shift_rl if m == "rl" else 0.0))  # fmt: skip

    by_size = {"256-256-128": at(0.0), "128-128-64": at(-0.04), "64-64": at(-0.06)}
    verdict = size_study.judge(by_size)
    assert verdict["holds"]["128-128-64"]["holds"] and not verdict["holds"]["64-64"]["holds"]
    assert verdict["standard"] == "128-128-64" and verdict["complete"]
    # While the smaller 64-64 has not run, a passing 128-128-64 is not yet the standard.
    unfinished = {k: v for k, v in by_size.items() if k != "64-64"}
    assert size_study.judge(unfinished)["standard"] is None
    rl = next(r for r in verdict["rows"] if r["size"] == "64-64" and r["method"] == "rl")
    assert rl["difference"] == pytest.approx(-0.06) and rl["resolved"]
    # The oracle's plateau must hold too; without the reference nothing is decided.
    by_size["128-128-64"]["training"] = [
        {**t, "final_eval_success_rate": 0.5} for t in by_size["128-128-64"]["training"]
    ]
    assert size_study.judge(by_size)["standard"] == "256-256-128"
    assert size_study.judge({"128-128-64": at(0.0)})["standard"] is None


def test_a_reading_that_resolvedly_lowers_rl_is_the_one_that_gives_it_its_catch():
    methods, behaviors = parity_study.METHODS, parity_study.BEHAVIORS
    default = _results(methods, behaviors, lambda m, b: 0.9)
    hidden = _results(methods, behaviors, lambda m, b: 0.5 if m == "rl" else 0.9)
    result = parity_study.analyse({"default": default, "paper_observation": hidden,
                                   "gamma_held": default})  # fmt: skip
    verdicts = {(r["setting"], r["method"]): r["verdict"] for r in result["primary"]}
    assert verdicts[("paper_observation", "rl")] == "lowers"
    assert verdicts[("paper_observation", "sp_rl")] == "unresolved"
    assert result["gives_rl_its_catch"] == ["paper_observation"]
    label = "paper_observation, reactive: sp_rl - rl"
    sp_minus_rl = next(r for r in result["secondary"] if r["label"] == label)
    assert sp_minus_rl["difference"] == pytest.approx(0.4)


def test_the_primary_pass_runs_first_and_its_finished_runs_are_shared_not_retrained(tmp_path):
    args = parity_study.parser().parse_args(["--out", str(tmp_path)])
    primary = parity_study.study_argv(args, ("gamma_held",), primary_seeds=10)
    full = parity_study.study_argv(args, ("gamma_held",))
    assert primary[primary.index("--out") + 1] == str(tmp_path / "primary_s10" / "gamma_held")
    assert primary[primary.index("--seeds") + 1] == "10"
    assert primary[primary.index("--methods") + 1 : primary.index("--seeds")] == ["rl", "sp_rl"]
    assert primary[primary.index("--behaviors") + 1] == "reactive"
    for argv in (primary, full):  # both plans pass the reproduction's own checks
        validate_plan(parse(argv)[1])
    # A finished run and predictor of the full pass appear in the primary pass's folder;
    # an unfinished run (no done.json) does not, and what is already there is kept.
    done = tmp_path / "gamma_held" / "runs" / "reactive" / "rl" / "seed0"
    done.mkdir(parents=True)
    (done / "done.json").write_text("{}")
    (done / "checkpoint.safetensors").write_bytes(b"w")
    partial = tmp_path / "gamma_held" / "runs" / "reactive" / "rl" / "seed1"
    beyond = tmp_path / "primary_s10" / "gamma_held" / "runs" / "reactive" / "rl" / "seed7"
    beyond.mkdir(parents=True)
    (beyond / "done.json").write_text("{}")
    partial.mkdir(parents=True)
    (partial / "checkpoint.safetensors").write_bytes(b"p")
    pred = tmp_path / "gamma_held" / "predictors" / "reactive_self_aware"
    pred.mkdir(parents=True)
    (pred / "metrics.json").write_text("{}")
    mine = tmp_path / "primary_s10" / "gamma_held" / "runs" / "reactive" / "sp_rl" / "seed0"
    mine.mkdir(parents=True)
    (mine / "done.json").write_text('{"mine": 1}')
    parity_study.share_runs(primary)
    there = tmp_path / "primary_s10" / "gamma_held"
    assert (there / "runs/reactive/rl/seed0/checkpoint.safetensors").read_bytes() == b"w"
    assert (there / "predictors/reactive_self_aware/metrics.json").exists()
    assert not (there / "runs/reactive/rl/seed1").exists()
    # And back: the full pass receives the primary pass's runs, its own left as they are.
    parity_study.share_runs(full)
    back = tmp_path / "gamma_held" / "runs/reactive/sp_rl/seed0/done.json"
    assert back.read_text() == '{"mine": 1}'
    # The full pass trains 5 seeds: seed 7 of the 10-seed pass is not its to hold.
    assert not (tmp_path / "gamma_held" / "runs/reactive/rl/seed7").exists()


def test_the_ten_seed_pass_runs_only_where_five_seeds_missed_the_half_width(tmp_path):
    import json

    args = parity_study.parser().parse_args(["--out", str(tmp_path)])
    methods, behaviors = parity_study.PRIMARY_METHODS, parity_study.PRIMARY_BEHAVIORS
    narrow = _results(methods, behaviors, lambda m, b: 0.9)
    wide = _results(methods, behaviors, lambda m, b: 0.6)
    for cell in wide["table_i"]["cells"]:  # a seed spread of 0.4: half-width far above 0.15
        cell["per_seed_success"] = [0.2, 0.9, 0.4, 1.0, 0.5]
    for name, res in (("default", narrow), ("gamma_held", narrow), ("beta_heading", wide)):
        folder = tmp_path / "primary_s5" / name
        folder.mkdir(parents=True)
        (folder / "results.json").write_text(json.dumps({**res, "plan": {"seeds": 5}}))
    ten = [a[a.index("--out") + 1] for a in parity_study.passes(args) if "--seeds" in a
           and a[a.index("--seeds") + 1] == "10"]  # fmt: skip
    names = [p.split("/")[-1] for p in ten]
    assert "default" in names and "beta_heading" in names  # the baseline, and the wide one
    assert "gamma_held" not in names  # met the target at 5 seeds
    assert "paper_observation" in names  # not measured yet: not decided against
    assert names[0] == "default"  # the baseline first, the wide one before the unmeasured
    assert names.index("paper_observation") < names.index("beta_heading")


def test_the_full_pass_skips_a_setting_where_no_primary_run_catches(tmp_path):
    import json

    args = parity_study.parser().parse_args(["--out", str(tmp_path), "--primary-seeds"])
    methods, behaviors = parity_study.PRIMARY_METHODS, parity_study.PRIMARY_BEHAVIORS
    for name, level in (("default", 0.9), ("arm_on_sighting", 0.0), ("gamma_held", 0.03)):
        res = _results(methods, behaviors, lambda m, b, level=level: level)
        for cell in res["table_i"]["cells"]:
            cell["per_seed_success"] = [level] * 4 + [level / 2]
        folder = tmp_path / "primary_s5" / name
        folder.mkdir(parents=True)
        (folder / "results.json").write_text(json.dumps({**res, "plan": {"seeds": 5}}))
    full = [a[a.index("--out") + 1].split("/")[-1] for a in parity_study.passes(args)]
    assert "arm_on_sighting" not in full
    assert {"default", "gamma_held", "paper_observation"} <= set(full)  # 0.03 is a catch


def test_the_full_pass_runs_first_the_setting_that_resolvedly_lowers_rl(tmp_path):
    import json

    args = parity_study.parser().parse_args(["--out", str(tmp_path), "--primary-seeds"])
    methods, behaviors = parity_study.PRIMARY_METHODS, parity_study.PRIMARY_BEHAVIORS
    levels = {"default": (0.9, 0.9), "gamma_held": (0.9, 0.9), "success_every_step": (0.0, 0.8)}
    for name, (rl, sp_rl) in levels.items():
        res = _results(methods, behaviors, lambda m, b, lv=(rl, sp_rl): lv[m == "sp_rl"])
        folder = tmp_path / "primary_s5" / name
        folder.mkdir(parents=True)
        (folder / "results.json").write_text(json.dumps({**res, "plan": {"seeds": 5}}))
    full = [a[a.index("--out") + 1].split("/")[-1] for a in parity_study.passes(args)]
    # rl at 0.0 against 0.9 (seed spread 0.04) is resolved after Holm; sp_rl still catches
    assert full[:3] == ["default", "success_every_step", "gamma_held"]
    assert len(full) == len(parity_study.SETTINGS)  # nothing here catches nothing
    summary = parity_study.summarize(parity_study.parser().parse_args(
        ["--out", str(tmp_path), "--summary-dir", str(tmp_path / "summary")]))  # fmt: skip
    assert "default" in summary["pending"] and "success_every_step" in summary["pending"]


def test_the_speed_profile_reads_the_folder_with_most_seeds_and_averages_over_them(tmp_path):
    import json

    profile = load_benchmark("speed_profile")
    study = tmp_path / "study"
    for folder, seeds in (("success_every_step", 5), ("primary_s10/success_every_step", 10)):
        (study / folder).mkdir(parents=True)
        (study / folder / "plan.json").write_text(json.dumps({"seeds": seeds}))
    assert profile.setting_folder(study, "success_every_step").parent.name == "primary_s10"
    with pytest.raises(FileNotFoundError, match="run the study"):
        profile.setting_folder(study, "gamma_held")
    args = profile.parser().parse_args(["--study", str(study), "--out", str(tmp_path / "out"),
                                        "--summary-dir", str(tmp_path / "sum"),
                                        "--settings", "success_every_step",
                                        "--speeds", "0.4", "0.8"])  # fmt: skip
    for seed, (slow, fast) in enumerate(((1.0, 0.2), (1.0, 0.4), (0.7, 0.0))):
        out = tmp_path / "out" / "success_every_step" / "rl" / f"seed{seed}.json"
        out.parent.mkdir(parents=True, exist_ok=True)
        rows = [{"speed_mps": 0.4, "success_rate": slow}, {"speed_mps": 0.8, "success_rate": fast}]
        out.write_text(json.dumps({"rows": rows}))
    result = profile.summarize(args)
    by_speed = {r["speed_mps"]: r for r in result["rows"]}
    assert by_speed[0.4]["mean"] == pytest.approx(0.9) and by_speed[0.8]["mean"] == pytest.approx(
        0.2
    )
    # t(2, 0.975) = 4.303, sd 0.2 over 3 seeds: half-width 4.303 * 0.2 / sqrt(3) = 0.4969
    lo, hi = by_speed[0.8]["ci95"]
    assert hi - 0.2 == pytest.approx(4.302653 * 0.2 / 3**0.5, rel=1e-5)
    assert by_speed[0.8]["per_seed"] == [0.2, 0.4, 0.0]


# plan.json files the parity study recorded before issue 32 made the paper's observation the
# default (copied from its folders: the 10-seed primary pass's default and
# paper_observation, and the full pass's gamma_held).
RECORDED = {
    "primary_s10/default": (),
    "primary_s10/paper_observation": ("paper_observation",),
    "gamma_held": ("gamma_held",),
}
_PLANS = Path(__file__).resolve().parent / "data" / "parity_plans"


@pytest.mark.parametrize("where", sorted(RECORDED))
def test_the_study_resumes_its_recorded_plans_under_the_new_default(tmp_path, where):
    """Each command pins the study's recorded observation (the staleness inputs, except under
    paper_observation) by a flag, so its folder and its plan.json stay as recorded: exactly,
    but for fields added since, each at what the code did before it existed."""
    import json

    from dyncatch.reproduce.layout import check_plan, plans_differ

    setting = RECORDED[where]
    recorded = json.loads((_PLANS / f"{where.replace('/', '_')}.json").read_text())
    stale = "paper_observation" not in setting
    assert recorded["world"]["observation"]["staleness_inputs"] is stale
    args = parity_study.parser().parse_args(
        ["--out", str(tmp_path), "--hidden-sizes", "128", "128", "64"]
    )
    seeds = recorded["seeds"] if where.startswith("primary_s") else None
    argv = parity_study.study_argv(args, setting, primary_seeds=seeds)
    folder = Path(argv[argv.index("--out") + 1])
    assert folder == tmp_path / where  # the folder's name is the setting's, as recorded
    folder.mkdir(parents=True)
    (folder / "plan.json").write_text(json.dumps(recorded))
    plan = parse(argv)[1]
    assert plans_differ(plan.to_json(), recorded) == {}
    check_plan(folder, plan)
    kept = json.loads((folder / "plan.json").read_text())
    assert kept == plan.to_json() and plans_differ(kept, recorded) == {}
    # Without the pin the new default is refused, naming the field.
    if stale:
        bare = [a for a in argv if a != parity_study.STALENESS_FLAG]
        with pytest.raises(ValueError, match=r"world\.observation\.staleness_inputs"):
            check_plan(folder, parse(bare)[1])


@pytest.mark.parametrize("where", ["primary_s10/default", "primary_s10/paper_observation"])
@pytest.mark.parametrize("method", ["rl", "sp_rl"])
def test_a_second_set_chunk_is_the_first_sets_plan_on_other_seeds(tmp_path, where, method):
    """The replication compares like with like: a chunk's plan differs from the first set's
    recorded one in its seeds and methods alone."""
    import json

    from dyncatch.reproduce.layout import plans_differ

    recorded = json.loads((_PLANS / f"{where.replace('/', '_')}.json").read_text())
    args = parity_study.parser().parse_args(
        ["--out", str(tmp_path), "--hidden-sizes", "128", "128", "64"]
    )
    argv = second_set.chunk_argv(args, RECORDED[where], 15, method)
    plan = parse(argv)[1]
    validate_plan(plan)
    assert plans_differ(plan.to_json(), recorded) == {
        "first_seed": (15, 0), "methods": ([method], ["rl", "sp_rl"]), "seeds": (5, 10),
    }  # fmt: skip
    name = "default" if not RECORDED[where] else "paper_observation"
    suffix = "" if method == "rl" else ".sp_rl"
    assert Path(argv[argv.index("--out") + 1]) == tmp_path / "seeds15-19" / f"{name}{suffix}"


def test_the_second_set_runs_rl_rounds_then_sp_rl_and_judges_its_own_seeds(tmp_path, monkeypatch):
    import json

    args = parity_study.parser().parse_args(["--out", str(tmp_path / "out")])
    args.summary_dir = tmp_path / "summary"
    order = [(a[a.index("--out") + 1], a[a.index("--first-seed") + 1])
             for a in second_set.passes(args)]  # fmt: skip
    names = [Path(out).relative_to(args.out).as_posix() for out, _ in order]
    rl_rounds = 3 * second_set.DEFAULT_ROUNDS + 2 * (second_set.ROUNDS - second_set.DEFAULT_ROUNDS)
    assert names[:4] == ["seeds10-14/default", "seeds10-14/paper_observation",
                         "seeds10-14/success_every_step", "seeds15-19/default"]  # fmt: skip
    assert "seeds25-29/default" not in names  # the baseline's rounds end at 15 seeds
    assert names[rl_rounds:rl_rounds + 2] == ["seeds10-14/default.sp_rl",
                                              "seeds10-14/success_every_step.sp_rl"]  # fmt: skip
    assert len(names) == rl_rounds + 2 * second_set.SP_ROUNDS
    assert all(first == out.split("seeds")[-1].split("-")[0] for out, first in order)

    def finish(setting, first, method, values, evals=(0.0, 0.9, 0.9)):
        folder = second_set.chunk_folder(args.out, setting, first, method)
        for seed in range(first, first + len(values)):  # each run's periodic evaluations
            run = folder / "runs" / "reactive" / method / f"seed{seed}"
            run.mkdir(parents=True)
            rows = ["iteration,env_steps,success_rate,reward_per_step,time_s,eval/success_rate"]
            rows += [f"{i},{i * 64},0,0,{i},{e}" for i, e in enumerate(evals, 1)]
            (run / "metrics.csv").write_text("\n".join(rows) + "\n")
        cells = [{"behavior": "reactive", "method": method, "speed_mps": v,
                  "per_seed_success": values} for v in (1.6, 1.8)]  # fmt: skip
        plan = {"first_seed": first, "seeds": len(values)}
        (folder / "results.json").write_text(
            json.dumps({"plan": plan, "table_i": {"cells": cells}})
        )

    finish((), 10, "rl", [0.90, 0.92, 0.88, 0.91, 0.89])
    finish((), 15, "rl", [0.90, 0.93, 0.87, 0.90, 0.90])
    finish(("paper_observation",), 10, "rl", [0.40, 0.42, 0.38, 0.41, 0.39], (0.0, 0.9, 0.5))
    finish(("success_every_step",), 10, "rl", [0.90, 0.92, 0.88, 0.91, 0.89])
    finish((), 10, "sp_rl", [0.95, 0.96, 0.94, 0.95, 0.95])
    finish(("success_every_step",), 15, "rl", [0.0, 0.9, 0.1, 0.9, 0.9], (0.0, 0.2, 0.1))
    first = tmp_path / "first.json"
    first.write_text(json.dumps({"primary": [
        {"setting": "paper_observation", "method": "rl", "difference": -0.3,
         "ci95": [-0.5, -0.1], "verdict": "lowers"},
        {"setting": "success_every_step", "method": "rl", "difference": -0.6,
         "ci95": [-0.9, -0.3], "verdict": "lowers"},
    ]}))  # fmt: skip
    monkeypatch.setattr(second_set, "FIRST_SET", first)
    result = second_set.summarize(args)
    assert list(result["per_seed"]["rl"]["default"]) == list(range(10, 20))
    assert result["per_seed"]["sp_rl"]["success_every_step"] == {}
    rows = {(r["setting"], r["method"]): r for r in result["primary"]}
    # Under 0.5 at 1.8 m/s: learned in training and lost it, or never learned at all.
    course = result["training_course"]["rl"]
    assert course["paper_observation"]["lost"] == [10, 11, 12, 13, 14]
    assert course["success_every_step"]["never"] == [15, 17]
    assert course["default"]["low"] == []
    assert set(rows) == {("paper_observation", "rl"), ("success_every_step", "rl")}
    lowered = rows[("paper_observation", "rl")]
    assert (lowered["seeds"], lowered["baseline_seeds"]) == (5, 10)
    assert lowered["difference"] == pytest.approx(0.40 - 0.90)
    assert lowered["verdict"] == "lowers" and lowered["agrees"]
    same = rows[("success_every_step", "rl")]
    assert same["verdict"] == "unresolved" and not same["agrees"]
    # Holm over the two: the smaller p doubled, the larger at least that.
    low, high = sorted((lowered["p_value"], same["p_value"]))
    assert lowered["p_holm"] == pytest.approx(min(1.0, 2 * low))
    assert same["p_holm"] == pytest.approx(min(1.0, max(high, 2 * low)))
    assert (
        "| paper_observation | rl | 5 (10) | -0.500"
        in (args.summary_dir / "summary.md").read_text()
    )


def test_the_full_pass_can_be_narrowed_to_named_settings_and_a_wrong_name_is_refused(tmp_path):
    argv = ["--out", str(tmp_path), "--primary-seeds", "--full-settings", "success_every_step"]
    args = parity_study.parser().parse_args(argv)
    full = [a[a.index("--out") + 1].split("/")[-1] for a in parity_study.passes(args)]
    assert full == ["success_every_step"]
    with pytest.raises(SystemExit, match="--full-settings: unknown setting.*success_every_step"):
        parity_study.run(["--out", str(tmp_path), "--full-settings", "every_step", "--dry-run"])
    assert not any(tmp_path.iterdir())  # refused before anything ran


@pytest.mark.parametrize("behavior", ["reactive", "random_reactive"])
def test_the_full_reproduction_trains_what_the_paper_observation_full_pass_would(behavior):
    """The full reproduction at 10 seeds (benchmarks/results/full10/, the memory study's rl
    and sp_rl) runs under the world and PPO of the parity study's ``paper_observation``
    setting: its runs stand for that setting's full pass (docs/fidelity.md)."""
    import json

    from dyncatch.reproduce.layout import plans_differ

    recorded = Path(__file__).resolve().parents[2] / "benchmarks/results/full10" / behavior
    full10 = json.loads((recorded / "plan.json").read_text())
    args = parity_study.parser().parse_args(["--out", "x", "--hidden-sizes", "128", "128", "64"])
    plan = parse(parity_study.study_argv(args, ("paper_observation",)))[1].to_json()
    differ = plans_differ(plan, full10)
    assert [k for k in differ if k.split(".")[0] in ("world", "ppo")] == []
    assert set(differ) <= {"behaviors", "fig9", "methods", "seeds", "setting", "speeds_mps",
                           "table_i_behaviors", "transfer_behaviors", "videos"}  # fmt: skip
    assert full10["episodes"] == plan["episodes"] and full10["train_steps"] == plan["train_steps"]
