"""An evader that picks its speed: the share rule by hand, the body at that share of its cap
(alone, in a league, and commanded by the evader's trainer), the cap among its features, and
files whose speed action and outputs disagree refused."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.rl.evader import evader_env
from dyncatch.sim import env
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT, EvaderNet, save_evader
from dyncatch.sim.behaviors.learned import (
    FEATURE_NAMES,
    SPEED_FEATURE,
    evader_features,
    feature_names,
    speed_share_of,
)
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import TargetState
from dyncatch.sim.target import steer
from dyncatch.sim.validate import ConfigError, validate_world

CAP_MPS = 1.6
WORLD = WorldCfg().with_speed(CAP_MPS)


def test_the_share_rule_by_hand():
    actions = jnp.asarray([-2.0, -1.0, -0.25, 0.0, 0.4, 3.0])
    np.testing.assert_allclose(
        jax.vmap(speed_share_of)(actions), [0.0, 0.0, 0.75, 1.0, 1.0, 1.0], atol=1e-7
    )


def test_steer_runs_at_the_share_of_the_cap_and_at_the_cap_without_one():
    f = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    target = TargetState(f((1.0, 1.0)), f(0.0), f(0.0), f(CAP_MPS), None)
    cfg = WORLD.target
    assert float(steer(target, f(0.0), cfg, 0.02).speed_mps) == CAP_MPS * np.float32(1)
    for share, want in ((0.5, 0.8), (1.7, CAP_MPS), (-0.3, 0.0)):
        got = steer(target, f(0.0), cfg, 0.02, f(share)).speed_mps
        assert float(got) == pytest.approx(want, abs=1e-6)


def test_the_cap_is_a_feature_after_the_turn_only_ones_and_before_robot_visible():
    fov = math.radians(120.0)
    assert feature_names(speed_action=True) == (*FEATURE_NAMES, SPEED_FEATURE)
    assert feature_names(fov, True) == (*FEATURE_NAMES, SPEED_FEATURE, "robot_visible")
    s = env.reset(jax.random.key(0), WORLD.with_behavior("commanded"))
    plain = np.asarray(evader_features(s.target, s.robot, WORLD))
    fast = np.asarray(evader_features(s.target, s.robot, WORLD, speed_action=True))
    np.testing.assert_array_equal(fast[:-1], plain)
    assert fast[-1] == pytest.approx(CAP_MPS)
    narrow = evader_features(s.target, s.robot, WORLD, fov, True)
    assert narrow.shape == (len(FEATURE_NAMES) + 2,) and float(narrow[-2]) == pytest.approx(CAP_MPS)


def slow_net(speed_bias: float, speed_action: bool = True, outputs: int = 2) -> EvaderNet:
    """A hand-made evader of one layer: no turn, and a constant speed action ``speed_bias``."""
    names = feature_names(speed_action=speed_action)
    dim = len(names)
    bias = np.zeros(outputs, np.float32)
    bias[-1] = speed_bias
    return EvaderNet(
        ((np.zeros((dim, outputs), np.float32), bias),),
        np.zeros(dim, np.float32),
        np.ones(dim, np.float32),
        math.pi,
        {"features": list(names)},
        0.5,
        speed_action=speed_action,
        speed_action_std=0.5 if speed_action else None,
    )


def _learned(path: str) -> WorldCfg:
    w = WORLD.with_behavior("learned")
    return validate_world(w.replace(target=w.target.replace(evader_checkpoint=path)))


def _speeds(world: WorldCfg, steps: int = 5) -> np.ndarray:
    s = env.reset(jax.random.key(3), world)
    step = jax.jit(lambda s: env.step(s, jnp.zeros(3), world)[0])
    out = []
    for _ in range(steps):
        s = step(s)
        out.append(float(s.target.speed_mps))
    return np.asarray(out)


def test_a_learned_evader_runs_at_the_share_its_speed_action_asks_for(tmp_path):
    path = str(save_evader(tmp_path / EVADER_CHECKPOINT, slow_net(-0.25)))
    world = _learned(path)
    np.testing.assert_allclose(_speeds(world), 0.75 * CAP_MPS, rtol=1e-6)
    # In a league whose weight is all on it, the same; all on reactive, the cap.
    league = world.with_behavior("league")
    for weights, want in (((0.0, 1.0), 0.75 * CAP_MPS), ((1.0, 0.0), CAP_MPS)):
        t = league.target.replace(
            league_behaviors=("reactive",), league_evaders=(path,), league_weights=weights
        )
        np.testing.assert_allclose(
            _speeds(validate_world(league.replace(target=t))), want, rtol=1e-6
        )


@pytest.mark.parametrize(
    "net, why",
    [
        (slow_net(-0.25, speed_action=False, outputs=2), "2 outputs"),
        (slow_net(-0.25, speed_action=True, outputs=1), "1 outputs"),
    ],
)
def test_a_file_whose_outputs_do_not_match_its_speed_action_is_refused(tmp_path, net, why):
    path = str(save_evader(tmp_path / EVADER_CHECKPOINT, net))
    with pytest.raises(ConfigError, match=why):
        _learned(path)


def test_the_trainers_environment_sets_the_share_from_the_second_action():
    ev = evader_env(WORLD, pursuit_policy(WORLD), speed_action=True)
    assert ev.action_spec.shape == (2,) and ev.observation_spec.shape == (len(FEATURE_NAMES) + 1,)
    s = ev.reset(jax.random.key(0))
    step = jax.jit(ev.step)
    s1, obs, *_ = step(s, jnp.asarray([0.0, -0.5]))
    assert float(s1.world.target.speed_mps) == pytest.approx(0.5 * CAP_MPS)
    assert float(obs.flat[-1]) == pytest.approx(CAP_MPS)
    s2 = step(s1, jnp.asarray([0.0, 0.3]))[0]
    assert float(s2.world.target.speed_mps) == pytest.approx(CAP_MPS)
    # Without the speed action the second number is not read.
    plain = evader_env(WORLD, pursuit_policy(WORLD))
    s3 = jax.jit(plain.step)(plain.reset(jax.random.key(0)), jnp.asarray([0.0, -0.5]))[0]
    assert float(s3.world.target.speed_mps) == pytest.approx(CAP_MPS)
