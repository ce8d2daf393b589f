"""The evader's environment and trainer: the protocol, the reward by hand, PPO over it, and a
trained checkpoint that runs as the ``learned`` behaviour with the trainer's own numbers."""

import dataclasses
import json
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from safetensors.numpy import load_file

from dyncatch.cli.main import main
from dyncatch.policies.intercept import intercept_policy
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.evader import EvaderRewardCfg, evader_env
from dyncatch.rl.evader_train import (
    LAST_CHECKPOINT,
    SELECTION_FILE,
    TRAIN_STATE,
    EvaderTrainCfg,
    evader_net_of,
    held_out_escape,
    resumable,
    train_evader,
)
from dyncatch.rl.train import make_train, to_command
from dyncatch.sim import env as sim_env
from dyncatch.sim.api import Environment
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT
from dyncatch.sim.behaviors.learned import EVADER_OBS_DIM, evader_net
from dyncatch.sim.behaviors.reactive import flee_and_dodge
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world
from dyncatch.utils.tree_io import read_header

TINY = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=1, hidden_sizes=(16,))
WORLD = WorldCfg().with_speed(1.6)


@pytest.fixture(scope="module")
def env():
    return evader_env(WORLD, pursuit_policy(WORLD))


class TestEnvironment:
    def test_is_an_environment(self, env):
        assert isinstance(env, Environment)
        assert env.world.target.behavior == "commanded"
        assert env.action_spec.shape == (1,) and env.observation_spec.shape == (EVADER_OBS_DIM,)
        assert env.with_world(WorldCfg()).world.target.behavior == "commanded"

    def test_step_reward_by_hand(self, env):
        s = env.reset(jax.random.key(0))
        s1, obs, reward, done, info = jax.jit(env.step)(s, jnp.array([0.3]))
        assert obs.flat.shape == (EVADER_OBS_DIM,)
        assert not bool(info["caught"]) and not bool(done)
        # Uncaught: 1 / max_steps for being alive plus 0.1 x the distance gained.
        gained = float(s1.world.distance_m - s.world.distance_m)
        want = 1.0 / WORLD.episode.max_steps + 0.1 * gained
        assert float(reward) == pytest.approx(want, rel=1e-5)
        for key in ("success", "terminated", "truncated", "reward/alive", "reward/caught"):
            assert key in info
        # The target turned by the action (under the turn-rate limit) and runs at the cap.
        assert float(s1.world.target.behavior_state.turn_rad) == pytest.approx(0.3)
        assert float(s1.world.target.speed_mps) == pytest.approx(1.6)

    def test_a_catch_pays_the_penalty_and_ends_the_episode(self):
        # A target standing still next to the robot is caught.
        world = WorldCfg().with_speed(0.0)
        reward = EvaderRewardCfg(distance_per_m=0.0)
        env = evader_env(world, pursuit_policy(world), reward)
        step = jax.jit(env.step)
        s = env.reset(jax.random.key(5))
        for _ in range(world.episode.max_steps):
            s, _, r, done, info = step(s, jnp.zeros(1))
            if bool(done):
                break
        assert bool(info["caught"]) and bool(info["terminated"]) and not bool(info["success"])
        assert float(r) == pytest.approx(-1.0)


class TestActionSpace:
    def test_turn_limit_spans_the_action(self):
        env = evader_env(WORLD, pursuit_policy(WORLD), turn_limit_rad=0.1)
        assert float(env.action_spec.high[0]) == pytest.approx(0.1)
        assert float(env.action_spec.low[0]) == pytest.approx(-0.1)
        s = env.reset(jax.random.key(0))
        s1 = jax.jit(env.step)(s, jnp.array([0.5]))[0]  # beyond the limit: clipped
        assert float(s1.world.target.behavior_state.turn_rad) == pytest.approx(0.1)
        heading = s1.world.target.heading_rad - s.world.target.heading_rad
        assert float(jnp.angle(jnp.exp(1j * heading))) == pytest.approx(0.1, abs=1e-5)

    def test_flee_frame_heads_off_the_flee_direction(self):
        env = evader_env(WORLD, pursuit_policy(WORLD), action_frame="flee")
        s = env.reset(jax.random.key(3))
        d = np.asarray(s.world.target.xy_m - s.world.robot.xy_m)
        flee = math.atan2(d[1], d[0])
        for angle in (0.0, 1.0, -2.5):
            s1 = jax.jit(env.step)(s, jnp.array([angle]))[0]
            want = math.remainder(flee + angle - float(s.world.target.heading_rad), math.tau)
            assert float(s1.world.target.behavior_state.turn_rad) == pytest.approx(want, abs=1e-5)

    def test_reactive_frame_at_zero_plays_eq_11_12_without_gamma(self):
        env = evader_env(WORLD, intercept_policy(WORLD), action_frame="reactive")
        starts = [env.reset(jax.random.key(k)) for k in range(8)]
        near = min(starts, key=lambda s: float(s.world.distance_m))
        far = max(starts, key=lambda s: float(s.world.distance_m))
        step = jax.jit(env.step)
        dodged = 0
        for s in (near, far):
            for _ in range(30):
                t, r = s.world.target, s.world.robot
                want = math.remainder(float(flee_and_dodge(t, r, WORLD) - t.heading_rad), math.tau)
                dodged += float(s.world.distance_m) <= WORLD.target.evade_radius_m
                s = step(s, jnp.zeros(1))[0]
                turn = float(s.world.target.behavior_state.turn_rad)
                assert turn == pytest.approx(want, abs=1e-5)
        assert 0 < dodged < 60  # both branches of eq. 12 were played

    def test_refuses_an_unknown_frame_and_a_bad_limit(self):
        with pytest.raises(ValueError, match="action frame 'up'"):
            evader_env(WORLD, pursuit_policy(WORLD), action_frame="up")
        with pytest.raises(ValueError, match="turn_limit_rad 0.0"):
            evader_env(WORLD, pursuit_policy(WORLD), turn_limit_rad=0.0)


def test_a_mixture_plays_the_drawn_pursuer():
    pursuers = [pursuit_policy(WORLD), intercept_policy(WORLD)]
    mixed = evader_env(WORLD, pursuers)
    alone = evader_env(WORLD, pursuers[1])
    states = jax.vmap(mixed.reset)(jax.random.split(jax.random.key(0), 64))
    drawn = np.asarray(states.pursuer_index)
    assert set(drawn) == {0, 1}
    i = int(np.argmax(drawn == 1))
    s = jax.tree.map(lambda x: x[i], states)
    carries = s.pursuer_carries[1:]
    single = s.replace(pursuer_index=jnp.zeros((), jnp.int32), pursuer_carries=carries)
    a = jax.jit(mixed.step)(s, jnp.array([0.1]))[0]
    b = jax.jit(alone.step)(single, jnp.array([0.1]))[0]
    np.testing.assert_allclose(a.world.robot.vel_body_mps, b.world.robot.vel_body_mps, atol=1e-6)
    np.testing.assert_allclose(a.world.target.xy_m, b.world.target.xy_m, atol=1e-6)


def test_ppo_trains_it_unchanged(env):
    init, iterate, _ = make_train(env, TINY)
    ts = jax.jit(init)(jax.random.key(0))
    iterate = jax.jit(iterate)
    for _ in range(3):
        ts, m = iterate(ts)
        assert all(np.isfinite(float(v)) for v in m.values())
    assert int(ts.env_steps) == 3 * TINY.batch_size


def test_exported_actor_is_the_trainers_mean_turn(env):
    init, iterate, net = make_train(env, TINY)
    ts, _ = jax.jit(iterate)(jax.jit(init)(jax.random.key(1)))
    exported = evader_net_of(ts, {})
    x = jax.random.normal(jax.random.key(2), (32, EVADER_OBS_DIM)) * 3.0
    mean, _, _ = net.apply(ts.params, ts.norm(x))
    want = jax.vmap(lambda m: to_command(m, env))(mean)[:, 0]
    got = jax.vmap(exported.mean_turn)(x)
    np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-5)
    log_std = float(ts.params["params"]["log_std"][0])
    assert exported.action_std == pytest.approx(np.exp(log_std))
    flee = evader_net_of(ts, {}, 0.5, "flee")
    assert (flee.turn_limit_rad, flee.action_frame) == (0.5, "flee")
    assert (exported.turn_limit_rad, exported.action_frame) == (math.pi, "heading")


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    out = tmp_path_factory.mktemp("evader")
    cfg = EvaderTrainCfg(total_steps=2 * TINY.batch_size, out=out, ppo=TINY, world=WORLD)
    metrics = train_evader(cfg)
    return cfg, metrics


class TestTrainEvader:
    def test_writes_a_checkpoint_the_behaviour_loads(self, trained):
        cfg, metrics = trained
        assert np.isfinite(metrics["reward_per_step"])
        world = WORLD.with_behavior("learned")
        world = validate_world(
            world.replace(target=world.target.replace(evader_checkpoint=str(cfg.out)))
        )
        net = evader_net(world)
        assert net.header["against"] == ["pursuit"] and net.header["env_steps"] == 128  # 2 x 8 x 8
        assert [k.shape for k, _ in net.layers] == [(EVADER_OBS_DIM, 16), (16, 1)]
        # An episode through the ordinary step, twice from one key: the same trajectory.
        run = jax.jit(lambda key: _episode(key, world))
        a, b = run(jax.random.key(7)), run(jax.random.key(7))
        for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
        assert np.all(np.isfinite(np.asarray(a[0])))

    def test_refuses_an_existing_run_and_an_unknown_pursuer(self, trained):
        cfg, _ = trained
        with pytest.raises(ValueError, match="exists"):
            train_evader(cfg)
        with pytest.raises(ValueError, match=r"--against \['nobody'\]"):
            train_evader(dataclasses.replace(cfg, against=("pursuit", "nobody")))

    def test_cli_names_the_fix_for_a_missing_checkpoint(self, capsys, tmp_path):
        rc = main(
            [
                "eval",
                "pursuit",
                "--speeds",
                "1.6",
                "--episodes",
                "2",
                "--behavior",
                "learned",
                "--world.target.evader-checkpoint",
                str(tmp_path / "x"),
            ]
        )
        assert rc == 2
        assert "--world.target.evader-checkpoint" in capsys.readouterr().err


def _episode(key, world):
    """100 steps of the pursuit policy against the learned target: target xy, caught."""
    policy = pursuit_policy(world)
    s = sim_env.reset(key, world)

    def body(s, k):
        action = policy(sim_env.observe(s, world), k)
        s, _, _, _, info = sim_env.step(s, action, world)
        return s, (s.target.xy_m + s.origin_xy_m, info["success"])

    return jax.lax.scan(body, s, jax.random.split(key, 100))[1]


def test_cli_trains_an_evader_with_a_speed_action(tmp_path):
    out = tmp_path / "run"
    rc = main(
        [
            "evader",
            "train",
            "--total-steps",
            "128",
            "--out",
            str(out),
            "--ppo.num-envs",
            "8",
            "--ppo.num-steps",
            "16",
            "--ppo.hidden-sizes",
            "8",
            "--speed-action",
        ]
    )
    assert rc == 0 and (out / EVADER_CHECKPOINT).exists() and (out / "metrics.csv").exists()
    world = WorldCfg().with_behavior("learned")
    world = validate_world(world.replace(target=world.target.replace(evader_checkpoint=str(out))))
    net = evader_net(world)
    assert net.speed_action and net.speed_action_std > 0 and net.layers[-1][0].shape == (8, 2)
    assert net.header["features"][-1] == "speed_cap_mps"


def test_an_exported_speed_action_is_the_trainers():
    env = evader_env(WORLD, pursuit_policy(WORLD), speed_action=True)
    init, _, net = make_train(env, TINY)
    ts = jax.jit(init)(jax.random.key(1))
    exported = evader_net_of(ts, {}, speed_action=True)
    x = jax.random.normal(jax.random.key(2), (16, EVADER_OBS_DIM + 1)) * 3.0
    mean, _, _ = net.apply(ts.params, ts.norm(x))
    want = jax.vmap(lambda m: to_command(m, env))(mean)
    got = jax.vmap(exported.action_mean)(x)
    np.testing.assert_allclose(got[:, 0] * math.pi, want[:, 0], rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(jnp.clip(got[:, 1], -1, 1), want[:, 1], rtol=1e-5, atol=1e-5)
    std = np.exp(np.asarray(ts.params["params"]["log_std"]))
    assert (exported.action_std, exported.speed_action_std) == pytest.approx(tuple(std))


def test_an_evader_with_a_field_of_view_observes_whether_it_sees_the_robot():
    import math

    from dyncatch.sim.behaviors.learned import FOV_FEATURE_NAMES

    env = evader_env(WORLD, pursuit_policy(WORLD), fov_rad=math.radians(120.0))
    assert env.observation_spec.shape == (len(FOV_FEATURE_NAMES),)
    s = env.reset(jax.random.key(0))
    obs = env.observe(s)
    assert obs.flat.shape == (len(FOV_FEATURE_NAMES),) and float(obs.flat[-1]) in (0.0, 1.0)
    for bad in (0.0, -1.0, 7.0):
        with pytest.raises(ValueError, match="field of view"):
            evader_env(WORLD, pursuit_policy(WORLD), fov_rad=bad)


def test_an_evader_trained_with_a_field_of_view_runs_as_the_learned_target(tmp_path):
    import math

    from dyncatch.sim.behaviors.learned import FOV_FEATURE_NAMES

    fov = math.radians(120.0)
    cfg = EvaderTrainCfg(
        total_steps=TINY.batch_size, out=tmp_path, ppo=TINY, world=WORLD, fov_rad=fov
    )
    train_evader(cfg)
    world = WORLD.with_behavior("learned")
    world = validate_world(
        world.replace(target=world.target.replace(evader_checkpoint=str(tmp_path)))
    )
    net = evader_net(world)
    assert net.fov_rad == pytest.approx(fov) and net.header["features"] == list(FOV_FEATURE_NAMES)
    assert net.layers[0][0].shape[0] == len(FOV_FEATURE_NAMES)
    assert np.all(np.isfinite(np.asarray(_episode(jax.random.key(3), world)[0])))
    with pytest.raises(ValueError, match="--fov-rad"):
        train_evader(dataclasses.replace(cfg, out=tmp_path / "x", fov_rad=0.0))


def test_select_every_keeps_the_best_held_out_iterate(tmp_path):
    world = WORLD.replace(episode=WORLD.episode.replace(duration_s=2.0))
    cfg = EvaderTrainCfg(
        total_steps=3 * TINY.batch_size,
        out=tmp_path,
        ppo=TINY,
        world=world,
        select_every=2,
        select_episodes=6,
    )
    metrics = train_evader(cfg)
    sel = json.loads((tmp_path / SELECTION_FILE).read_text())
    assert sel["iterations"] == [2, 3] and sel["episodes"] == 6  # every 2nd, and the last
    assert all(round(e * 6, 6) == int(round(e * 6)) for e in sel["escape"])  # shares of 6
    best = int(np.argmax(sel["escape"]))  # the first of equals: only a better one replaces it
    chosen = sel["iterations"][best]
    assert (sel["selected_iteration"], sel["selected_escape"]) == (chosen, sel["escape"][best])
    assert metrics["held_out_escape"] == sel["escape"][-1]
    assert read_header(tmp_path / EVADER_CHECKPOINT)["iteration"] == chosen
    assert read_header(tmp_path / LAST_CHECKPOINT)["iteration"] == 3
    log = (tmp_path / "metrics.csv").read_text().splitlines()
    column = log[0].split(",").index("held_out_escape")
    assert [r.split(",")[column] for r in log[1:]] == ["nan", *map(str, sel["escape"])]
    # The score is the deterministic evader's (the mean action, as deployed): the policy's
    # spread changes nothing.
    env = evader_env(world, pursuit_policy(world))
    init, _, net = make_train(env, TINY)
    ts = jax.jit(init)(jax.random.key(0))
    wide = ts.replace(params=jax.tree.map(lambda x: x, ts.params))
    wide.params["params"]["log_std"] = ts.params["params"]["log_std"] + 3.0
    key = jax.random.key(3)
    assert held_out_escape(ts, net, env, key, 16) == held_out_escape(wide, net, env, key, 16)


def _files(out):
    """A run folder's numbers: metrics.csv less its clock, selection.json, every array."""
    rows = [r.split(",") for r in (out / "metrics.csv").read_text().splitlines()]
    clock = rows[0].index("time_s")
    arrays = {
        name: load_file(out / name) for name in (EVADER_CHECKPOINT, LAST_CHECKPOINT, TRAIN_STATE)
    }
    selection = json.loads((out / SELECTION_FILE).read_text())
    return [r[:clock] + r[clock + 1 :] for r in rows], selection, arrays


def test_a_resumed_run_is_the_uninterrupted_one(tmp_path):
    # Four iterations straight, against two and then --resume to four (a longer
    # --total-steps may be given on resume): the same rows, candidates and arrays, with the
    # best iterate selected every 2nd iteration.
    world = WORLD.replace(episode=WORLD.episode.replace(duration_s=2.0))
    steps = TINY.batch_size
    cfg = EvaderTrainCfg(
        total_steps=4 * steps, out=tmp_path / "a", ppo=TINY, world=world, select_every=2,
        select_episodes=6, checkpoint_every=3,
    )  # fmt: skip
    straight = train_evader(cfg)
    half = dataclasses.replace(cfg, out=tmp_path / "b", total_steps=2 * steps)
    train_evader(half)
    assert read_header(tmp_path / "b" / TRAIN_STATE)["seed"] == 0
    with pytest.raises(ValueError, match="pass --resume"):
        train_evader(dataclasses.replace(half, total_steps=4 * steps))
    with pytest.raises(ValueError, match=r"--seed \(0 -> 1\)"):
        train_evader(dataclasses.replace(half, seed=1, resume=True))
    resumed = train_evader(dataclasses.replace(half, total_steps=4 * steps, resume=True))
    assert {k: v for k, v in resumed.items() if k != "time_s"} == {
        k: v for k, v in straight.items() if k != "time_s"
    }
    (rows_a, sel_a, arrays_a), (rows_b, sel_b, arrays_b) = _files(cfg.out), _files(half.out)
    assert rows_a == rows_b and len(rows_a) == 5 and sel_a == sel_b
    for name, arrays in arrays_a.items():
        assert arrays.keys() == arrays_b[name].keys()
        for k, v in arrays.items():
            np.testing.assert_array_equal(v, arrays_b[name][k], err_msg=f"{name} {k}")
    # Resumed at its end, it trains nothing and returns its last row.
    again = train_evader(dataclasses.replace(half, total_steps=4 * steps, resume=True))
    assert again["success_rate"] == straight["success_rate"]
    with pytest.raises(ValueError, match="is missing"):
        train_evader(dataclasses.replace(cfg, out=tmp_path / "c", resume=True))
    # A cached pipeline's stage (the self-play rounds) continues a matching state and
    # clears a folder whose state was made otherwise.
    assert resumable(dataclasses.replace(half, total_steps=8 * steps)).resume
    other = resumable(dataclasses.replace(half, seed=1))
    assert not other.resume and not half.out.exists()


@pytest.mark.parametrize(("field", "value"), [("select_every", -1), ("select_episodes", 0)])
def test_bad_selection_flags_are_refused_naming_them(tmp_path, field, value):
    cfg = EvaderTrainCfg(out=tmp_path / "x", ppo=TINY, world=WORLD, **{field: value})
    with pytest.raises(ValueError, match="--select-every") as err:
        train_evader(cfg)
    assert "--select-episodes" in str(err.value) and not (tmp_path / "x").exists()
