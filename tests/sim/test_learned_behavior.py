"""The ``learned`` and ``commanded`` behaviours: features by hand, a hand-made network's
turn, the walls' corner riding with the frame, determinism, and the checkpoint's errors."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.sim import env
from dyncatch.sim.behaviors import BEHAVIORS, EvaderState, scripted_behaviors
from dyncatch.sim.behaviors.evader_net import (
    EVADER_CHECKPOINT,
    EvaderNet,
    _load_cached,
    save_evader,
)
from dyncatch.sim.behaviors.learned import (
    FEATURE_NAMES,
    evader_features,
    learned_heading,
)
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import RobotState, TargetState
from dyncatch.sim.validate import ConfigError, validate_world

from .helpers import away_net, fixed_rollout, place

LEFT = FEATURE_NAMES.index("robot_rel_left_m")


def _bodies(target_xy, heading, speed, robot_xy, robot_yaw=0.0, robot_vel=(0.0, 0.0)):
    f = lambda x: jnp.asarray(x, jnp.float32)  # noqa: E731
    target = TargetState(
        xy_m=f(target_xy),
        heading_rad=f(heading),
        speed_mps=f(speed),
        speed_cap_mps=f(speed),
        behavior_state=EvaderState(f(0.0), f((0.0, 0.0)), f(1.0)),
    )
    robot = RobotState(
        xy_m=f(robot_xy),
        yaw_rad=f(robot_yaw),
        vel_body_mps=f(robot_vel),
        yaw_rate_rps=f(0.0),
        arm_q_rad=jnp.zeros(6),
        gripper_xyz_m=jnp.zeros(3),
    )
    return target, robot


@pytest.fixture
def away_file(tmp_path):
    return str(save_evader(tmp_path / EVADER_CHECKPOINT, away_net()))


def test_features_by_hand():
    # Target at (3, 4) heading north at 1 m/s; the robot still, 2 m ahead of it at (3, 6).
    target, robot = _bodies((3.0, 4.0), math.pi / 2, 1.0, (3.0, 6.0))
    f = np.asarray(evader_features(target, robot, WorldCfg()))
    want = [2.0, 0.0, -1.0, 0.0, 1.0, 3.0, 13.0, 4.0, 12.0, 0.0, 1.0]
    np.testing.assert_allclose(f, want, atol=1e-6)
    # A robot running east at 2 m/s (yaw 0, forward 2) is, for a target heading north,
    # moving to its right: relative velocity (forward, left) = (-1, -2).
    target, robot = _bodies((3.0, 4.0), math.pi / 2, 1.0, (3.0, 6.0), robot_vel=(2.0, 0.0))
    np.testing.assert_allclose(
        evader_features(target, robot, WorldCfg())[2:4], [-1.0, -2.0], atol=1e-6
    )


def test_learned_heading_is_the_networks_mean_turn(away_file):
    cfg = WorldCfg().with_behavior("learned")
    cfg = cfg.replace(target=cfg.target.replace(evader_checkpoint=away_file))
    # Robot 0.5 m to the target's left: turn = -0.5 * pi (away, to the right).
    target, robot = _bodies((8.0, 8.0), 0.0, 1.0, (8.0, 8.5))
    heading, state = learned_heading(target, robot, cfg, jax.random.key(0))
    assert float(heading) == pytest.approx(-0.5 * math.pi, abs=1e-6)
    assert float(state.turn_rad) == pytest.approx(-0.5 * math.pi, abs=1e-6)


def test_flee_frame_adds_the_action_to_the_flee_direction(tmp_path):
    # A constant action 1/3 (60 deg) off the flee direction, read from the file.
    path = str(save_evader(tmp_path / EVADER_CHECKPOINT, away_net(0.0, bias=1 / 3, frame="flee")))
    cfg = _learned_world(path)
    # Target at (8, 8) heading east, robot 1 m north: flee direction -90 deg, so the desired
    # heading is -90 + 60 = -30 deg, a heading change of -30 deg.
    target, robot = _bodies((8.0, 8.0), 0.0, 1.0, (8.0, 9.0))
    heading, state = learned_heading(target, robot, cfg, jax.random.key(0))
    assert float(heading) == pytest.approx(-math.pi / 6, abs=1e-6)
    assert float(state.turn_rad) == pytest.approx(-math.pi / 6, abs=1e-6)
    # Heading north-west (135 deg) with the robot to the west: flee east (0 deg), desired
    # +60 deg, a change of -75 deg (not +285).
    target, robot = _bodies((8.0, 8.0), 0.75 * math.pi, 1.0, (6.0, 8.0))
    heading, _ = learned_heading(target, robot, cfg, jax.random.key(0))
    assert float(heading) == pytest.approx(math.pi / 3, abs=1e-6)
    # The reactive frame: an action of 0 is eq. 11-12 without gamma. Robot 2 m south, yaw
    # east: flee north (90 deg), beta = 90 deg > 0 so it dodges left, +60: desired 150 deg.
    zero = str(save_evader(tmp_path / "r.safetensors", away_net(0.0, frame="reactive")))
    target, robot = _bodies((8.0, 8.0), 0.0, 1.0, (8.0, 6.0))
    heading, _ = learned_heading(target, robot, _learned_world(zero), jax.random.key(0))
    assert float(heading) == pytest.approx(math.radians(150.0), abs=1e-6)
    # Beyond r_ev (robot 4 m south) it flees straight: 90 deg.
    target, robot = _bodies((8.0, 8.0), 0.0, 1.0, (8.0, 4.0))
    heading, _ = learned_heading(target, robot, _learned_world(zero), jax.random.key(0))
    assert float(heading) == pytest.approx(math.radians(90.0), abs=1e-6)
    bad = str(save_evader(tmp_path / "bad.safetensors", away_net(frame="sideways")))
    with pytest.raises(ConfigError, match="action frame 'sideways'"):
        _learned_world(bad)


def _learned_world(path: str, sample: bool = False) -> WorldCfg:
    cfg = WorldCfg().with_behavior("learned").with_speed(1.6)
    target = cfg.target.replace(evader_checkpoint=path, evader_sample=sample)
    return validate_world(cfg.replace(target=target))


def test_sampled_turns_draw_around_the_mean(tmp_path):
    path = str(save_evader(tmp_path / EVADER_CHECKPOINT, away_net(action_std=0.25)))
    cfg = _learned_world(path, sample=True)
    target, robot = _bodies((8.0, 8.0), 0.0, 1.0, (8.0, 8.25))  # mean action -0.25
    keys = jax.random.split(jax.random.key(0), 2000)
    turns = jax.vmap(lambda k: learned_heading(target, robot, cfg, k)[0])(keys) / math.pi
    assert float(jnp.mean(turns)) == pytest.approx(-0.25, abs=0.02)
    assert float(jnp.std(turns)) == pytest.approx(0.25, abs=0.02)
    again = learned_heading(target, robot, cfg, keys[0])[0] / math.pi
    assert float(again) == pytest.approx(float(turns[0]), abs=1e-6)  # one key, one turn
    with pytest.raises(ConfigError, match="evader_sample.*no action std"):
        _learned_world(str(save_evader(tmp_path / "no_std.safetensors", away_net())), True)


def test_episode_through_the_ordinary_step_is_deterministic(away_file):
    cfg = _learned_world(away_file)
    command = jnp.array([0.5, 0.0, 0.0])

    def episode(seed):
        s = env.reset(jax.random.key(seed), cfg)
        s = place(s, robot_xy=(8.0, 9.0), robot_yaw=0.0, target_xy=(8.0, 8.0), heading=0.0)
        states, _, info = fixed_rollout(s, command, cfg, 40)
        return states.robot, states.target, info

    a, b, c = episode(3), episode(3), episode(4)
    for x, y in zip(jax.tree.leaves(a), jax.tree.leaves(b), strict=True):
        np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert not np.array_equal(np.asarray(a[1].xy_m), np.asarray(c[1].xy_m))  # noise differs
    target = a[1]
    # The first step turns right at the turn-rate limit (10 rad/s x 0.02 s), at the cap.
    assert float(target.heading_rad[0]) == pytest.approx(-0.2, abs=1e-5)
    assert float(target.speed_mps[0]) == pytest.approx(1.6)


def test_corner_rides_with_the_frame():
    cfg = WorldCfg().with_behavior("commanded").with_scene("arena")
    s0 = env.reset(jax.random.key(1), cfg)
    states, _, _ = fixed_rollout(s0, jnp.array([1.0, 0.0, 0.5]), cfg, 30)
    # The stored corner is the scene origin seen from the moving frame.
    np.testing.assert_allclose(
        states.target.behavior_state.corner_xy_m, -states.origin_xy_m, atol=1e-5
    )


def test_commanded_applies_the_turn_in_its_state():
    cfg = WorldCfg().with_behavior("commanded").with_speed(1.0)
    s = env.reset(jax.random.key(2), cfg)
    h0 = float(s.target.heading_rad)
    bs = s.target.behavior_state.replace(turn_rad=jnp.float32(0.1))
    s = s.replace(target=s.target.replace(behavior_state=bs))
    s1 = env.step(s, jnp.zeros(3), cfg)[0]
    turned = (float(s1.target.heading_rad) - h0 + math.pi) % (2 * math.pi) - math.pi
    assert turned == pytest.approx(0.1, abs=1e-5)


def test_listings_take_the_scripted_behaviours():
    assert set(BEHAVIORS) - set(scripted_behaviors()) == {"learned", "commanded", "league"}


class TestCheckpointErrors:
    def _refused(self, path: str, *words: str):
        with pytest.raises(ConfigError) as err:
            _learned_world(path)
        msg = str(err.value)
        assert "--world.target.evader-checkpoint" in msg and "target.evader_checkpoint" in msg
        for w in words:
            assert w in msg

    def test_none(self):
        self._refused("", "empty")

    def test_missing(self, tmp_path):
        self._refused(str(tmp_path / "nope.safetensors"), "no such file")

    def test_damaged(self, away_file):
        data = bytearray(open(away_file, "rb").read())
        data[-3] ^= 0xFF  # a tensor byte: the checksum refuses it
        open(away_file, "wb").write(bytes(data))
        self._refused(away_file, "damaged")

    def test_not_a_checkpoint(self, tmp_path):
        p = tmp_path / "x.safetensors"
        p.write_text("hello")
        self._refused(str(p), "not an evader checkpoint")

    def test_other_features(self, tmp_path):
        net = away_net()
        net = EvaderNet(net.layers, net.norm_mean, net.norm_std, math.pi, {"features": ["x"]})
        self._refused(str(save_evader(tmp_path / "e.safetensors", net)), "retrain")

    def test_a_run_folder_is_read(self, away_file, tmp_path):
        assert _learned_world(str(tmp_path)).target.evader_checkpoint == str(tmp_path)


def test_a_first_load_inside_a_traced_step_gives_constants(tmp_path):
    # No validate_world first: the file is read while the step is traced.
    world = _learned_world(str(save_evader(tmp_path / EVADER_CHECKPOINT, away_net())))
    _load_cached.cache_clear()  # _learned_world validated (and so loaded) it
    s0 = env.reset(jax.random.key(0), world)
    step = jax.jit(lambda s: env.step(s, jnp.zeros(3), world)[0])
    assert np.all(np.isfinite(np.asarray(step(s0).target.xy_m)))


def test_a_field_of_view_hides_the_robot_outside_it():
    """With a 120 deg field of view the robot 2 m ahead is seen as with a whole turn's view
    (and robot_visible 1); 2 m behind, or 61 deg off the heading, it reads 0 (and 0)."""
    from dyncatch.sim.behaviors.learned import FOV_FEATURE_NAMES, feature_names

    fov = math.radians(120.0)
    assert feature_names(fov) == FOV_FEATURE_NAMES and feature_names() == FEATURE_NAMES
    ahead = _bodies((3.0, 4.0), math.pi / 2, 1.0, (3.0, 6.0), robot_vel=(2.0, 0.0))
    full = np.asarray(evader_features(*ahead, WorldCfg()))
    narrow = np.asarray(evader_features(*ahead, WorldCfg(), fov))
    np.testing.assert_allclose(narrow, [*full, 1.0], atol=1e-6)
    for bearing_deg in (180.0, 61.0, -61.0):
        b = math.radians(90.0 + bearing_deg)  # the target heads north (90 deg)
        xy = (3.0 + 2.0 * math.cos(b), 4.0 + 2.0 * math.sin(b))
        hidden = np.asarray(
            evader_features(*_bodies((3.0, 4.0), math.pi / 2, 1.0, xy), WorldCfg(), fov)
        )
        assert hidden[-1] == 0.0 and not hidden[:4].any(), bearing_deg
        np.testing.assert_allclose(hidden[4:-1], full[4:], atol=1e-6)  # speed, walls, heading
    at_edge = math.radians(90.0 + 59.0)
    xy = (3.0 + 2.0 * math.cos(at_edge), 4.0 + 2.0 * math.sin(at_edge))
    assert evader_features(*_bodies((3.0, 4.0), math.pi / 2, 1.0, xy), WorldCfg(), fov)[-1] == 1.0


def test_an_evader_files_field_of_view_is_how_the_learned_target_sees(tmp_path):
    """The file records the field of view; the deployed evader computes the 12 features of
    a narrow view from it, and a file whose features do not match its view is refused."""
    from dyncatch.sim.behaviors.learned import FOV_FEATURE_NAMES, evader_net

    fov = math.radians(120.0)
    dim = len(FOV_FEATURE_NAMES)
    kernel = np.zeros((dim, 1), np.float32)
    kernel[FOV_FEATURE_NAMES.index("robot_visible"), 0] = 0.5  # turns only when it sees
    net = EvaderNet(((kernel, np.zeros(1, np.float32)),), np.zeros(dim, np.float32),
                    np.ones(dim, np.float32), math.pi, {"features": list(FOV_FEATURE_NAMES)},
                    fov_rad=fov)  # fmt: skip
    world = _learned_world(str(save_evader(tmp_path / EVADER_CHECKPOINT, net)))
    assert evader_net(world).fov_rad == pytest.approx(fov)
    ahead = _bodies((3.0, 4.0), math.pi / 2, 1.0, (3.0, 6.0))
    behind = _bodies((3.0, 4.0), math.pi / 2, 1.0, (3.0, 2.0))
    turn = lambda bodies: float(learned_heading(*bodies, world, jax.random.key(0))[0])  # noqa: E731
    assert turn(ahead) == pytest.approx(math.pi / 2 + 0.5 * math.pi)
    assert turn(behind) == pytest.approx(math.pi / 2)
    whole_view = EvaderNet(net.layers, net.norm_mean, net.norm_std, math.pi, net.header)
    bad = str(save_evader(tmp_path / "whole.safetensors", whole_view))
    with pytest.raises(ConfigError, match="retrain"):
        _learned_world(bad)
