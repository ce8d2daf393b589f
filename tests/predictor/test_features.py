"""Encoders: hand-worked values, frame invariances and use inside a jitted rollout."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.features import FEATURE_DOCS, FEATURES, History, history_from_state
from dyncatch.predictor.model import Predictor
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import reset, step

H = History(
    target_xy_m=jnp.array([5.0, 4.0]),
    prev_target_xy_m=jnp.array([4.5, 4.0]),
    robot_pose=jnp.array([3.0, 4.0, jnp.pi / 2]),
    prev_robot_pose=jnp.array([3.0, 3.0, jnp.pi / 2]),
    robot_vel_body_mps=jnp.array([2.0, 0.0]),
    robot_yaw_rate_rps=jnp.array(0.0),
)


def test_vanilla_world_by_hand():
    x, yaw = FEATURES["vanilla"]["world"](H, 16.0, 0.5)
    # p_t / 16, p_{t-1} / 16, velocity (0.5 m in 0.5 s = 1 m/s along x); no wall distances
    # (the open plane has none, and the stored frame moves with the robot).
    expected = [5 / 16, 4 / 16, 4.5 / 16, 4 / 16, 1.0, 0.0]
    np.testing.assert_allclose(x, expected, atol=1e-6)
    assert float(yaw) == 0.0


def test_egocentric_puts_the_target_in_the_robot_frame():
    x, yaw = FEATURES["self_aware"]["egocentric"](H, 16.0, 0.5)
    # The robot faces +y; the target 2 m along +x is 2 m to its right: (0, -2) in its frame.
    np.testing.assert_allclose(x[:2] * 16.0, [0.0, -2.0], atol=1e-5)
    np.testing.assert_allclose(x[4:6], [0.0, -1.0], atol=1e-5)  # its velocity, 1 m/s rightward
    assert float(yaw) == pytest.approx(np.pi / 2)


def test_vanilla_egocentric_by_hand():
    x, yaw = FEATURES["vanilla"]["egocentric"](H, 16.0, 0.5)
    # 1 m/s along +x, seen by a camera facing +y: 1 m/s to its right, (0, -1) in its frame;
    # the output is rotated back by the camera's yaw.
    np.testing.assert_allclose(x, [0.0, -1.0], atol=1e-6)
    assert float(yaw) == pytest.approx(np.pi / 2)


def _moved(h: History, angle_rad: float, shift_m) -> History:
    """The history under a rigid motion of the plane: rotate by ``angle_rad``, then shift."""
    c, s = np.cos(angle_rad), np.sin(angle_rad)
    rot = jnp.array([[c, -s], [s, c]], jnp.float32)
    shift_m = jnp.asarray(shift_m, jnp.float32)

    def pose(p):
        return jnp.concatenate([rot @ p[:2] + shift_m, p[2:] + angle_rad])

    return h.replace(
        target_xy_m=rot @ h.target_xy_m + shift_m,
        prev_target_xy_m=rot @ h.prev_target_xy_m + shift_m,
        robot_pose=pose(h.robot_pose),
        prev_robot_pose=pose(h.prev_robot_pose),
    )


@pytest.mark.parametrize("kind", list(FEATURES))
@pytest.mark.parametrize(("angle", "shift"), [(0.7, (3.0, -2.0)), (-2.5, (1e3, 40.0))])
def test_egocentric_inputs_ignore_where_the_world_is(kind, angle, shift):
    encoder = FEATURES[kind]["egocentric"]
    x, yaw = encoder(H, 16.0, 0.5)
    x2, yaw2 = encoder(_moved(H, angle, shift), 16.0, 0.5)
    np.testing.assert_allclose(x2, x, atol=1e-4)
    # The output (a velocity in the camera frame) turns with the world.
    np.testing.assert_allclose(float(yaw2), float(yaw) + angle, atol=1e-6)


@pytest.mark.parametrize("kind", list(FEATURES))
@pytest.mark.parametrize("frame", ["world", "relative", "egocentric"])
def test_predict_runs_inside_a_jitted_rollout(kind, frame):
    world = WorldCfg()
    predictor = Predictor.for_world(PredictorCfg(kind=kind, frame=frame, hidden=(8,)), world)
    params = predictor.init(jax.random.key(0))

    @jax.jit
    def rollout(key):
        def body(state, _):
            state = step(state, jnp.array([1.0, 0.0, 0.3]), world)[0]
            return state, predictor.predict(params, history_from_state(state))

        return jax.lax.scan(body, reset(key, world), None, length=30)[1]

    v = rollout(jax.random.key(1))
    assert v.shape == (30, 2)
    assert bool(jnp.all(jnp.isfinite(v)))


def test_the_layout_names_the_hand_worked_values():
    encoder = FEATURES["vanilla"]["world"]
    x, _ = encoder(H, 16.0, 0.5)
    sizes = [size for _, size in encoder.layout()]
    parts = np.split(np.asarray(x), np.cumsum(sizes)[:-1])
    named = {name: part.tolist() for (name, _), part in zip(encoder.layout(), parts, strict=True)}
    expected = {
        "target_xy_frac": [5 / 16, 4 / 16],
        "prev_target_xy_frac": [4.5 / 16, 4 / 16],
        "target_vel_mps": [1.0, 0.0],
    }
    assert named.keys() == expected.keys()
    for name, value in expected.items():
        np.testing.assert_allclose(named[name], value, atol=1e-6, err_msg=name)


@pytest.mark.parametrize(
    ("kind", "frame"), [(k, f) for k in FEATURES for f in FEATURES[k]], ids=lambda v: v
)
def test_every_encoder_names_and_documents_all_its_inputs(kind, frame):
    encoder = FEATURES[kind][frame]
    x, _ = encoder(H, 16.0, 0.5)
    layout = encoder.layout()
    assert sum(size for _, size in layout) == x.shape[0]
    names = [name for name, _ in layout]
    assert len(set(names)) == len(names)
    assert set(names) <= set(FEATURE_DOCS), set(names) - set(FEATURE_DOCS)
