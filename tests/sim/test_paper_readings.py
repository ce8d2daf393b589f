"""The readings of issue 32 (docs/fidelity.md): each off by default, with today's numbers,
and each changing what it says: gamma held, the paper's observation, the FoV as a
half-angle, beta as the heading difference, the arm aiming at the sighting. The paper's
observation became the default (issue 32, item 4): the observation from before the readings
is ``staleness_observation``."""

import dataclasses
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.export.layout import policy_layout
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.reproduce.plan import PROFILES
from dyncatch.reproduce.readings import get_reading
from dyncatch.rl.methods import method_obs
from dyncatch.sim import env
from dyncatch.sim.api import JaxCatchEnv, obs_dim
from dyncatch.sim.behaviors import get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import wrap_angle
from dyncatch.sim.reward import reward_terms
from dyncatch.sim.sensing import in_view

from .helpers import fixed_rollout, place, world_xy

CFG = WorldCfg()
STILL = jnp.zeros(3)


def _read(name: str, world: WorldCfg = CFG) -> WorldCfg:
    """``world`` under the named reading (as ``dyncatch reproduce --setting`` applies it)."""
    return get_reading(name).apply(dataclasses.replace(PROFILES["quick"], world=world)).world


def _pursuit_rollout(cfg: WorldCfg, n: int = 4, steps: int = 150, seed: int = 11):
    """The scripted pursuer in ``n`` environments from a fixed key, no auto-reset."""
    policy = pursuit_policy(cfg)
    vstep = jax.vmap(env.step, in_axes=(0, 0, None))

    def body(carry, _):
        s, obs = carry
        s, obs, r, _, info = vstep(s, jax.vmap(lambda o: policy(o, None))(obs), cfg)
        return (s, obs), (obs.flat, r, info["success"], s.target.xy_m + s.origin_xy_m)

    def rollout(key):  # one program, the reset included (eagerly, op by op)
        s = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(key, n), cfg)
        obs = jax.vmap(env.observe, in_axes=(0, None))(s, cfg)
        return jax.lax.scan(body, (s, obs), None, length=steps)[1]

    return jax.jit(rollout)(jax.random.key(seed))


# Recorded at commit 3f68e95, before these readings existed, under the tests' XLA flags
# (Makefile TEST_ENV), where the rollout reproduces them bit for bit; the tolerance only
# covers XLA's default optimisation, which reassociates float sums (measured: 3e-9 relative).
BEFORE = {
    "reactive": (50697.79447971345, 244.39442468760535, 48, [10.27915, 2.22573]),
    "random_reactive": (50514.575671699706, 129.38613009639084, 25, [9.66510, 2.05276]),
}


@pytest.mark.parametrize("behavior", sorted(BEFORE))
def test_the_default_world_reproduces_the_numbers_from_before_the_readings(behavior):
    # The sums include Obs.flat, which carried the staleness inputs before the readings.
    before = _read("staleness_observation").with_behavior(behavior).with_speed(1.0)
    obs, reward, success, target_xy = _pursuit_rollout(before)
    obs_sum, reward_sum, catches, last_xy = BEFORE[behavior]
    assert float(np.asarray(obs, np.float64).sum()) == pytest.approx(obs_sum, rel=1e-7)
    assert float(np.asarray(reward, np.float64).sum()) == pytest.approx(reward_sum, rel=1e-7)
    assert int(np.asarray(success).sum()) == catches
    np.testing.assert_allclose(np.asarray(target_xy[-1, 3]), last_xy, atol=1e-4)


def _old_reactive_heading(target, robot, cfg, key):
    """Eq. 12 as written before the readings: gamma drawn every step, beta the bearing."""
    d = target.xy_m - robot.xy_m
    flee = jnp.arctan2(d[1], d[0])
    beta = wrap_angle(flee - robot.yaw_rad)
    tc = cfg.target
    gamma = jax.random.uniform(key, (), minval=-tc.gamma_max_rad, maxval=tc.gamma_max_rad)
    close = jnp.sum(d * d) <= tc.evade_radius_m**2
    return flee + jnp.where(close, jnp.sign(beta) * tc.evade_angle_rad, 0.0) + gamma


def test_the_default_reactive_heading_is_the_old_formula_bit_for_bit():
    cfg = CFG.with_speed(1.0)
    reset = jax.jit(jax.vmap(env.reset, in_axes=(0, None)))  # one program, not op by op
    states = reset(jax.random.split(jax.random.key(4), 256), cfg)
    keys = jax.random.split(jax.random.key(5), 256)
    beh = get_behavior("reactive")
    new = jax.jit(jax.vmap(lambda s, k: beh.desired_heading(s.target, s.robot, cfg, k)[0]))
    old = jax.jit(jax.vmap(lambda s, k: _old_reactive_heading(s.target, s.robot, cfg, k)))
    np.testing.assert_array_equal(new(states, keys), old(states, keys))


@pytest.mark.parametrize("behavior", ["reactive", "random_reactive"])
def test_gamma_held_is_constant_over_a_camera_period(behavior):
    held = _read("gamma_held", CFG.with_behavior(behavior).with_speed(1.0))
    assert held.target.gamma_hold_s == 0.5
    for cfg, run in ((CFG.with_behavior(behavior).with_speed(1.0), 1), (held, 25)):
        s = jax.jit(env.reset)(jax.random.key(2), cfg)
        s = place(s, robot_xy=(0.0, 0.0), robot_yaw=0.0, target_xy=(8.0, 0.0))
        states, _, _ = fixed_rollout(s, STILL, cfg, 200)
        bs = states.target.behavior_state
        gamma = np.asarray(bs.gamma_rad if behavior == "reactive" else bs.gamma.gamma_rad)
        changes = np.flatnonzero(np.diff(gamma)) + 1
        # Drawn at the first step, then every `run` steps: 0.5 s = 25 control steps.
        assert changes.tolist() == list(range(run, 200, run))
        assert np.abs(gamma).max() <= cfg.target.gamma_max_rad + 1e-6
        assert len(np.unique(gamma)) == len(changes) + 1


def test_the_paper_observation_drops_the_staleness_inputs_for_every_method():
    paper, stale = _read("paper_observation"), _read("staleness_observation")
    assert paper == CFG  # the standard observation is the paper's (issue 32)
    assert obs_dim(stale) == 15 and obs_dim(paper) == 13
    s = jax.jit(env.reset)(jax.random.key(0), CFG)
    s = jax.jit(lambda s: env.step(s, jnp.array([1.0, 0.0, 0.5]), CFG)[0])(s)
    full, short = env.observe(s, stale), env.observe(s, paper)
    keep = [i for i in range(15) if i not in (5, 6)]  # time_since_seen_s, visible
    np.testing.assert_array_equal(short.flat, np.asarray(full.flat)[keep])
    assert float(short.time_since_seen_s) == float(full.time_since_seen_s)  # still in Obs
    spec = JaxCatchEnv(paper).observation_spec
    assert spec.shape == (13,) and spec.low.shape == spec.high.shape == (13,)
    for name in ("rl", "gt_rl"):
        fn = method_obs(name)
        layout = fn.layout(paper)
        names = [n for n, _ in layout]
        assert "time_since_seen_s" not in names and "visible" not in names
        assert [e["name"] for e in policy_layout(fn, paper)] == names
        assert sum(size for _, size in layout) == sum(size for _, size in fn.layout(stale)) - 2
        assert fn(s, short).shape == (sum(size for _, size in layout),)


def test_the_fov_as_a_half_angle_sees_and_pays_a_target_at_100_degrees():
    half = _read("fov_half_angle")
    s = jax.jit(env.reset)(jax.random.key(0), CFG)
    a = math.radians(100.0)
    s = place(s, robot_xy=(0.0, 0.0), robot_yaw=0.0, target_xy=(3 * math.cos(a), 3 * math.sin(a)))
    bearing = jnp.asarray(a)
    for cfg, seen in ((CFG, False), (half, True)):
        assert bool(in_view(s.robot, s.target.xy_m, cfg)) is seen
        terms = reward_terms(jnp.zeros(()), jnp.zeros(()), bearing, jnp.zeros((), bool), cfg.sensor)
        assert float(terms["visibility"]) == float(seen)
    # Beyond 120 degrees neither reading sees it.
    assert not bool(in_view(s.robot, jnp.array([-3.0, 0.5]), half))


def test_beta_as_the_heading_difference_on_a_hand_worked_geometry():
    # Robot at the origin facing +x; target 1 m ahead and 0.2 m left (bearing +11.3 deg)
    # running at -90 deg (to the robot's right): inside r_ev, so it dodges by alpha = 60 deg.
    # Bearing: beta = +11.3 deg, it dodges left: 11.3 + 60 = 71.3 deg.
    # Heading difference: beta = -90 - 0 = -90 deg, it dodges right: 11.3 - 60 = -48.7 deg.
    base = CFG.replace(target=CFG.target.replace(gamma_max_rad=0.0))
    s = jax.jit(env.reset)(jax.random.key(0), base)
    s = place(s, robot_xy=(0.0, 0.0), robot_yaw=0.0, target_xy=(1.0, 0.2), heading=-math.pi / 2)
    flee = math.degrees(math.atan2(0.2, 1.0))
    beh = get_behavior("reactive")
    for cfg, expected in ((base, flee + 60.0), (_read("beta_heading", base), flee - 60.0)):
        heading = beh.desired_heading(s.target, s.robot, cfg, jax.random.key(1))[0]
        assert math.degrees(float(heading)) == pytest.approx(expected, abs=1e-4)


def _arm_rollout(cfg: WorldCfg, sighting_xy, steps: int = 20):
    """A still target 0.6 m ahead of a still robot, the held sighting put at ``sighting_xy``
    (world, m); the camera's next frame is 25 steps on, so it stays for ``steps`` < 25."""
    cfg = cfg.with_behavior("bounce").with_speed(0.0)
    cfg = cfg.replace(base=cfg.base.replace(gait_noise_mps=0.0, gait_noise_yaw_rps=0.0))
    s = jax.jit(env.reset)(jax.random.key(3), cfg)
    s = place(s, robot_xy=(8.0, 8.0), robot_yaw=0.0, target_xy=(8.6, 8.0))
    sighting = jnp.asarray(sighting_xy, jnp.float32) - s.origin_xy_m
    s = s.replace(sensor=s.sensor.replace(obs_xy_m=sighting, ever_seen=jnp.ones((), bool)))
    states, _, infos = fixed_rollout(s, STILL, cfg, steps)
    return world_xy(states, states.robot.gripper_xyz_m[:, :2]), infos


def test_the_arm_on_sighting_reaches_for_the_sighting_not_the_target():
    sighting = (8.5, 8.3)
    true_aim, true_info = _arm_rollout(CFG, sighting)
    cfg = _read("arm_on_sighting")
    sight_aim, sight_info = _arm_rollout(cfg, sighting)
    np.testing.assert_allclose(np.asarray(true_aim[-1]), [8.6, 8.0], atol=0.02)
    np.testing.assert_allclose(np.asarray(sight_aim[-1]), sighting, atol=0.02)
    assert bool(true_info["success"].any()) and not bool(sight_info["success"].any())
    # A sighting beyond the activation distance keeps the arm stowed, though the target is near.
    far_aim, _ = _arm_rollout(cfg, (10.0, 8.0))
    stowed, _ = _arm_rollout(cfg.replace(arm=cfg.arm.replace(activation_distance_m=0.0)), sighting)
    np.testing.assert_allclose(np.asarray(far_aim), np.asarray(stowed), atol=1e-6)
