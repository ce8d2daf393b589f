"""CatchEnv: gymnasium's checker, seeding, parity with the pure simulator, clipping, and every
observation of random rollouts inside the observation space."""

from __future__ import annotations

import warnings

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from hypothesis import assume, given, settings
from hypothesis import strategies as st

import dyncatch  # noqa: F401  (registers the gymnasium ids)
from dyncatch.gym import CATCH_ID
from dyncatch.gym.catch_env import CatchEnv, seed_to_key
from dyncatch.sim import env as sim_env
from dyncatch.sim.api import obs_dim
from dyncatch.sim.behaviors import scripted_behaviors
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import Obs
from dyncatch.sim.validate import ConfigError

NUM_STEPS = 20
# check_env warns about these by design: the target's observed position and the time since
# the last sighting have no finite bound (sim/obs_bounds.py), and the action is the physical
# command (vx in [-1, 2] m/s, ...), not a normalised one.
EXPECTED_WARNINGS = ("infinity", "symmetric and normalized")


def _with_staleness(world: WorldCfg) -> WorldCfg:
    """``world`` with every ``Obs`` field in ``flat`` (reading ``staleness_observation``), so
    a bounds test covers the staleness inputs too."""
    return world.replace(observation=world.observation.replace(staleness_inputs=True))


_LAYOUT = Obs.layout(WorldCfg().scene.scan_rays, staleness=True)
_OFFSETS = dict(
    zip(
        [name for name, _ in _LAYOUT],
        np.cumsum([0] + [size for _, size in _LAYOUT])[:-1],
        strict=True,
    )
)
VEL = slice(int(_OFFSETS["robot_vel_body_mps"]), int(_OFFSETS["robot_vel_body_mps"]) + 3)
"""robot_vel_body_mps (2) and robot_yaw_rate_rps (1) in ``Obs.flat`` (either layout)."""
TIME = int(_OFFSETS["time_since_seen_s"])
"""time_since_seen_s in ``Obs.flat`` with the staleness inputs."""


def fixed_actions(num_steps: int = NUM_STEPS) -> np.ndarray:
    """A varied command sequence inside the limits, (num_steps, 3)."""
    t = np.arange(num_steps, dtype=np.float32)[:, None]
    return np.array([1.5, 0.6, 1.2], np.float32) * np.sin(0.3 * t + np.array([0.0, 1.0, 2.0]))


def rollout(env: CatchEnv, seed: int, actions: np.ndarray):
    """(obs (T+1, D), rewards (T,), infos [T]) from reset(seed) under ``actions``."""
    obs, _ = env.reset(seed=seed)
    all_obs, rewards, infos = [obs], [], []
    for action in actions:
        obs, reward, _, _, info = env.step(action)
        all_obs.append(obs)
        rewards.append(reward)
        infos.append(info)
    return np.stack(all_obs), np.array(rewards), infos


@pytest.fixture(scope="module")
def made_envs() -> dict[str, CatchEnv]:
    """One CatchEnv per behaviour, built through gymnasium.make (compiles once each)."""
    names = scripted_behaviors()
    return {name: gymnasium.make(CATCH_ID, behavior=name).unwrapped for name in names}


@pytest.fixture(scope="module")
def env(made_envs) -> CatchEnv:
    return made_envs["reactive"]


class TestGymnasiumApi:
    @pytest.mark.parametrize("behavior", sorted(scripted_behaviors()))
    def test_check_env_passes(self, made_envs, behavior):
        env = made_envs[behavior]
        assert env.world.target.behavior == behavior
        assert env.spec is not None and env.spec.id == CATCH_ID
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env)
        unexpected = [
            str(w.message)
            for w in caught
            if not any(text in str(w.message) for text in EXPECTED_WARNINGS)
        ]
        assert unexpected == []

    def test_spaces(self, env):
        assert env.observation_space.shape == (13,)  # the paper's s: no staleness inputs
        assert env.observation_space.dtype == np.float32
        np.testing.assert_array_equal(env.action_space.low, [-1.0, -1.0, -2.0])
        np.testing.assert_array_equal(env.action_space.high, [2.0, 1.0, 2.0])

    @pytest.mark.parametrize(("scene", "rays"), [("arena", 8), ("arena", 12), ("open_plane", 3)])
    def test_observation_space_follows_the_scan(self, scene, rays):
        # 5 egocentric values (velocity 2, yaw rate 1, sighting 2) + rays; age 1 and
        # visible 1 more under staleness_observation.
        world = WorldCfg().with_scene(scene)
        world = world.replace(scene=world.scene.replace(scan_rays=rays))
        assert obs_dim(world) == 5 + rays and obs_dim(_with_staleness(world)) == 7 + rays
        env = CatchEnv(world=world)
        assert env.observation_space.shape == (5 + rays,)
        obs, _ = env.reset(seed=0)
        assert obs.shape == (5 + rays,) and env.observation_space.contains(obs)
        obs, *_ = env.step(np.zeros(3, np.float32))
        assert obs.shape == (5 + rays,)
        stale = CatchEnv(world=_with_staleness(world))
        assert stale.observation_space.shape == (7 + rays,)
        assert stale.reset(seed=0)[0].shape == (7 + rays,)

    def test_step_returns_python_scalars(self, env):
        env.reset(seed=0)
        obs, reward, terminated, truncated, info = env.step(np.zeros(3, np.float32))
        assert obs.dtype == np.float32 and obs.shape == (13,)
        assert type(reward) is float and type(terminated) is bool and type(truncated) is bool
        assert type(info["success"]) is bool and type(info["distance_m"]) is float

    def test_the_reward_is_eq_9_with_the_default_weights(self, env):
        # Seed 2 under a forward turn keeps the target in view, so the visibility term counts.
        env.reset(seed=2)
        seen = 0.0
        for _ in range(10):
            _, reward, _, _, info = env.step(np.array([1.0, 0.0, 0.5], np.float32))
            # Eq. 9 in the default world: w1 = 1, w2 = 0.2 per s x 0.02 s = 0.004, w3 = 5.
            expected = (
                1.0 * info["reward/pursuit"]
                + 0.004 * info["reward/visibility"]
                + 5.0 * info["reward/success"]
            )
            assert reward == pytest.approx(expected, abs=1e-7)
            seen += info["reward/visibility"]
        assert seen == 10.0

    def test_truncates_itself_at_the_episode_limit(self, env):
        # 0.2 s at 50 Hz = 10 steps; duration_s is a traced leaf, so this does not recompile.
        world = env.world.replace(episode=env.world.episode.replace(duration_s=0.2))
        short = CatchEnv(world=world)
        short.reset(seed=1)
        truncations = [short.step(np.zeros(3, np.float32))[3] for _ in range(10)]
        assert truncations == [False] * 9 + [True]


class TestSeeding:
    def test_same_seed_same_trajectory(self, env):
        actions = fixed_actions()
        obs_a, rew_a, info_a = rollout(env, 7, actions)
        obs_b, rew_b, info_b = rollout(env, 7, actions)
        np.testing.assert_array_equal(obs_a, obs_b)
        np.testing.assert_array_equal(rew_a, rew_b)
        assert info_a == info_b

    def test_other_seed_other_start(self, env):
        obs_7, _ = env.reset(seed=7)
        obs_8, _ = env.reset(seed=8)
        assert np.abs(obs_7 - obs_8).max() > 0.1

    def test_unseeded_resets_follow_the_seed(self, env):
        def two_resets():
            # The observation, and where the target starts relative to the robot (on the open
            # plane the first observation may hold no sighting, so it can repeat).
            return [(env.reset()[0], np.asarray(env.state.target.xy_m)) for _ in range(2)]

        env.reset(seed=3)
        first = two_resets()
        env.reset(seed=3)
        second = two_resets()
        for (obs_a, xy_a), (obs_b, xy_b) in zip(first, second, strict=True):
            np.testing.assert_array_equal(obs_a, obs_b)
            np.testing.assert_array_equal(xy_a, xy_b)
        assert np.abs(first[0][1] - first[1][1]).max() > 0.1

    def test_seed_to_key(self):
        for seed in (0, 1, 123, 2**32 - 1):
            np.testing.assert_array_equal(seed_to_key(seed), jax.random.PRNGKey(seed))
        keys = {tuple(np.asarray(seed_to_key(s)).tolist()) for s in (0, 5, 2**32, 2**32 + 5, 2**70)}
        assert len(keys) == 5
        with pytest.raises(ValueError, match="non-negative"):
            seed_to_key(-1)


def test_matches_pure_simulator(env):
    """20 steps of CatchEnv equal sim.env.reset/step from PRNGKey(seed), each jitted on its
    own (eagerly, every operation of a step compiles on its own)."""
    seed, actions = 11, fixed_actions()
    obs, rewards, infos = rollout(env, seed, actions)

    reset, observe, step = (jax.jit(f) for f in (sim_env.reset, sim_env.observe, sim_env.step))
    state = reset(jax.random.PRNGKey(seed), env.world)
    np.testing.assert_allclose(obs[0], observe(state, env.world).flat, atol=1e-5)
    for t, action in enumerate(actions):
        state, ref_obs, ref_reward, ref_done, ref_info = step(state, jnp.asarray(action), env.world)
        np.testing.assert_allclose(obs[t + 1], ref_obs.flat, atol=1e-5)
        np.testing.assert_allclose(rewards[t], ref_reward, atol=1e-5)
        np.testing.assert_allclose(infos[t]["distance_m"], ref_info["distance_m"], atol=1e-5)
        assert infos[t]["terminated"] == bool(ref_info["terminated"])
        assert infos[t]["truncated"] == bool(ref_info["truncated"])
        assert bool(ref_done) is False


def test_obs_in_space_and_actions_clipped(env):
    """Commands 5x the limits, held 1 s each: the base never goes faster than the limits.

    Gait noise is clipped to the command limits too, so the bound is exact everywhere.
    """
    high = env.action_space.high.astype(np.float64)
    low = env.action_space.low.astype(np.float64)
    margin = 1e-5
    rng = np.random.default_rng(0)
    velocities = []
    for seed in range(4):
        obs, _ = env.reset(seed=seed)
        for _ in range(6):
            action = (rng.choice([-5.0, 5.0], size=3) * high).astype(np.float32)
            for _ in range(50):
                obs, *_ = env.step(action)
                assert env.observation_space.contains(obs), obs
                velocities.append(obs[0:3])  # base velocity (2) and yaw rate
    velocities = np.array(velocities)
    assert np.all(velocities <= high + margin)
    assert np.all(velocities >= low - margin)
    # The commands did act: the base reached its forward and backward limits.
    assert velocities[:, 0].max() > high[0] - 0.2
    assert velocities[:, 0].min() < low[0] + 0.2


class TestConfigErrors:
    def test_unknown_behavior(self):
        with pytest.raises(ValueError, match="unknown behavior 'zigzag'.*circle"):
            CatchEnv(behavior="zigzag")

    def test_bad_speed(self):
        with pytest.raises(ConfigError, match="speed_min_mps"):
            CatchEnv(speed_mps=-1.0)

    def test_speed_and_behavior_applied(self):
        cfg = CatchEnv(behavior="circle", speed_mps=1.2).world
        assert cfg.target.behavior == "circle"
        assert (cfg.target.speed_min_mps, cfg.target.speed_max_mps) == (1.2, 1.2)

    def test_step_before_reset(self):
        with pytest.raises(RuntimeError, match="reset"):
            CatchEnv().step(np.zeros(3, np.float32))

    def test_wrong_action_shape(self, env):
        env.reset(seed=0)
        with pytest.raises(ValueError, match=r"shape \(3,\)"):
            env.step(np.zeros(2, np.float32))

    def test_render_mode_refused(self):
        with pytest.raises(ValueError, match=r"render_mode 'human'.*rgb_array"):
            CatchEnv(render_mode="human")


def random_world(w: WorldCfg, speed, arena_m, lag_s, gait_noise, cam_noise, latency_s, dur_s):
    """``w`` with the fields the observation bounds depend on (or might) changed."""
    base = w.base.replace(lag_s=lag_s, gait_noise_mps=gait_noise, gait_noise_yaw_rps=gait_noise)
    return w.replace(
        arena=w.arena.replace(size_m=arena_m),
        base=base,
        sensor=w.sensor.replace(noise_m=cam_noise, latency_s=latency_s),
        episode=w.episode.replace(duration_s=dur_s),
    ).with_speed(speed)


def random_command_obs(env: CatchEnv, seed: int, amplitude: float, hold: int, steps: int):
    """Every observation (steps + resets, D) of ``steps`` control steps of ``env`` under
    uniform random commands in ``amplitude`` x the command box, each held ``hold`` steps,
    resetting after each episode."""
    rng = np.random.default_rng(seed)
    low, high = env.action_space.low * amplitude, env.action_space.high * amplitude
    seen = [env.reset(seed=seed)[0]]
    for t in range(steps):
        if t % hold == 0:
            action = rng.uniform(low, high).astype(np.float32)
        obs, _, terminated, truncated, _ = env.step(action)
        seen.append(obs)
        if terminated or truncated:
            seen.append(env.reset()[0])
    return np.stack(seen)


class TestObservationBounds:
    @pytest.mark.parametrize("behavior", sorted(scripted_behaviors()))
    @settings(max_examples=4, deadline=None)
    @given(
        seed=st.integers(0, 2**31 - 1),
        amplitude=st.sampled_from([0.5, 1.0, 5.0]),
        hold=st.integers(1, 150),
        speed=st.floats(0.0, 3.0),
        arena_m=st.floats(11.0, 30.0),
        lag_s=st.floats(0.00501, 0.3),
        gait_noise=st.floats(0.0, 0.5),
        cam_noise=st.floats(0.0, 0.5),
        latency_s=st.floats(0.0, 0.45),
        dur_s=st.floats(0.3, 12.0),
    )
    def test_every_observation_lies_in_the_space(
        self, made_envs, behavior, seed, amplitude, hold, speed, arena_m, lag_s, gait_noise,
        cam_noise, latency_s, dur_s,
    ):  # fmt: skip
        """Random worlds and commands (up to 5x the limits, held up to 3 s, so the base
        presses into walls), many episodes: no observation leaves the declared space."""
        base = _with_staleness(made_envs[behavior].world)
        world = random_world(base, speed, arena_m, lag_s, gait_noise, cam_noise, latency_s, dur_s)
        try:
            env = CatchEnv(behavior, world=world)
        except ConfigError:
            assume(False)
        obs = random_command_obs(env, seed, amplitude, hold, steps=800)
        space = env.observation_space
        outside = ~((obs >= space.low) & (obs <= space.high))
        rows, cols = np.nonzero(outside)
        assert rows.size == 0, (rows[:5], cols[:5], obs[rows[:5], cols[:5]])
        assert all(space.contains(o) for o in obs[:: max(1, len(obs) // 20)])
        # The reset observation reads exactly 0 s since the last sighting: the bound is tight.
        assert obs[0, TIME] == 0.0

    def test_velocity_bound_is_needed_where_it_is_dropped(self, made_envs):
        """With a 0.004 s lag under 0.005 s sub-steps the base overshoots its limits, and the
        space says nothing about velocities."""
        base = made_envs["circle"].world
        env = CatchEnv("circle", world=base.replace(base=base.base.replace(lag_s=0.004)))
        obs = random_command_obs(env, 0, amplitude=5.0, hold=50, steps=400)
        limits = env.env.action_spec
        overshoot = (obs[:, VEL] > np.asarray(limits.high) + 1e-4) | (
            obs[:, VEL] < np.asarray(limits.low) - 1e-4
        )
        assert overshoot.any()
        assert np.isposinf(env.observation_space.high[VEL]).all()
        assert np.isneginf(env.observation_space.low[VEL]).all()
