"""``--scene`` on every command: one alias of ``world.scene.name``, choices read from SCENES."""

import json

import pytest

from dyncatch.cli.commands import COMMANDS, Group
from dyncatch.cli.main import main, parse
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SCENES
from dyncatch.sim.validate import ConfigError, validate_world

# The arguments that reach each command (eval needs its positional target).
PREFIXES = {
    "demo": ["demo"],
    "render": ["render"],
    "train": ["train"],
    "eval": ["eval", "pursuit"],
    "evader train": ["evader", "train"],
    "evader selfplay": ["evader", "selfplay"],
    "reproduce": ["reproduce"],
    "bench env": ["bench", "env"],
    "bench ppo": ["bench", "ppo"],
    "predictor train": ["predictor", "train"],
    "predictor table": ["predictor", "table"],
    "predictor score": ["predictor", "score", "p.safetensors"],
}


def test_every_command_that_holds_a_world_is_listed():
    import dataclasses

    commands = {
        (f"{name} {sub}" if isinstance(c, Group) else name): (
            c.commands[sub] if isinstance(c, Group) else c
        )
        for name, c in COMMANDS.items()
        for sub in (c.commands if isinstance(c, Group) else [None])
    }
    with_world = {
        name
        for name, c in commands.items()
        if "world" in {f.name for f in dataclasses.fields(c.spec)}
    }
    assert with_world == set(PREFIXES)
    # export and plot read their runs' worlds and take no --scene; bench gait simulates the
    # full body in MuJoCo, which has no catch world; bench machine times a fixed program.
    assert set(commands) - with_world == {"export", "plot", "bench gait", "bench machine"}


@pytest.mark.parametrize("command", sorted(PREFIXES))
def test_scene_flag_sets_the_world_scene(command):
    _, default = parse(PREFIXES[command])
    assert default.world.scene.name == "open_plane"  # the paper's Table I setting
    for scene in SCENES:
        _, cmd = parse([*PREFIXES[command], "--scene", scene])
        assert cmd.world.scene.name == scene
        # The long form is the same field.
        _, long = parse([*PREFIXES[command], "--world.scene.name", scene])
        assert long.world == cmd.world


def test_reproduce_quick_keeps_the_scene():
    _, plan = parse(["reproduce", "--quick", "--scene", "open_plane"])
    assert plan.world.scene.name == "open_plane"


def test_unknown_scene_names_the_choices(capsys):
    with pytest.raises(SystemExit) as exit_:
        parse(["eval", "pursuit", "--scene", "moon"])
    assert exit_.value.code == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "moon" in err and "arena, open_plane" in err
    with pytest.raises(ConfigError, match=r"scene\.name.*'moon'.*arena, open_plane"):
        validate_world(WorldCfg().with_scene("moon"))


def test_eval_pursuit_on_the_open_plane(capsys):
    argv = ["eval", "pursuit", "--scene", "open_plane", "--behavior", "reactive"]
    assert main([*argv, "--speeds", "1.8", "--episodes", "300", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    (row,) = out["rows"]
    assert (row["behavior"], row["speed_mps"], row["episodes"]) == ("reactive", 1.8, 300)
    # With no wall to corner it against, a 1.8 m/s reactive target is out of the pursuer's
    # reach: measured 0.000 here (1000 episodes: docs/model.md, Scenes), 0.43 in the arena.
    assert row["success_rate"] <= 0.02


def test_bench_env_rows_name_their_scene(monkeypatch, capsys):
    from dyncatch.bench import env_bench

    # The row building, not the timing: the two measurements are stubbed.
    monkeypatch.setattr(env_bench, "jax_steps_per_s", lambda cfg, n: 1000.0 * n)
    monkeypatch.setattr(env_bench, "gym_loop_steps_per_s", lambda cfg: 10.0)
    argv = ["bench", "env", "--json", "--scene", "room_8", "--world.scene.scan-rays", "32"]
    assert main([*argv, "--num-envs", "4", "16"]) == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert [(r["backend"], r["num_envs"]) for r in rows] == [
        ("jax", 4),
        ("jax", 16),
        ("gym_loop", 1),
    ]
    assert all((r["scene"], r["scan_rays"]) == ("room_8", 32) for r in rows)
