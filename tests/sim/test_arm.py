"""Forward kinematics, the Jacobian and the damped-least-squares IK controller."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.sim import arm
from dyncatch.sim.config import WorldCfg

CFG = WorldCfg()
A, B = CFG.arm, CFG.base


def test_zero_pose_points_straight_ahead():
    # All links horizontal and forward: x = mount + sum of the lengths, z = shoulder height.
    p = arm.gripper_in_base(jnp.zeros(6), A, B)
    reach = A.upper_arm_m + A.forearm_m + A.wrist_m + A.wrist2_m + A.gripper_m
    np.testing.assert_allclose(
        p, [A.mount_x_m + reach, 0.0, B.height_m + A.shoulder_height_m], atol=1e-6
    )


def test_pitching_the_shoulder_up_raises_the_arm_vertically():
    q = jnp.zeros(6).at[1].set(jnp.pi / 2)
    reach = A.upper_arm_m + A.forearm_m + A.wrist_m + A.wrist2_m + A.gripper_m
    p = arm.gripper_in_base(q, A, B)
    np.testing.assert_allclose(
        p, [A.mount_x_m, 0.0, B.height_m + A.shoulder_height_m + reach], atol=1e-6
    )


def test_jacobian_matches_finite_differences():
    q = jnp.array([0.3, 0.5, -1.2, 0.4, 0.7, -0.2])

    # Derivative of the base-frame point, rotated into the joint-1 frame.
    jac_fd = jax.jacfwd(lambda dq: arm.gripper_in_base(q + dq, A, B))(jnp.zeros(6))
    c, s = jnp.cos(q[0]), jnp.sin(q[0])
    rot = jnp.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])
    np.testing.assert_allclose(arm.jacobian_local(q, A), rot @ jac_fd, atol=1e-5)


def _reach(q0, goal, steps):
    def body(q, _):
        g = arm.gripper_in_base(q, A, B)
        return arm.arm_substep(q, g, goal, jnp.array(True), A, 0.005), None

    q, _ = jax.lax.scan(body, q0, None, length=steps)
    return q


@pytest.mark.parametrize("seed", range(3))
def test_ik_reaches_reachable_points_within_a_centimetre(seed):
    # Reachable by construction: the forward kinematics of random in-limit joint angles.
    lo, hi = arm.joint_min(A), arm.joint_max(A)
    qs = jax.random.uniform(jax.random.key(seed), (64, 6), minval=lo * 0.8, maxval=hi * 0.8)
    goals = jax.vmap(lambda q: arm.gripper_in_base(q, A, B))(qs)
    # Keep goals in front of the base and above the trunk's underside, where catches happen.
    keep = (goals[:, 0] > 0.3) & (goals[:, 2] > 0.1)
    goals = goals[keep]
    assert goals.shape[0] >= 8
    q0 = jnp.asarray(A.stow_rad)
    q_final = jax.jit(jax.vmap(lambda g: _reach(q0, g, 600)))(goals)
    err = jnp.linalg.norm(
        jax.vmap(lambda q: arm.gripper_in_base(q, A, B))(q_final) - goals, axis=-1
    )
    assert float(jnp.median(err)) < 0.002
    assert float(jnp.quantile(err, 0.9)) < 0.01


def test_ik_respects_joint_and_velocity_limits():
    goal = jnp.array([0.1, 0.0, -2.0])  # unreachable, far below: drives joints into limits
    q0 = jnp.asarray(A.stow_rad)

    def body(q, _):
        g = arm.gripper_in_base(q, A, B)
        q_new = arm.arm_substep(q, g, goal, jnp.array(True), A, 0.005)
        return q_new, (q_new, q_new - q)

    _, (qs, dqs) = jax.lax.scan(body, q0, None, length=400)
    assert bool(jnp.all(qs >= arm.joint_min(A) - 1e-6))
    assert bool(jnp.all(qs <= arm.joint_max(A) + 1e-6))
    assert float(jnp.abs(dqs).max()) <= A.max_joint_vel_rps * 0.005 + 1e-6
    # It did push some joint all the way to a limit.
    at_limit = jnp.isclose(qs[-1], arm.joint_min(A)) | jnp.isclose(qs[-1], arm.joint_max(A))
    assert bool(jnp.any(at_limit))


def test_inactive_arm_returns_to_stow():
    q0 = jnp.array([1.0, 1.0, -1.0, 0.5, 0.5, 0.5])

    def body(q, _):
        g = arm.gripper_in_base(q, A, B)
        return arm.arm_substep(q, g, g, jnp.array(False), A, 0.005), None

    q, _ = jax.lax.scan(body, q0, None, length=200)
    np.testing.assert_allclose(q, A.stow_rad, atol=1e-5)
