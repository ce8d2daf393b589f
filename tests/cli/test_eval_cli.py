"""``dyncatch eval`` for the non-learned baselines, through the real entry point."""

import json

from dyncatch.cli.main import main, parse


def test_eval_json_rows(capsys):
    rc = main(
        ["eval", "pursuit", "--behavior", "circle", "--speeds", "0.8", "--episodes", "16", "--json"]
    )
    assert rc == 0
    rows = json.loads(capsys.readouterr().out)["rows"]
    assert len(rows) == 1
    r = rows[0]
    assert (r["method"], r["behavior"], r["speed_mps"], r["episodes"]) == (
        "pursuit",
        "circle",
        0.8,
        16,
    )
    # The pursuer catches slow circle targets (measured 1.00 over 1000 episodes).
    assert r["success_rate"] >= 0.9
    # It catches them in a few seconds (measured 3.2 s), well below the 20 s limit.
    assert 0.0 < r["catch_time_s"] < 10.0


def test_bad_input_is_one_line_error(capsys):
    assert main(["eval", "telepathy"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "telepathy" in err and "pursuit" in err
    assert main(["eval", "pursuit", "--speeds", "-1"]) == 2
    assert "--speeds" in capsys.readouterr().err
    assert main(["eval", "pursuit", "--scan", "plane"]) == 2
    assert "--scan applies to trained runs" in capsys.readouterr().err


def test_a_baseline_deployed_with_the_blend_in_a_room(capsys, monkeypatch):
    """--blend wraps the policy that is evaluated (the evaluation itself is Fig. 9's,
    tested in tests/reproduce/test_fig9.py; here it is replaced to keep the test cheap)."""
    import dyncatch.cli.eval as eval_cli
    from dyncatch.policies.blend import Blended

    seen = []

    def fake(policy, world, behavior, speeds, episodes, seed, method, backend="jax", fullbody=None):
        seen.append((policy, world.scene.name))
        return [{"speed_mps": v, "episodes": episodes} for v in speeds]

    monkeypatch.setattr(eval_cli, "evaluate_speeds", fake)
    argv = ["eval", "pursuit", "--scene", "room_8", "--speeds", "1.0", "--episodes", "4"]
    assert main([*argv, "--blend", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["deployment"] == {"blend": True, "scan": None}
    assert isinstance(seen[0][0], Blended) and seen[0][1] == "room_8"
    assert main([*argv, "--json"]) == 0
    assert not isinstance(seen[1][0], Blended)


def test_the_default_speeds_are_table_i_s():
    assert parse(["eval", "pursuit"])[1].speeds == (0.8, 1.0, 1.2, 1.4, 1.6, 1.8)
