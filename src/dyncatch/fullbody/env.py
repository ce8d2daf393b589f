"""``FullBodyEnv``: one ``mujoco.MjData`` stepped at the 200 Hz control rate.

The physics state is the ``MjData``; the controllers' memory is ``GaitState`` plus the arm's
PD targets; the constants are ``FullBodyCfg``. A batched evaluation can hold one env per
worker (MuJoCo releases the GIL while stepping) or copy ``qpos``/``qvel`` in and out.
"""

from __future__ import annotations

import numpy as np

from dyncatch.fullbody.arm_ik import ik_target_step, speed_limited_pd_ctrl, stow_target_step
from dyncatch.fullbody.config import FullBodyCfg, validate_fullbody
from dyncatch.fullbody.gait import (
    GaitState,
    JointTargets,
    RobotObs,
    initial_gait_state,
    trot_step,
    yaw_of,
)
from dyncatch.fullbody.legs import FOOT_RADIUS_M, leg_ik, nominal_feet_base
from dyncatch.fullbody.model import build_model, robot_mass_kg
from dyncatch.fullbody.speed_limit import ArmSpeedLimiter
from dyncatch.fullbody.stance import STANCE_CONTROLLERS


class FullBodyEnv:
    """Aliengo + arm + target. ``step(cmd, arm_goal_m)`` advances one control period."""

    def __init__(self, cfg: FullBodyCfg | None = None, built=None):
        """``built``: ``build_model(cfg)``'s ``(model, Indices)`` to share one compiled
        model between several envs (a batched evaluation); None compiles one."""
        import mujoco

        cfg = FullBodyCfg() if cfg is None else cfg

        self._mj = mujoco
        self.cfg = validate_fullbody(cfg)
        self.model, self.idx = build_model(cfg) if built is None else built
        self.data = mujoco.MjData(self.model)
        self._scratch = mujoco.MjData(self.model)
        self.mass_kg = robot_mass_kg(self.model)
        self._jacp = np.zeros((3, self.model.nv))
        self.gait: GaitState | None = None
        self.arm_q_des = np.asarray(cfg.arm.stow_rad, float)
        self.arm_qd_des = np.zeros(6)
        self.time_s = 0.0
        self._arm_body = self.model.body("arm_link1").id
        self.arm_mass_kg = float(self.model.body_subtreemass[self._arm_body])
        self._leg_lo = self.model.actuator_ctrlrange[self.idx.leg_ctrl, 0]
        self._leg_hi = self.model.actuator_ctrlrange[self.idx.leg_ctrl, 1]
        z1 = self.cfg.z1
        self._arm_kp = np.asarray(z1.kp_nm_per_rad, float)
        self._arm_kd = np.asarray(z1.kd_nms_per_rad, float)
        self._arm_accel = z1.max_joint_accel_rps2
        self._stance_fn = STANCE_CONTROLLERS[self.cfg.gait.controller]
        frac = z1.pd_speed_fraction
        self._arm_pd_speed_rps = None if frac is None else frac * self.cfg.arm.max_joint_vel_rps
        stow = z1.stow_speed_fraction
        self._stow_speed_rps = None if stow is None else stow * self.cfg.arm.max_joint_vel_rps
        self.arm_driver = ArmSpeedLimiter(self.model, self.idx, self.cfg)
        """Steps the physics with the Z1's speed limit; keeps the arm's peak speed and torque."""

    @property
    def dt_s(self) -> float:
        return 1.0 / self.cfg.control_hz

    def reset(self, xy_m: tuple[float, float] = (0.0, 0.0), yaw_rad: float = 0.0) -> RobotObs:
        """Stand the robot at ``xy_m`` facing ``yaw_rad``, feet under the hips, arm stowed."""
        mj, d, idx = self._mj, self.data, self.idx
        mj.mj_resetData(self.model, d)
        d.qpos[:3] = (xy_m[0], xy_m[1], self.cfg.stand_height_m)
        d.qpos[3:7] = (np.cos(yaw_rad / 2), 0.0, 0.0, np.sin(yaw_rad / 2))
        feet = nominal_feet_base(self.cfg.stand_height_m - FOOT_RADIUS_M)
        d.qpos[idx.leg_qpos] = np.concatenate([leg_ik(feet[i], i) for i in range(4)])
        d.qpos[idx.arm_qpos] = self.cfg.arm.stow_rad
        mj.mj_forward(self.model, d)
        self.arm_q_des = np.asarray(self.cfg.arm.stow_rad, float)
        self.arm_qd_des = np.zeros(6)
        self.time_s = 0.0
        self.arm_driver.reset_peaks()
        obs = self.observe()
        self.gait = initial_gait_state(obs)
        return obs

    def observe(self) -> RobotObs:
        mj, m, d, idx = self._mj, self.model, self.data, self.idx
        rot = d.xmat[idx.base_body].reshape(3, 3).copy()
        jac = np.zeros((4, 3, 3))
        for leg, body in enumerate(idx.foot_body):
            mj.mj_jacBody(m, d, self._jacp, None, body)
            jac[leg] = self._jacp[:, idx.leg_dof[3 * leg : 3 * leg + 3]]
        # The wrench the trunk puts on the arm (force; moment about the robot's COM), from
        # the last physics step's accelerations: what the arm's joints transmit.
        mj.mj_rnePostConstraint(m, d)
        link = self._arm_body
        return RobotObs(
            base_pos_m=d.qpos[:3].copy(),
            base_rot=rot,
            base_vel_mps=d.qvel[:3].copy(),
            base_angvel_rps=rot @ d.qvel[3:6],
            com_m=d.subtree_com[idx.base_body].copy(),
            feet_m=d.xpos[idx.foot_body].copy(),
            foot_jac=jac,
            leg_q_rad=d.qpos[idx.leg_qpos].copy(),
            mass_kg=self.mass_kg,
            arm_mass_kg=self.arm_mass_kg,
            arm_com_m=d.subtree_com[link].copy(),
            arm_wrench=np.concatenate([d.cfrc_int[link, 3:], d.cfrc_int[link, :3]]),
            leg_torque_limit_nm=self._leg_hi,
        )

    def gripper_m(self) -> np.ndarray:
        """(3,) gripper point in the world."""
        return self.data.site_xpos[self.idx.gripper_site].copy()

    def set_target(self, pos_m: np.ndarray) -> None:
        """Place the kinematic target sphere's centre at ``pos_m`` (3,)."""
        self.data.mocap_pos[self.idx.target_mocap] = pos_m

    def _arm_targets(
        self, goal_m: np.ndarray | None, goal_vel_mps: np.ndarray | None = None
    ) -> np.ndarray:
        """Next arm PD targets. The DLS step runs on the *commanded* joints (their gripper
        and Jacobian from a scratch ``MjData`` at the measured base pose), as the JAX arm
        does; the PD then tracks the converged targets, so its lag cannot wind the IK up.
        With ``goal_vel_mps`` (3,, world) and ``FullBodyCfg.arm_goal_feedforward`` the step
        follows the goal's motion relative to the trunk's horizontal motion."""
        mj, m, idx = self._mj, self.model, self.idx
        if goal_m is None:
            return stow_target_step(
                self.arm_q_des,
                self.arm_qd_des,
                self.cfg.arm,
                self.dt_s,
                self._arm_accel,
                self._stow_speed_rps,
            )
        k = self._scratch
        k.qpos[:] = self.data.qpos
        k.qpos[idx.arm_qpos] = self.arm_q_des
        mj.mj_kinematics(m, k)
        mj.mj_comPos(m, k)
        mj.mj_jacSite(m, k, self._jacp, None, idx.gripper_site)
        gripper = k.site_xpos[idx.gripper_site].copy()
        rel_vel = None
        if goal_vel_mps is not None and self.cfg.arm_goal_feedforward:
            # What the trunk's horizontal motion (velocity, yaw rate) does to the gripper
            # held still on it; its ripple (roll, pitch, bounce) is left to the feedback.
            d = self.data
            yaw_rate = (d.xmat[idx.base_body].reshape(3, 3) @ d.qvel[3:6])[2]
            r = gripper[:2] - d.qpos[:2]
            carried = d.qvel[:2] + yaw_rate * np.array([-r[1], r[0]])
            rel_vel = np.asarray(goal_vel_mps, float) - np.array([*carried, 0.0])
        return ik_target_step(
            self.arm_q_des,
            self.arm_qd_des,
            self._jacp[:, idx.arm_dof],
            gripper,
            np.asarray(goal_m, float),
            self.cfg.arm,
            self.dt_s,
            self.cfg.max_arm_ik_step_rad,
            self._arm_accel,
            rel_vel,
        )

    def step(
        self,
        cmd: np.ndarray,
        arm_goal_m: np.ndarray | None = None,
        arm_goal_vel_mps: np.ndarray | None = None,
    ) -> RobotObs:
        """One control period. ``cmd`` (3,): forward, left (m/s, heading frame), yaw rate
        (rad/s). ``arm_goal_m`` (3,): where the gripper should go (world), None to stow;
        ``arm_goal_vel_mps`` (3,): its velocity (world), None for a goal at rest."""
        if self.gait is None:
            raise RuntimeError("call reset() before step()")
        cmd = np.asarray(cmd, float)
        obs = self.observe()
        legs, self.gait = trot_step(obs, cmd, self.gait, self.cfg, self._stance_fn)
        q_des = self._arm_targets(arm_goal_m, arm_goal_vel_mps)
        # The commanded joint velocity: the targets' step over the period (the SDK's dq).
        self.arm_qd_des = (q_des - self.arm_q_des) / self.dt_s
        self.arm_q_des = q_des
        self._run_pd(legs, stowing=arm_goal_m is None)
        self.time_s += self.dt_s
        return self.observe()

    def _run_pd(self, legs: JointTargets, stowing: bool) -> None:
        m, d, idx = self.model, self.data, self.idx
        # Gravity (and Coriolis) compensation of the arm, held over the control period. The
        # arm's servos (model._add_arm) give kp (ctrl - q) - kd qd: this ctrl makes that
        # kp (q_des - q) + kd (qd_des - qd) + tau_ff, the Z1's PD law with its feedforward.
        arm_ff = d.qfrc_bias[idx.arm_dof].copy()
        kp, kd = self._arm_kp, self._arm_kd
        d.ctrl[idx.arm_ctrl] = self.arm_q_des + (kd * self.arm_qd_des + arm_ff) / kp
        limit = self._arm_pd_speed_rps
        if stowing and self._stow_speed_rps is not None:
            limit = self._stow_speed_rps if limit is None else min(limit, self._stow_speed_rps)
        for _ in range(self.cfg.substeps):
            if limit is not None:
                d.ctrl[idx.arm_ctrl] = speed_limited_pd_ctrl(
                    d.qpos[idx.arm_qpos], self.arm_qd_des, self.arm_q_des, arm_ff, kp, kd, limit
                )
            q, qd = d.qpos[idx.leg_qpos], d.qvel[idx.leg_dof]
            tau_leg = legs.kp * (legs.q_des - q) + legs.kd * (legs.qd_des - qd) + legs.tau_ff
            d.ctrl[idx.leg_ctrl] = np.clip(tau_leg, self._leg_lo, self._leg_hi)
            self.arm_driver.step(m, d)

    def fallen(self) -> bool:
        """True once the trunk is below ``fall_height_m`` or tilted past ``fall_tilt_rad``."""
        rot = self.data.xmat[self.idx.base_body].reshape(3, 3)
        return bool(
            self.data.qpos[2] < self.cfg.fall_height_m or rot[2, 2] < np.cos(self.cfg.fall_tilt_rad)
        )

    def base_velocity_heading(self) -> np.ndarray:
        """(3,) forward and left velocity in the heading frame (m/s), yaw rate (rad/s)."""
        d = self.data
        rot = d.xmat[self.idx.base_body].reshape(3, 3)
        yaw = yaw_of(rot)
        c, s = np.cos(yaw), np.sin(yaw)
        v = d.qvel[:2]
        w = rot @ d.qvel[3:6]
        return np.array([c * v[0] + s * v[1], -s * v[0] + c * v[1], w[2]])
