"""Joint-space damped-least-squares IK of the arm, the formulation of ``dyncatch.sim.arm``.

``dq = J^T (J J^T + lambda^2 I)^-1 (gain * e)``, with ``J`` the gripper's (3, 6) position
Jacobian and ``e`` its error, both in the world frame (the DLS step is invariant to a common
rotation). The result moves the PD *targets* of the arm: the joints follow under PD with
gravity compensation. The step is clipped to the joint-velocity limit and the joint limits
(``ArmCfg``), as the JAX arm does.
"""

from __future__ import annotations

import numpy as np

from dyncatch.sim.config import ArmCfg


def dls_delta(jac: np.ndarray, err: np.ndarray, damping: float, gain: float) -> np.ndarray:
    """Joint change (n,) for a gripper error ``err`` (3,) under the Jacobian ``jac`` (3, n)."""
    jjt = jac @ jac.T + damping**2 * np.eye(3)
    return jac.T @ np.linalg.solve(jjt, gain * err)


def ik_target_step(
    q_des: np.ndarray,
    jac: np.ndarray,
    gripper_m: np.ndarray,
    goal_m: np.ndarray,
    arm: ArmCfg,
    dt_s: float,
    max_step_rad: float,
) -> np.ndarray:
    """Next arm PD targets (6,) moving the gripper toward ``goal_m`` (3,) in one step.

    ``jac`` (3, 6) and ``gripper_m`` (3,) are those of the commanded joints ``q_des`` (6,).
    """
    dq = dls_delta(jac, goal_m - gripper_m, arm.ik_damping, arm.ik_gain)
    limit = min(arm.max_joint_vel_rps * dt_s, max_step_rad)
    q_new = q_des + np.clip(dq, -limit, limit)
    return np.clip(q_new, arm.joint_min_rad, arm.joint_max_rad)


def stow_target_step(q_des: np.ndarray, arm: ArmCfg, dt_s: float) -> np.ndarray:
    """Next arm PD targets (6,) moving toward the stow pose at the joint-velocity limit."""
    limit = arm.max_joint_vel_rps * dt_s
    return q_des + np.clip(np.asarray(arm.stow_rad) - q_des, -limit, limit)
