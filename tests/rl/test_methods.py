"""What each method's policy sees."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.model import Predictor
from dyncatch.rl.methods import GROUND_TRUTH, METHODS, MethodObs, method_obs
from dyncatch.sim import env
from dyncatch.sim.api import OBS_DIM
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import world_to_body

WORLD = WorldCfg().with_speed(1.2)


def _state_after(steps):
    s = env.reset(jax.random.key(4), WORLD)
    step = jax.jit(env.step)
    for _ in range(steps):
        s, obs, *_ = step(s, jnp.zeros(3), WORLD)
    return s, obs


def test_registry_holds_the_paper_methods():
    assert set(METHODS) == {
        "rl", "p_rl", "sp_rl", "gt_rl", "sp_fp", "st_rl", "st_fp", "rnn_rl", "rnn_sp_rl"
    }  # fmt: skip
    assert METHODS["sp_fp"].trained_as == "gt_rl"


def test_rl_sees_the_plain_observation_and_gt_rl_the_true_velocity_in_the_base_frame():
    s, obs = _state_after(3)
    # GT-Pred is given where the predictor's input is (two consecutive sightings).
    s = s.replace(sensor=s.sensor.replace(consecutive=jnp.array(True)))
    np.testing.assert_array_equal(method_obs("rl")(s, obs), obs.flat)
    x = method_obs("gt_rl")(s, obs)
    assert x.shape == (OBS_DIM + 3,)
    np.testing.assert_allclose(
        x[OBS_DIM : OBS_DIM + 2], world_to_body(s.target.vel_mps, s.robot.yaw_rad), atol=1e-6
    )
    assert float(x[-1]) == 1.0
    # The speed of the input is the target's speed (1.2 m/s).
    np.testing.assert_allclose(jnp.linalg.norm(x[OBS_DIM : OBS_DIM + 2]), 1.2, atol=1e-5)
    # The layout names every slot: the observation fields, then the velocity inputs.
    layout = method_obs("gt_rl").layout(WORLD)
    assert sum(size for _, size in layout) == x.shape[0]
    assert [name for name, _ in layout[-2:]] == ["target_vel_body_mps", "target_vel_defined"]
    assert sum(size for _, size in method_obs("rl").layout(WORLD)) == OBS_DIM


def test_predictor_input_is_zero_until_two_consecutive_sightings():
    predictor = Predictor.for_world(PredictorCfg(kind="self_aware"), WORLD)
    params = predictor.init(jax.random.key(0))
    f = method_obs("sp_rl", predictor, params)
    s, obs = _state_after(1)
    assert not bool(s.sensor.consecutive)
    x = f(s, obs)
    np.testing.assert_array_equal(x[OBS_DIM:], 0.0)
    s = s.replace(sensor=s.sensor.replace(consecutive=jnp.array(True)))
    x = f(s, obs)
    assert float(x[-1]) == 1.0 and float(jnp.abs(x[OBS_DIM : OBS_DIM + 2]).sum()) > 0


def test_bad_combinations_are_refused_with_the_fix():
    with pytest.raises(ValueError, match="predictor train --kind vanilla"):
        method_obs("p_rl")
    with pytest.raises(ValueError, match="train 'gt_rl'"):
        method_obs("sp_fp")
    predictor = Predictor.for_world(PredictorCfg(kind="vanilla"), WORLD)
    with pytest.raises(ValueError, match="needs a 'self_aware' predictor"):
        method_obs("sp_rl", predictor, predictor.init(jax.random.key(0)))
    with pytest.raises(ValueError, match="unknown method"):
        method_obs("magic")
    assert method_obs(
        "sp_fp",
        predictor=Predictor.for_world(PredictorCfg(kind="self_aware"), WORLD),
        predictor_params={"x": 1},
        evaluation=True,
    ).velocity_input == ("self_aware")


def test_a_predictor_method_trains_one_iteration_with_the_predictor_inside_the_jit():
    from dyncatch.rl.config import PPOCfg
    from dyncatch.rl.train import make_train

    predictor = Predictor.for_world(PredictorCfg(kind="self_aware", hidden=(16,)), WORLD)
    f = method_obs("sp_rl", predictor, predictor.init(jax.random.key(0)))
    ppo = PPOCfg(num_envs=8, num_steps=30, num_minibatches=2, update_epochs=1, hidden_sizes=(16,))
    init, iterate, _ = make_train(WORLD, ppo, f)
    ts, metrics = jax.jit(iterate)(jax.jit(init)(jax.random.key(0)))
    assert ts.norm.mean.shape == (OBS_DIM + 3,)
    assert int(ts.env_steps) == 240
    assert all(bool(jnp.isfinite(v)) for v in jax.tree.leaves(metrics))
    # 30 steps cross a camera frame (step 25): some envs had two consecutive sightings,
    # so the running statistics of the validity flag moved off zero.
    assert float(ts.norm.mean[-1]) > 0.0


def test_stateless_methods_carry_nothing_and_step_is_their_input():
    """The carry seam leaves every method but the tracker's as it was: an empty carry (no
    leaves, so checkpoints hold the same arrays) and ``step`` returning ``__call__``."""
    predictor = Predictor.for_world(PredictorCfg(kind="self_aware"), WORLD)
    params = predictor.init(jax.random.key(0))
    s, obs = _state_after(30)
    for name in ("rl", "gt_rl", "sp_rl"):
        f = method_obs(name, predictor, params) if name == "sp_rl" else method_obs(name)
        assert not f.stateful
        carry = f.init_carry(s)
        assert carry == () and jax.tree.leaves(carry) == []
        carry, x = f.step(carry, s, obs)
        assert carry == ()
        np.testing.assert_array_equal(x, f(s, obs))


def test_a_tracker_policy_resets_its_carry_at_episode_start_inside_the_auto_reset():
    """st_rl trains with the tracker's memory carried per environment. Episodes of 60
    steps, rollouts of 40: after the first rollout (camera frames at steps 0 and 25) some
    memories hold two sightings; after the second every environment is 20 steps into a new
    episode (one frame, at its step 0), so a memory holding more than one sighting, or one
    when the new episode saw nothing, kept the old episode's carry."""
    from dyncatch.predictor.tracker.config import TrackerCfg
    from dyncatch.predictor.tracker.model import Tracker
    from dyncatch.rl.config import PPOCfg
    from dyncatch.rl.methods import TRACK_INPUTS
    from dyncatch.rl.train import make_train

    world = WORLD.replace(episode=WORLD.episode.replace(duration_s=1.2))
    tracker = Tracker.for_world(TrackerCfg(hidden=(8,)), world)
    f = method_obs("st_rl", tracker, tracker.init(jax.random.key(0)))
    assert f.stateful
    ppo = PPOCfg(num_envs=8, num_steps=40, num_minibatches=1, update_epochs=1, hidden_sizes=(8,))
    init, iterate, _ = make_train(world, ppo, f)
    iterate = jax.jit(iterate)
    ts = jax.jit(init)(jax.random.key(0))
    assert not bool(ts.obs_carry.valid.any())
    assert ts.norm.mean.shape == (OBS_DIM + sum(size for _, size, _ in TRACK_INPUTS),)
    ts, _ = iterate(ts)
    assert bool(ts.obs_carry.valid[:, 1].any())
    ts, metrics = iterate(ts)
    assert float(metrics["episodes"]) >= 8
    steps = np.asarray(ts.env_state.step)
    live = steps == 20  # the rest were caught early and restarted later
    assert live.sum() >= 6
    valid = np.asarray(ts.obs_carry.valid)[live]
    assert not valid[:, 1:].any()
    np.testing.assert_array_equal(valid[:, 0], np.asarray(ts.env_state.sensor.ever_seen)[live])


def test_a_time_out_bootstraps_from_the_input_at_its_own_episodes_end():
    """gt_rl reads the target's true velocity from the state: the input PPO bootstraps a
    time-out from is the one at the finished episode's last state, not at the state the
    auto-reset put in its place."""
    from dyncatch.rl.train import step_with_final_input
    from dyncatch.sim.api import as_env
    from dyncatch.sim.vec import batch_reset

    world = WORLD.replace(episode=WORLD.episode.replace(duration_s=0.1))  # 5 steps
    e = as_env(world)
    # Read 'always': 5 steps see no two frames, so the masked reading would be 0 in both.
    f = MethodObs(GROUND_TRUTH, ground_truth="always")
    vstep, vinit = jax.vmap(f.step), jax.vmap(f.init_carry)
    action = jnp.zeros((2, 3))
    state = batch_reset(jax.random.key(1), e, 2)
    carry = vinit(state)
    move = jax.jit(lambda s, c: step_with_final_input(e, vstep, vinit, s, action, c))
    for _ in range(5):
        before = state
        state, _, _, done, info, final_x, carry = move(state, carry)
    assert bool(info["truncated"].all()) and bool(done.all())
    for i in range(2):  # the same last step, by hand, without the auto-reset
        one = jax.tree.map(lambda a, i=i: a[i], before)
        end_state, end_obs, *_ = e.step(one, action[i])
        np.testing.assert_allclose(final_x[i], f(end_state, end_obs), rtol=1e-6, atol=1e-6)
        restarted = jax.tree.map(lambda a, i=i: a[i], state)
        assert not np.allclose(final_x[i], f(restarted, end_obs))  # what the bug read


class TestGroundTruthReading:
    """GT-Pred under the predictor's availability rule, and a normaliser that never
    amplifies an input it saw no spread of (issue 31)."""

    def test_the_oracle_is_masked_like_the_predictor(self):
        s, obs = _state_after(1)
        assert not bool(s.sensor.consecutive)
        np.testing.assert_array_equal(method_obs("gt_rl")(s, obs)[OBS_DIM:], 0.0)

        always = MethodObs(GROUND_TRUTH, ground_truth="always")(s, obs)
        assert float(always[-1]) == 1.0
        seen = s.replace(sensor=s.sensor.replace(consecutive=jnp.array(True)))
        x = method_obs("gt_rl")(seen, obs)
        assert float(x[-1]) == 1.0
        np.testing.assert_allclose(
            x[OBS_DIM : OBS_DIM + 2], world_to_body(s.target.vel_mps, s.robot.yaw_rad), atol=1e-6
        )

    @pytest.mark.parametrize("reading", ["when_predicted", "always"])
    def test_a_trained_gt_rl_policy_feeds_a_bounded_input_with_the_flag_at_0(self, reading):
        from dyncatch.rl.config import PPOCfg
        from dyncatch.rl.train import make_train

        f = MethodObs(GROUND_TRUTH, ground_truth=reading)
        # `always` needs the (optional) floor on the normaliser's scale; the default reading
        # keeps the flag in its training range without one.
        ppo = PPOCfg(
            num_envs=16,
            num_steps=40,
            num_minibatches=1,
            update_epochs=1,
            hidden_sizes=(8,),
            obs_min_std=0.5 if reading == "always" else 0.0,
        )
        init, iterate, _ = make_train(WORLD, ppo, f)
        ts = jax.jit(init)(jax.random.key(0))
        for _ in range(2):
            ts, _ = jax.jit(iterate)(ts)
        flag_std = float(jnp.sqrt(ts.norm.var[-1]))
        if reading == "always":
            # The flag never varied: without the floor, 0 would land on the clip (-10).
            assert flag_std < 1e-3
            assert float(ts.norm.replace(min_std=0.0)(jnp.zeros_like(ts.norm.mean))[-1]) == -10.0
        else:
            assert flag_std > 0.1
        z = ts.norm(ts.norm.mean.at[-1].set(0.0))
        # |0 - mean| <= 1; the scale is >= the floor 0.5 (`always`) or the flag's own training
        # spread, > 0.1 (`when_predicted`): at most 2 or 10 from the training mean, not the clip.
        bound = 1 / ppo.obs_min_std if ppo.obs_min_std > 0 else 1 / flag_std
        assert abs(float(z[-1])) <= bound + 1e-6
        assert abs(float(z[-1])) < 10.0
