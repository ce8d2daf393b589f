"""The memory study's plan, its sharing of the full reproduction's runs and its analysis on
hand-made results (benchmarks/memory_study.py)."""

import dataclasses
import json
from pathlib import Path

import pytest

from dyncatch.cli.main import parse
from dyncatch.reproduce.plan import PROFILES
from dyncatch.reproduce.validate import validate_plan

from .benchmark_scripts import load_benchmark

memory = load_benchmark("memory_study")
SPREAD = (-0.02, -0.01, 0.0, 0.01, 0.02)


def _results(success_of):
    """A behaviour's results.json with five seeds a cell around ``success_of(method)``."""
    cells = [
        {"behavior": "b", "method": m, "speed_mps": v,
         "per_seed_success": [success_of(m) + d for d in SPREAD],
         "per_seed_catch_time_s": [10.0 - 5 * success_of(m) + d for d in SPREAD]}
        for m in memory.METHODS for v in (1.6, 1.8)
    ]  # fmt: skip
    return {"table_i": {"cells": cells}}


def _rename(results: dict, behavior: str) -> dict:
    cells = [{**c, "behavior": behavior} for c in results["table_i"]["cells"]]
    return {"table_i": {"cells": cells}}


def test_the_plan_is_the_full_profiles_training_with_three_methods_and_two_speeds(tmp_path):
    args = memory.parser().parse_args(["--out", str(tmp_path)])
    argv = memory.study_argv(args, "reactive")
    plan = validate_plan(parse(argv)[1])
    full = PROFILES["full"]
    assert plan.method_names == ("rl", "sp_rl", "rnn_rl") and plan.behaviors == ("reactive",)
    assert (plan.seeds, plan.first_seed, plan.speeds_mps) == (10, 0, (1.6, 1.8))
    assert (plan.executor, plan.ray_workers) == ("ray", 2)
    # Everything that shapes a run is the full reproduction's: its runs can be shared.
    assert memory.linkable(full.to_json(), plan.to_json()) == []
    one = memory.study_argv(memory.parser().parse_args(["--out", "x", "--workers", "1"]), "b")
    assert "--executor" not in one


def _part(root: Path, plan: dict, behavior: str) -> Path:
    """A finished part of the full reproduction: its plan, two seeds of rl and sp_rl, one
    unfinished, and both predictors."""
    part = root / behavior
    part.mkdir(parents=True)
    (part / "plan.json").write_text(json.dumps(plan))
    for m in ("rl", "sp_rl", "gt_rl"):
        for s in (0, 1, 12):
            run = part / "runs" / behavior / m / f"seed{s}"
            run.mkdir(parents=True)
            (run / "checkpoint.safetensors").write_bytes(b"x")
            (run / "done.json").write_text("{}")
    unfinished = part / "runs" / behavior / "rl" / "seed2"
    unfinished.mkdir(parents=True)
    for kind in ("self_aware", "vanilla"):
        pred = part / "predictors" / f"{behavior}_{kind}"
        pred.mkdir(parents=True)
        (pred / "metrics.json").write_text("{}")
    return part


def test_the_full_reproductions_finished_runs_are_linked_not_retrained(tmp_path):
    args = memory.parser().parse_args(["--out", str(tmp_path / "m"), "--full", str(tmp_path / "f")])
    argv = memory.study_argv(args, "reactive")
    whole = validate_plan(dataclasses.replace(PROFILES["full"], seeds=10)).to_json()
    part = _part(tmp_path / "f", whole, "reactive")
    assert memory.link_from_full(args, argv) == []
    out = tmp_path / "m" / "reactive"
    linked = sorted(str(p.parent.relative_to(out)) for p in out.rglob("done.json"))
    # rl and sp_rl of the study's seeds (0-9), finished; not gt_rl, seed 12 or the unfinished.
    assert linked == [f"runs/reactive/{m}/seed{s}" for m in ("rl", "sp_rl") for s in (0, 1)]
    assert [p.name for p in (out / "predictors").iterdir()] == ["reactive_self_aware"]
    ckpt = "runs/reactive/rl/seed0/checkpoint.safetensors"
    assert (out / ckpt).stat().st_ino == (part / ckpt).stat().st_ino  # a hard link
    # A part trained otherwise (another budget) lends nothing.
    other = tmp_path / "g"
    _part(other, {**whole, "train_steps": 2_000_000}, "random_reactive")
    args = memory.parser().parse_args(["--out", str(tmp_path / "n"), "--full", str(other)])
    argv = memory.study_argv(args, "random_reactive")
    assert memory.link_from_full(args, argv) == ["train_steps"]
    assert not (tmp_path / "n").exists()


def test_memory_that_matches_the_predictor_is_equivalent_and_one_that_does_not_is_beaten():
    equal = _results(lambda m: {"rl": 0.5, "sp_rl": 0.9, "rnn_rl": 0.9}[m])
    short = _results(lambda m: {"rl": 0.5, "sp_rl": 0.9, "rnn_rl": 0.6}[m])
    r = memory.analyse({"reactive": _rename(equal, "reactive"),
                        "random_reactive": _rename(short, "random_reactive")})  # fmt: skip
    by = {(p["behavior"], tuple(p["pair"])): p for p in r["primary"]}
    assert len(by) == 4
    assert by[("reactive", ("rnn_rl", "rl"))]["verdict"] == "holds"
    assert by[("reactive", ("sp_rl", "rnn_rl"))]["difference"] == pytest.approx(0.0, abs=1e-12)
    assert by[("random_reactive", ("sp_rl", "rnn_rl"))]["verdict"] == "holds"
    assert r["memory"]["reactive"].startswith("recovers")
    assert r["memory"]["random_reactive"].startswith("does not recover")
    # Holm over the four: the smallest p times 4, the largest at least the one before it.
    ps = sorted(p["p_value"] for p in r["primary"])
    holms = sorted(p["p_holm"] for p in r["primary"])
    assert holms[0] == pytest.approx(min(1.0, 4 * ps[0]))
    assert holms[-1] >= holms[-2]
    assert r["means_1_8"]["random_reactive"]["rnn_rl"] == pytest.approx(0.6)
    assert {s["measure"] for s in r["secondary"]} == {"success", "catch time (s)"}


def test_a_wide_interval_around_zero_is_unresolved_not_equivalent():
    def wide(m):
        return {"rl": 0.5, "sp_rl": 0.8, "rnn_rl": 0.75}[m]

    res = _results(wide)
    for c in res["table_i"]["cells"]:  # a spread of +-0.3 among rnn_rl's seeds
        if c["method"] == "rnn_rl":
            c["per_seed_success"] = [0.45, 0.6, 0.75, 0.9, 1.05]
    r = memory.analyse({"reactive": _rename(res, "reactive")})
    # One behaviour measured: Holm still over the declared four, the other two at p = 1.
    p1, p2 = (next(p for p in r["primary"] if p["pair"] == pair) for pair in
              (["rnn_rl", "rl"], ["sp_rl", "rnn_rl"]))  # fmt: skip
    assert p1["p_holm"] == pytest.approx(min(1.0, 4 * min(p1["p_value"], p2["p_value"])))
    assert p2["ci95"][0] < -memory.MARGIN and p2["verdict"] == "unresolved"
    assert r["memory"]["reactive"] == "unresolved"


def test_a_second_seed_set_pools_with_the_first_seed_by_seed():
    first = _rename(_results(lambda m: {"rl": 0.5, "sp_rl": 0.9, "rnn_rl": 0.7}[m]), "reactive")
    second = _rename(_results(lambda m: {"rl": 0.4, "sp_rl": 0.8, "rnn_rl": 0.8}[m]), "reactive")
    other = _rename(
        _results(lambda m: {"rl": 0.3, "sp_rl": 0.9, "rnn_rl": 0.6}[m]), "random_reactive"
    )
    pooled = memory.pool(first, second)
    cell = next(c for c in pooled["table_i"]["cells"]
                if (c["method"], c["speed_mps"]) == ("rnn_rl", 1.8))  # fmt: skip
    assert cell["per_seed_success"] == pytest.approx([0.68, 0.69, 0.7, 0.71, 0.72,
                                                      0.78, 0.79, 0.8, 0.81, 0.82])  # fmt: skip
    assert len(cell["per_seed_catch_time_s"]) == 10
    # random_reactive only in the first set: it enters with its own seeds, the family stays four.
    r = memory.pooled_analysis({"reactive": first, "random_reactive": other}, {"reactive": second})
    seeds = {(p["behavior"], tuple(p["pair"])): p["seeds"] for p in r["primary"]}
    assert seeds[("reactive", ("rnn_rl", "rl"))] == [10, 10]
    assert seeds[("random_reactive", ("sp_rl", "rnn_rl"))] == [5, 5]
    assert r["means_1_8"]["reactive"]["rnn_rl"] == pytest.approx(0.75)
    # A baseline has no seeds: both sets' cells are the same episodes, kept once.
    base = {"behavior": "reactive", "method": "pursuit", "speed_mps": 1.8,
            "per_seed_success": [0.3], "per_seed_catch_time_s": [15.0]}  # fmt: skip
    with_base = memory.pool(
        {"table_i": {"cells": [*first["table_i"]["cells"], base]}},
        {"table_i": {"cells": [*second["table_i"]["cells"], base]}},
    )
    assert with_base["table_i"]["cells"][-1] == base
    with pytest.raises(ValueError, match="same in both sets"):
        memory.pool(first, first)
