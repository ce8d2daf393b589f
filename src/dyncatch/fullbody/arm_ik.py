"""Joint-space damped-least-squares IK of the arm, the formulation of ``dyncatch.sim.arm``.

``dq = J^T (J J^T + lambda^2 I)^-1 (gain * e)``, with ``J`` the gripper's (3, 6) position
Jacobian and ``e`` its error, both in the world frame (the DLS step is invariant to a common
rotation). The result moves the PD *targets* of the arm: the joints follow under PD with
gravity compensation. The step is clipped to the joint-velocity limit and the joint limits
(``ArmCfg``), as the JAX arm does, and its change from the last step to the joint-acceleration
bound (``Z1Cfg.max_joint_accel_rps2``), which the kinematic JAX arm does not have; under that
bound a moving goal's rate is fed forward (``goal_rate``), which the JAX arm, closing its whole
error every step, does not need.
"""

from __future__ import annotations

import numpy as np

from dyncatch.sim.config import ArmCfg


def dls_delta(jac: np.ndarray, err: np.ndarray, damping: float, gain: float) -> np.ndarray:
    """Joint change (n,) for a gripper error ``err`` (3,) under the Jacobian ``jac`` (3, n)."""
    jjt = jac @ jac.T + damping**2 * np.eye(3)
    return jac.T @ np.linalg.solve(jjt, gain * err)


def limit_step(
    dq: np.ndarray, qd_prev: np.ndarray, max_vel: float, max_accel: float, dt_s: float
) -> np.ndarray:
    """``dq`` (6,) clipped so that its rate stays within ``max_vel`` and moves from the last
    step's rate ``qd_prev`` (6,) by at most ``max_accel`` (per joint)."""
    lo = np.maximum(-max_vel, qd_prev - max_accel * dt_s) * dt_s
    hi = np.minimum(max_vel, qd_prev + max_accel * dt_s) * dt_s
    return np.clip(dq, lo, hi)


def scale_to_bound(dq: np.ndarray, bound: float) -> np.ndarray:
    """``dq`` (n,) scaled as a whole so that no element exceeds ``bound`` in magnitude."""
    peak = float(np.max(np.abs(dq)))
    return dq if peak <= bound else dq * (bound / peak)


def speed_limited_pd_ctrl(
    q: np.ndarray,
    qd_des: np.ndarray,
    q_des: np.ndarray,
    tau_ff: np.ndarray,
    kp: np.ndarray,
    kd: np.ndarray,
    max_vel_rps: float,
) -> np.ndarray:
    """Position-servo setpoint (n,) whose force ``kp (ctrl - q) - kd qd`` is the PD law
    ``kp (q_des - q) + kd (qd_des - qd) + tau_ff`` with the velocity it drives toward,
    ``qd_des + kp / kd (q_des - q)``, held within ``max_vel_rps``: a joint far behind its
    target catches up at the speed limit instead of overrunning it (a motor driver's
    speed-limited position mode). All arrays (n,)."""
    v_drive = np.clip(qd_des + kp / kd * (q_des - q), -max_vel_rps, max_vel_rps)
    return q + (kd * v_drive + tau_ff) / kp


def _brake(dq: np.ndarray, max_accel_rps2: float, dt_s: float) -> np.ndarray:
    """The step toward a joint change ``dq`` (6,) at no more than the fastest rate from which
    the acceleration bound still stops there in steps of ``dt_s`` (v^2 / 2a + v dt / 2 <= |dq|):
    without it the bounded deceleration overshoots and the targets ring around the goal."""
    half = 0.5 * max_accel_rps2 * dt_s
    v_stop = np.sqrt(half**2 + 2.0 * max_accel_rps2 * np.abs(dq)) - half
    return np.sign(dq) * np.minimum(v_stop * dt_s, np.abs(dq))


def ik_target_step(
    q_des: np.ndarray,
    qd_prev: np.ndarray,
    jac: np.ndarray,
    gripper_m: np.ndarray,
    goal_m: np.ndarray,
    arm: ArmCfg,
    dt_s: float,
    max_step_rad: float,
    max_accel_rps2: float,
    goal_vel_mps: np.ndarray | None = None,
) -> np.ndarray:
    """Next arm PD targets (6,) moving the gripper toward ``goal_m`` (3,) in one step.

    ``jac`` (3, 6) and ``gripper_m`` (3,) are those of the commanded joints ``q_des`` (6,);
    ``qd_prev`` (6,) is the last step's rate of the targets. ``goal_vel_mps`` (3,): the
    goal's velocity relative to the gripper held still on the trunk (None: at rest); the
    step then carries the joint rate that follows it (``goal_rate``), and the brake acts on
    the error relative to the moving goal.
    """
    dq = dls_delta(jac, goal_m - gripper_m, arm.ik_damping, arm.ik_gain)
    # Scaled as a whole, not clipped joint by joint, so that the step keeps its direction:
    # first to the IK's own bound, then (after braking toward it) to the speed limit.
    dq = _brake(scale_to_bound(dq, max_step_rad), max_accel_rps2, dt_s)
    if goal_vel_mps is not None:
        dq = dq + goal_rate(jac, goal_vel_mps, arm.ik_damping) * dt_s
    dq = scale_to_bound(dq, arm.max_joint_vel_rps * dt_s)
    q_new = q_des + limit_step(dq, qd_prev, arm.max_joint_vel_rps, max_accel_rps2, dt_s)
    return np.clip(q_new, arm.joint_min_rad, arm.joint_max_rad)


def goal_rate(jac: np.ndarray, goal_vel_mps: np.ndarray, damping: float) -> np.ndarray:
    """Joint rate (6,) that moves the gripper with a goal moving at ``goal_vel_mps`` (3,)
    relative to it, by the same damped least squares as the IK's step (``jac`` (3, 6)):
    the braked step toward the goal is then taken relative to the goal's own motion, so a
    moving goal is followed without the lag ``qd^2 / (2 max_accel)`` that braking toward
    it as if at rest leaves (``FullBodyCfg.arm_goal_feedforward``)."""
    return dls_delta(jac, np.asarray(goal_vel_mps, float), damping, 1.0)


def stow_target_step(
    q_des: np.ndarray,
    qd_prev: np.ndarray,
    arm: ArmCfg,
    dt_s: float,
    max_accel_rps2: float,
    max_vel_rps: float | None = None,
) -> np.ndarray:
    """Next arm PD targets (6,) moving toward the stow pose at up to ``max_vel_rps`` (None:
    the joint-velocity limit), braking in time (per joint) so as to stop there."""
    vel = arm.max_joint_vel_rps if max_vel_rps is None else max_vel_rps
    dq = _brake(np.asarray(arm.stow_rad) - q_des, max_accel_rps2, dt_s)
    return q_des + limit_step(dq, qd_prev, vel, max_accel_rps2, dt_s)
