"""The Z1 driver's speed limiter: no arm joint leaves a physics step above its speed limit.

A motor driver in speed-limited mode withholds the torque that would carry its joint past
the speed limit. ``ArmSpeedLimiter.step`` takes one physics step with the PD's torques; if an
arm joint comes out of it faster than the limit, the step is taken again from the same state
with the arm's commands changed by what the step's own dynamics say brings those joints back
to ``Z1Cfg.speed_limiter_aim`` of the limit: the sensitivity of the new joint velocities to
the servos' commands, ``dt (M + dt D)^-1 kp`` on the arm's rows and columns, with ``M`` the
mass matrix the step used and ``D`` the damping the ``implicitfast`` integrator treats
implicitly (the servos' ``kd`` and the joints' passive damping). The contacts of the feet
are left out of that model, so up to ``Z1Cfg.speed_limiter_passes`` passes are taken.
MuJoCo's ``forcerange`` still clips every arm torque to the Z1's (``Z1Cfg.max_torque_nm``):
where braking would need more, a joint stays over and the peaks below show it.

It also keeps, since the last ``reset_peaks``, the largest arm joint speed and torque ratio
over every physics step (``peak_speed_rps``, ``peak_torque_ratio``), limiter on or off.
"""

from __future__ import annotations

import numpy as np

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.model import Indices


class ArmSpeedLimiter:
    """Steps a ``MjData`` one physics step at a time with the arm's speeds held to the limit."""

    def __init__(self, model, idx: Indices, cfg: FullBodyCfg):
        import mujoco

        self._mj = mujoco
        self._spec = mujoco.mjtState.mjSTATE_INTEGRATION
        self._state = np.empty(mujoco.mj_stateSize(model, self._spec))
        self._mass = np.zeros((model.nv, model.nv))
        self._dof, self._ctrl, self._qpos = idx.arm_dof, idx.arm_ctrl, idx.arm_qpos
        self._kp = np.asarray(cfg.z1.kp_nm_per_rad, float)
        self._kd = np.asarray(cfg.z1.kd_nms_per_rad, float)
        self._torque = np.asarray(cfg.z1.max_torque_nm, float)
        self._damping = model.dof_damping.copy()
        self._dt = model.opt.timestep
        self.limit_rps = cfg.arm.max_joint_vel_rps
        self.enabled = cfg.z1.speed_limiter
        self.passes = cfg.z1.speed_limiter_passes
        self.aim_rps = cfg.z1.speed_limiter_aim * self.limit_rps
        self.retaken = 0
        """Physics steps taken again (over all time)."""
        self.reset_peaks()

    def reset_peaks(self) -> None:
        self.peak_speed_rps = 0.0
        """Largest |joint speed| of the arm after any physics step (rad/s)."""
        self.peak_torque_ratio = 0.0
        """Largest |arm torque| over its limit in any physics step."""

    def step(self, model, data) -> None:
        """One ``mj_step`` of ``data``, taken again with braking commands while an arm joint
        would leave it above the limit. ``data.ctrl`` holds the PD's commands on entry."""
        mj = self._mj
        if self.enabled:
            mj.mj_getState(model, data, self._state, self._spec)
        mj.mj_step(model, data)
        if self.enabled:
            self._hold(model, data)
        qd = np.abs(data.qvel[self._dof])
        tau = np.abs(data.actuator_force[self._ctrl]) / self._torque
        self.peak_speed_rps = max(self.peak_speed_rps, float(qd.max()))
        self.peak_torque_ratio = max(self.peak_torque_ratio, float(tau.max()))

    def _hold(self, model, data) -> None:
        mj, dof = self._mj, self._dof
        qd = data.qvel[dof].copy()
        over = np.abs(qd) > self.limit_rps
        if not over.any():
            return
        # The mass matrix and the servo forces the step used (mj_step computed them before
        # integrating). A servo at its torque clip is first given the command that makes
        # exactly that torque, so that the correction moves its torque from there.
        mj.mj_fullM(model, data, self._mass)
        force = data.actuator_force[self._ctrl].copy()
        damping = self._damping.copy()
        damping[dof] += self._kd
        inv = np.linalg.inv(self._mass + self._dt * np.diag(damping))
        gain = self._dt * inv[np.ix_(dof, dof)] * self._kp[None, :]
        mj.mj_setState(model, data, self._state, self._spec)
        q0, qd0 = data.qpos[self._qpos], data.qvel[dof]
        ctrl = data.ctrl[self._ctrl].copy()
        clipped = np.abs(force) >= self._torque
        ctrl[clipped] = (q0 + (force + self._kd * qd0) / self._kp)[clipped]
        held = over
        for _ in range(self.passes):
            aim = np.sign(qd) * self.aim_rps
            j = np.flatnonzero(held)
            ctrl[j] += np.linalg.solve(gain[np.ix_(j, j)], aim[j] - qd[j])
            mj.mj_setState(model, data, self._state, self._spec)
            data.ctrl[self._ctrl] = ctrl
            mj.mj_step(model, data)
            self.retaken += 1
            qd = data.qvel[dof].copy()
            over = np.abs(qd) > self.limit_rps
            if not over.any():
                return
            held = held | over
