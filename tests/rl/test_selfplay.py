"""Self-play rounds: two tiny rounds end to end, the cross-evaluation's cells (one by hand),
a resume that trains and evaluates nothing, an interrupted stage made again, more rounds
reusing the finished ones, a changed config refused naming the flag, and the exploitability
row by hand."""

import dataclasses
import json
import math
from pathlib import Path

import jax
import numpy as np
import pytest

from dyncatch.cli.main import main
from dyncatch.evaluation.episodes import run_episodes_at_speeds
from dyncatch.evaluation.intervals import t_quantile
from dyncatch.rl import selfplay
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.cross_eval import shared_policy
from dyncatch.rl.exploitability import EXPLOIT_EVAL_STREAM, best_response_world, exploitability
from dyncatch.rl.policy import CHECKPOINT, load_run
from dyncatch.rl.selfplay import SelfPlayRunner
from dyncatch.rl.selfplay_cfg import SelfPlayCfg
from dyncatch.rl.stages import Stage, run_stage, stage_done
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT
from dyncatch.utils.config_io import to_json
from dyncatch.utils.tree_io import read_header

# 8 environments: the gated reset and arm step (sim.gate) have one compact sub-batch besides
# the whole batch, so each training program traces them twice, not three times as with 16
# (the study's fixture 59.8 -> 52.5 CPU s).
TINY = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=1, hidden_sizes=(16,))


def tiny(out, **fields) -> SelfPlayCfg:
    """Two rounds of one-iteration trainings, 2 pursuer seeds, 8 episodes at one speed."""
    cfg = SelfPlayCfg(
        out=out,
        rounds=2,
        methods=("rl",),
        seeds=2,
        evader_steps=TINY.batch_size,
        pursuer_steps=TINY.batch_size,
        exploit_steps=TINY.batch_size,
        eval_speeds_mps=(1.6,),
        eval_episodes=8,
        evader_ppo=TINY,
        pursuer_ppo=TINY,
    )
    return dataclasses.replace(cfg, **fields)


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    cfg = tiny(tmp_path_factory.mktemp("selfplay") / "study")
    summary = SelfPlayRunner(cfg).learn()
    return cfg, summary


def _no_training(monkeypatch):
    def refuse(cfg, *args):
        raise RuntimeError(f"trained {cfg.out}")

    monkeypatch.setattr(selfplay, "train_evader", refuse)
    monkeypatch.setattr(selfplay, "make_runner", refuse)


def _no_evaluation(monkeypatch):
    def refuse(*args):
        raise RuntimeError("evaluated")

    monkeypatch.setattr(selfplay, "evaluate_pursuer", refuse)
    monkeypatch.setattr(selfplay, "evaluate_runs", refuse)


def _checkpoints(out):
    return {p: p.stat().st_mtime_ns for p in out.rglob("*.safetensors")}


class TestTwoRounds:
    def test_every_stage_is_made(self, study):
        cfg, summary = study
        out = cfg.out
        for k in (0, 1):
            assert (out / f"round{k}" / "evader" / EVADER_CHECKPOINT).exists()
            for s in (0, 1):
                assert (out / f"round{k}" / "pursuer" / "rl" / f"seed{s}" / CHECKPOINT).exists()
                assert (
                    out / f"round{k}" / "exploit" / "rl" / f"seed{s}" / EVADER_CHECKPOINT
                ).exists()
                assert (out / f"round{k}" / "eval" / "rl" / f"seed{s}" / "done.json").exists()
        assert json.loads((out / "summary.json").read_text()) == summary
        assert "| 1 | rl | 2 |" in (out / "summary.md").read_text()
        assert "| rl | 1 | round0 | 2 |" in (out / "summary.md").read_text()

    def test_round_k_plays_the_last_pursuers_and_the_league_of_evaders_0_to_k(self, study):
        cfg, _ = study
        out = cfg.out
        e0 = read_header(out / "round0" / "evader" / EVADER_CHECKPOINT)
        e1 = read_header(out / "round1" / "evader" / EVADER_CHECKPOINT)
        assert e0["against"] == ["pursuit"]
        assert e1["against"] == [
            str(out / "round0" / "pursuer" / "rl" / f"seed{s}") for s in (0, 1)
        ]
        p1 = read_header(out / "round1" / "pursuer" / "rl" / "seed1" / CHECKPOINT)
        target = p1["world"]["target"]
        assert target["behavior"] == "league" and target["league_behaviors"] == ["reactive"]
        assert target["league_evaders"] == [
            str(out / f"round{k}" / "evader" / EVADER_CHECKPOINT) for k in (0, 1)
        ]
        br = read_header(out / "round1" / "exploit" / "rl" / "seed1" / EVADER_CHECKPOINT)
        assert br["against"] == [str(out / "round1" / "pursuer" / "rl" / "seed1")]

    def test_rows_are_the_seeds_means(self, study):
        cfg, summary = study
        rows = summary["rounds"]
        assert [(r["round"], r["method"], r["seeds"]) for r in rows] == [(0, "rl", 2), (1, "rl", 2)]
        for r in rows:
            evals = [
                json.loads(
                    (
                        cfg.out / f"round{r['round']}" / "eval" / "rl" / f"seed{s}" / "done.json"
                    ).read_text()
                )["result"]
                for s in (0, 1)
            ]
            league = [e["league_success"] for e in evals]
            br = [e["best_response_success"] for e in evals]
            assert r["league"] == pytest.approx(np.mean(league))
            assert r["exploitability"] == pytest.approx(np.mean(league) - np.mean(br))
            assert all(0.0 <= x <= 1.0 for x in league + br)
            assert r["round_time_s"] > 0


class TestCrossEvaluation:
    OPPONENTS = ("round0", "round1", "reactive")

    def _result(self, cfg, k, opponent):
        done = cfg.out / f"round{k}" / "cross" / "rl" / opponent / "done.json"
        return json.loads(done.read_text())["result"]

    def test_one_cell_per_method_seed_round_opponent_and_speed(self, study):
        cfg, summary = study
        rows = summary["cross_eval"]
        assert [(r["method"], r["pursuer_round"], r["opponent"]) for r in rows] == [
            ("rl", k, o) for k in (0, 1) for o in self.OPPONENTS
        ]
        cells = 0
        for r in rows:
            got = self._result(cfg, r["pursuer_round"], r["opponent"])
            assert np.shape(got["success"]) == np.shape(got["catch_time_s"]) == (2, 1)
            cells += np.size(got["success"])
            assert r["seeds"] == 2 and r["speeds_mps"] == [1.6]
            assert r["success"]["mean"] == pytest.approx(np.mean(got["success"]))
            assert r["catch_time_s"]["mean"] == pytest.approx(np.mean(got["catch_time_s"]))
            caught = np.asarray(got["success"]) * cfg.eval_episodes  # 8 episodes a cell
            assert np.allclose(caught, np.round(caught))
            times = np.asarray(got["catch_time_s"])
            assert np.all((times > 0) & (times <= cfg.world.episode.duration_s))
        assert cells == 1 * 2 * 2 * 3 * 1  # methods x seeds x rounds x opponents x speeds
        assert summary["compare"] == []  # sp_rl is not trained here
        assert summary["cross_eval_time_s"] > 0

    def test_a_cell_by_hand(self, study):
        # Round 1's seed 1 against round 0's evader with the evaluation's keys, in the
        # program the stage compiled (shared_policy; the next test checks what it changes).
        cfg, _ = study
        world = best_response_world(cfg.world, cfg.out / "round0" / "evader")
        run = load_run(cfg.out / "round1" / "pursuer" / "rl" / "seed1").policy
        key = jax.random.fold_in(jax.random.key(cfg.eval_seed), EXPLOIT_EVAL_STREAM)
        policy = shared_policy(run, world)
        out = run_episodes_at_speeds(policy, jax.random.split(key, 1), world, [1.6], 8)
        got = self._result(cfg, 1, "round0")
        for name in ("success", "catch_time_s"):
            assert got[name][1] == [float(np.asarray(out[name], float).mean())]

    def test_every_rounds_pursuer_shares_one_program_per_opponent(self, study):
        cfg, _ = study
        world = best_response_world(cfg.world, cfg.out / "round1" / "evader")
        runs = [cfg.out / f"round{k}" / "pursuer" / "rl" / "seed0" for k in (0, 1)]
        p0, p1 = (load_run(run).policy for run in runs)
        assert jax.tree.structure(p0) != jax.tree.structure(p1)  # their leagues differ
        shared = [shared_policy(p, world) for p in (p0, p1)]
        assert jax.tree.structure(shared[0]) == jax.tree.structure(shared[1])
        # What the policy reads from its environment, the command limits, is unchanged.
        for before, after in zip((p0, p1), shared, strict=True):
            a, b = before.env.action_spec, after.env.action_spec
            assert np.array_equal(a.low, b.low) and np.array_equal(a.high, b.high)
            assert after.env.world.replace(target=before.env.world.target) == before.env.world

    def test_more_rounds_add_only_the_missing_cells(self, study):
        cfg, _ = study
        runner = SelfPlayRunner(dataclasses.replace(cfg, rounds=3))
        stages = [s for k in (0, 1) for s in runner.cross_stages(k, "rl")]
        missing = [s.name for s in stages if stage_done(s) is None]
        assert missing == ["round0/cross/rl/round2", "round1/cross/rl/round2"]

    def test_turning_it_off_is_a_changed_flag(self, study):
        cfg, _ = study
        with pytest.raises(ValueError, match=r"--cross-eval \(True -> False\)"):
            SelfPlayRunner(dataclasses.replace(cfg, cross_eval=False)).learn()


class TestResume:
    def test_a_second_run_trains_and_evaluates_nothing(self, study, monkeypatch):
        cfg, summary = study
        before = _checkpoints(cfg.out)
        _no_training(monkeypatch)
        _no_evaluation(monkeypatch)
        assert SelfPlayRunner(cfg).learn() == summary
        assert _checkpoints(cfg.out) == before

    def test_an_interrupted_stage_is_made_again(self, study, monkeypatch):
        cfg, summary = study
        stage = cfg.out / "round1" / "eval" / "rl" / "seed1"
        (stage / "done.json").unlink()
        (stage / "partial.tmp").write_text("left by a crash")
        _no_training(monkeypatch)  # the evaluation is made again, nothing is trained
        again = SelfPlayRunner(cfg).learn()
        assert (stage / "done.json").exists() and not (stage / "partial.tmp").exists()
        for a, b in zip(again["rounds"], summary["rounds"], strict=True):
            assert a["league"] == b["league"] and a["best_response"] == b["best_response"]

    def test_more_rounds_reuse_the_finished_ones(self, study, monkeypatch):
        cfg, _ = study
        _no_training(monkeypatch)
        with pytest.raises(RuntimeError, match="round2/evader"):
            SelfPlayRunner(dataclasses.replace(cfg, rounds=3)).learn()

    def test_a_changed_config_is_refused_naming_the_flag(self, study):
        cfg, _ = study
        with pytest.raises(ValueError, match=r"--pursuer-steps \(64 -> 256\)"):
            SelfPlayRunner(dataclasses.replace(cfg, pursuer_steps=256)).learn()
        other = dataclasses.replace(cfg, evader_ppo=TINY.replace(learning_rate=3e-3))
        with pytest.raises(ValueError, match=r"--evader-ppo\.learning-rate"):
            SelfPlayRunner(other).learn()

    def test_a_stage_made_from_another_spec_is_refused(self, tmp_path):
        made = Stage("s", tmp_path / "s", {"steps": 1}, lambda p: {"ok": 1})
        assert run_stage(made)["skipped"] is False
        assert run_stage(made)["skipped"] is True
        other = dataclasses.replace(made, spec={"steps": 2})
        with pytest.raises(ValueError, match=r"stage s .*--steps \(1 -> 2\)"):
            run_stage(other)

    def test_an_interrupted_stage_is_cleared_unless_it_continues_itself(self, tmp_path):
        def make(p):
            stage.out.mkdir(exist_ok=True)
            return {"found": sorted(f.name for f in stage.out.iterdir())}

        for keeps, found in ((False, []), (True, ["partial"])):
            stage = Stage("s", tmp_path / f"s{keeps}", {}, make, keeps_partial=keeps)
            stage.out.mkdir()
            (stage.out / "partial").write_text("")
            assert run_stage(stage)["result"] == {"found": found}
        # The evaders' stages continue from their training state (rl.evader_train.resumable;
        # tests/rl/test_evader.py), the pursuers' start again.
        stages = SelfPlayRunner(tiny(tmp_path / "study")).round_stages(0)
        kept = {s.name.split("/")[1] for s in stages if s.keeps_partial}
        assert kept == {"evader", "exploit"}
        assert not any(s.keeps_partial for s in stages if "/pursuer/" in s.name)


class TestBadInput:
    @pytest.mark.parametrize(
        ("fields", "words"),
        [
            ({"rounds": 0}, "--rounds"),
            ({"seeds": 0}, "--seeds"),
            ({"methods": ("sp_rl",)}, "--predictor"),
            ({"methods": ("sp_fp",)}, "'gt_rl' instead"),
            ({"methods": ("rl", "rl")}, "--methods"),
            ({"exploit_steps": -1}, "--exploit-steps"),
            ({"first_pursuers": ("nobody",)}, "--first-pursuers"),
            ({"league_behaviors": ("bounce",)}, "league_behaviors"),
            ({"league_scripted_share": 2.0}, "league_scripted_share"),
            ({"compare": ("rl", "rl")}, "--compare rl rl"),
            ({"compare": ("sp_rl", "rll")}, "--compare sp_rl rll"),
            ({"evader_fov_rad": 0.0}, "--evader-fov-rad"),
            ({"evader_select_every": -1}, "--evader-select-every -1"),
            ({"evader_select_episodes": 0}, "--evader-select-episodes 0"),
            ({"predictor_steps": -1}, "--predictor-steps -1"),
            (
                {"methods": ("sp_rl",), "predictor_steps": 10, "predictor": Path("p")},
                "--predictor and --predictor-steps both",
            ),
        ],
    )
    def test_names_the_flag(self, tmp_path, fields, words):
        with pytest.raises(ValueError, match=words):
            SelfPlayRunner(tiny(tmp_path / "x", **fields))
        assert not (tmp_path / "x").exists()

    def test_the_cli_says_it(self, tmp_path, capsys):
        assert main(["evader", "selfplay", "--out", str(tmp_path / "x"), "--rounds", "0"]) == 2
        assert "--rounds 0" in capsys.readouterr().err


def test_each_round_can_train_the_predictor_its_pursuers_read(tmp_path):
    # --predictor-steps: after round k's evader, a predictor of each kind the methods read,
    # trained on the round's league (evaders 0..k and the scripted members), read by that
    # round's p_rl / sp_rl; rl reads none.
    cfg = tiny(tmp_path / "x", methods=("rl", "sp_rl", "p_rl"), predictor_steps=5000)
    stages = SelfPlayRunner(cfg).round_stages(1)
    names = [s.name for s in stages[:5]]
    assert names == [
        "round1/evader",
        "round1/predictor/self_aware",
        "round1/predictor/vanilla",
        "round1/pursuer/rl",
        "round1/pursuer/sp_rl",
    ]
    pc = selfplay.round_predictor_cfg(cfg, 1, "self_aware")
    assert stages[1].spec == to_json(pc) and (pc.steps, pc.seed) == (5000, cfg.seed + 1)
    league = selfplay.pursuer_cfg(cfg, 1, "sp_rl").world
    assert pc.world == league and len(league.target.league_evaders) == 2
    assert selfplay.pursuer_cfg(cfg, 1, "sp_rl").predictor == pc.out / "predictor.safetensors"
    vanilla = selfplay.round_predictor_cfg(cfg, 1, "vanilla").out / "predictor.safetensors"
    assert selfplay.pursuer_cfg(cfg, 1, "p_rl").predictor == vanilla
    assert selfplay.pursuer_cfg(cfg, 1, "rl").predictor is None
    # Without it, the study's one --predictor, and no predictor stage.
    fixed = tiny(tmp_path / "y", methods=("sp_rl",), predictor=Path("p.safetensors"))
    assert selfplay.pursuer_cfg(fixed, 1, "sp_rl").predictor == Path("p.safetensors")
    assert not any("/predictor/" in s.name for s in SelfPlayRunner(fixed).round_stages(0))


def test_a_study_recorded_before_a_field_existed_reads_it_as_its_default(tmp_path):
    cfg = tiny(tmp_path / "x")
    selfplay.check_study(cfg)
    path = cfg.out / "selfplay.json"
    recorded = json.loads(path.read_text())
    del recorded["predictor_steps"]
    path.write_text(json.dumps(recorded))
    selfplay.check_study(cfg)  # accepted: the missing field is at its default
    with pytest.raises(ValueError, match=r"--predictor-steps \(None -> 10\)"):
        selfplay.check_study(dataclasses.replace(cfg, predictor_steps=10))


def test_every_evader_gets_the_studys_speed_action_field_of_view_and_selection(tmp_path):
    cfg = tiny(
        tmp_path / "x",
        evader_speed_action=True,
        evader_fov_rad=2.0,
        evader_select_every=5,
        evader_select_episodes=7,
    )
    run = selfplay.pursuer_runs(cfg, 0, "rl")[0]
    for ev in (
        selfplay.evader_cfg(cfg, 0),
        selfplay.evader_cfg(cfg, 1),
        selfplay.exploit_cfg(cfg, run, 0),
    ):
        assert (ev.speed_action, ev.fov_rad) == (True, 2.0)
        assert (ev.select_every, ev.select_episodes) == (5, 7)
    plain = selfplay.evader_cfg(tiny(tmp_path / "y"), 0)
    assert (plain.speed_action, plain.fov_rad) == (False, 2 * math.pi)
    assert plain.select_every == 0


def test_exploitability_by_hand():
    # Per seed: league 0.5, 0.7; best response 0.3, 0.3 -> gains 0.2, 0.4: mean 0.3, sd
    # 0.1414, se 0.1, t(0.975, 1 df) = 12.706: the interval 0.3 +- 1.2706.
    row = exploitability([0.5, 0.7], [0.3, 0.3])
    assert row["seeds"] == 2
    assert row["league"] == pytest.approx(0.6) and row["best_response"] == pytest.approx(0.3)
    assert row["exploitability"] == pytest.approx(0.3)
    half = t_quantile(1) * 0.1
    assert half == pytest.approx(1.2706, abs=1e-4)
    assert row["exploitability_ci"] == pytest.approx([0.3 - half, 0.3 + half])
    assert row["best_response_ci"] == pytest.approx([0.3, 0.3])  # no spread
    one = exploitability([0.5], [0.25])
    assert one["exploitability"] == 0.25 and one["exploitability_ci"] is None
    with pytest.raises(ValueError, match="one value per seed"):
        exploitability([0.5, 0.6], [0.1])
    assert math.isfinite(row["league_ci"][0])
