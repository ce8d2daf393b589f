"""A model-based trot at 200 Hz: stance forces by least squares, Raibert swing, PD joints.

Pure numpy on explicit inputs (``RobotObs``, the command, ``GaitState``): the MuJoCo calls
that fill ``RobotObs`` live in ``dyncatch.fullbody.env``. Each control step returns
``JointTargets`` for the joint PD law ``tau = kp (q_des - q) + kd (qd_des - qd) + tau_ff``,
which the environment re-evaluates at every physics step.

* **Gait.** A trot: the diagonal pairs (FL, RR) and (FR, RL) alternate, each swinging for
  half of ``period_s``. Under a zero command the robot finishes its current step and
  stands on four feet, holding where it stopped; any command starts the trot again.
* **Stance** (Focchi et al.'s balance controller, unconstrained): the desired wrench on the
  centre of mass (gravity, PD on height and attitude, velocity feedback, the yaw rate) is
  spread over the stance feet by damped least squares; each force is clipped to the
  friction cone and becomes joint torques ``-J^T f``.
* **Swing** (Raibert): the foot lands half a stance ahead of the hip at the commanded hip
  velocity plus a velocity-error correction; it flies there on a sine-bump path, tracked by
  joint PD through the closed-form leg IK.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.legs import FOOT_RADIUS_M, HIP_OFFSETS_M, SIDE, THIGH_OFFSET_M, leg_ik

GRAVITY_MPS2 = 9.81
PAIR_OF_LEG = np.array([0, 1, 1, 0])
"""Diagonal pair of each leg (FL, FR, RL, RR): pair 0 swings in the cycle's first half."""


@dataclasses.dataclass(frozen=True)
class RobotObs:
    """What the controller reads, at one control step (world frame unless said otherwise)."""

    base_pos_m: np.ndarray
    """(3,) trunk centre."""
    base_rot: np.ndarray
    """(3, 3) trunk orientation (columns: trunk axes in the world)."""
    base_vel_mps: np.ndarray
    """(3,) trunk linear velocity."""
    base_angvel_rps: np.ndarray
    """(3,) trunk angular velocity."""
    com_m: np.ndarray
    """(3,) centre of mass of the whole robot."""
    feet_m: np.ndarray
    """(4, 3) foot centres."""
    foot_jac: np.ndarray
    """(4, 3, 3) each foot's translational Jacobian w.r.t. its own three leg joints."""
    leg_q_rad: np.ndarray
    """(12,) leg joint angles."""
    mass_kg: float
    """Total robot mass."""
    arm_mass_kg: float
    """Mass of the arm (its six links)."""
    arm_com_m: np.ndarray
    """(3,) centre of mass of the arm."""
    arm_wrench: np.ndarray
    """(6,) what the trunk puts on the arm through its first joint: force (N), then moment
    about ``com_m`` (N m); it holds the arm's weight and drives its motion."""
    leg_torque_limit_nm: np.ndarray | None = None
    """(12,) the leg motors' torque limits (the model's ``ctrlrange``, FL/FR/RL/RR x
    hip/thigh/calf); None: not known to the controller."""


@dataclasses.dataclass(frozen=True)
class GaitState:
    """The controller's memory between control steps."""

    phase: float
    """Position in the trot cycle, [0, 1)."""
    trotting: bool
    """False while standing on four feet."""
    yaw_ref_rad: float
    """Heading the yaw feedback holds (the integral of the commanded yaw rate)."""
    hold_xy_m: np.ndarray
    """(2,) where the base stopped (the standing position hold)."""
    liftoff_m: np.ndarray
    """(4, 3) where each foot left the ground (the start of its swing path)."""
    vel_err_int_m: np.ndarray
    """(2,) integral of the velocity error (forward, left; heading frame), in metres."""
    tilt_int_rad_s: np.ndarray
    """(2,) integral of the trunk's roll and pitch (rad s): the MPC's offset-free reference
    (``MpcCfg.ki_tilt_per_s``); the least-squares stance does not read it."""
    cmd_ref: np.ndarray
    """(3,) the command the gait follows: the given one under ``BaseCfg``'s acceleration
    limits (the reduced base's own limits, so both models see the same reference)."""
    forces_n: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros((4, 3)))
    """(4, 3) the stance forces last solved for (``GaitCfg.stance_solve_every``)."""
    forces_stance: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(4, bool))
    """(4,) the stance feet they were solved for."""
    forces_age: int = 0
    """Control periods since they were solved."""


@dataclasses.dataclass(frozen=True)
class JointTargets:
    """Targets of the joint PD law for the 12 leg joints, each (12,)."""

    q_des: np.ndarray
    qd_des: np.ndarray
    tau_ff: np.ndarray
    kp: np.ndarray
    kd: np.ndarray


def yaw_of(rot: np.ndarray) -> float:
    return float(np.arctan2(rot[1, 0], rot[0, 0]))


def initial_gait_state(obs: RobotObs) -> GaitState:
    return GaitState(
        phase=0.0,
        trotting=False,
        yaw_ref_rad=yaw_of(obs.base_rot),
        hold_xy_m=obs.base_pos_m[:2].copy(),
        liftoff_m=obs.feet_m.copy(),
        vel_err_int_m=np.zeros(2),
        tilt_int_rad_s=np.zeros(2),
        cmd_ref=np.zeros(3),
    )


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _cross(a, b) -> np.ndarray:
    """``np.cross`` of two 3-vectors, written out: numpy's general version costs about 20 %
    of a full-body evaluation's CPU time (profiled), this one a tenth of it."""
    return np.array(
        [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
    )


def _wrap(a: float) -> float:
    return (a + np.pi) % (2 * np.pi) - np.pi


def horizontal_accel(
    obs: RobotObs, cmd: np.ndarray, state: GaitState, cfg: FullBodyCfg
) -> tuple[np.ndarray, bool]:
    """Desired horizontal COM acceleration (2,) (world) and whether it was clipped.

    P+I on the velocity error, the turn's feedforward, the standing position hold; the sum
    is clipped to ``max_accel_mps2``, and a clipped demand stops the integral (anti-windup:
    an infeasible command, e.g. 2 m/s while turning at 2 rad/s, must not wind it up).
    """
    g = cfg.gait
    yaw = yaw_of(obs.base_rot)
    c, s = np.cos(yaw), np.sin(yaw)
    rot = np.array([[c, -s], [s, c]])
    v_cmd = rot @ cmd[:2]
    acc = g.kp_vel_per_s * (v_cmd - obs.base_vel_mps[:2]) + g.ki_vel_per_s2 * (
        rot @ state.vel_err_int_m
    )
    # Feedforward of the turn: the commanded velocity rotates with the heading at cmd[2].
    acc += cmd[2] * np.array([-v_cmd[1], v_cmd[0]])
    if not state.trotting:
        acc += g.hold_kp_per_s2 * (state.hold_xy_m - obs.base_pos_m[:2])
    norm = float(np.linalg.norm(acc))
    if norm > g.max_accel_mps2:
        return acc * (g.max_accel_mps2 / norm), True
    return acc, False


def stance_forces(
    obs: RobotObs, cmd: np.ndarray, state: GaitState, stance: np.ndarray, cfg: FullBodyCfg
) -> np.ndarray:
    """Ground reaction forces (4, 3) on the stance feet (zeros elsewhere).

    ``cmd`` (3,) is (forward m/s, left m/s, yaw rate rad/s) in the trunk's heading frame.
    """
    g = cfg.gait
    m = obs.mass_kg
    acc = np.zeros(3)
    acc[:2], _ = horizontal_accel(obs, cmd, state, cfg)
    acc[2] = (
        g.kp_height_per_s2 * (cfg.stand_height_m - obs.base_pos_m[2])
        - g.kd_height_per_s * obs.base_vel_mps[2]
        + GRAVITY_MPS2
    )
    # Attitude error as a rotation vector: roll and pitch to level, yaw to the reference.
    r = obs.base_rot
    tilt_err = _cross(r[:, 2], np.array([0.0, 0.0, 1.0]))
    yaw_err = _wrap(state.yaw_ref_rad - yaw_of(r))
    rot_err = tilt_err + np.array([0.0, 0.0, yaw_err])
    w_err = np.array([0.0, 0.0, cmd[2]]) - obs.base_angvel_rps
    inertia_w = r @ np.diag(g.inertia_kgm2) @ r.T
    moment = inertia_w @ (g.kp_att_per_s2 * rot_err + g.kd_att_per_s * w_err)
    wrench = np.concatenate([m * acc, moment])
    if g.arm_reaction:
        wrench = wrench + arm_reaction(obs, acc)
    return distribute_wrench(obs, wrench, stance, cfg)


def arm_reaction(obs: RobotObs, acc_mps2: np.ndarray) -> np.ndarray:
    """(6,) the arm's share of the feet's wrench (force; moment about the COM) beyond a rigid
    robot's: what the trunk gives the arm, less what the arm would need were it welded to a
    trunk moving at ``acc_mps2`` (3,) (gravity included). Zero for a still arm on a still
    trunk; with it the feet answer the arm's swings instead of the trunk tilting."""
    rigid_f = obs.arm_mass_kg * acc_mps2
    rigid_m = _cross(obs.arm_com_m - obs.com_m, rigid_f)
    return obs.arm_wrench - np.concatenate([rigid_f, rigid_m])


def distribute_wrench(
    obs: RobotObs, wrench: np.ndarray, stance: np.ndarray, cfg: FullBodyCfg
) -> np.ndarray:
    """Ground reaction forces (4, 3) on the stance feet (zeros elsewhere) that best supply
    ``wrench`` (6,) (force; moment about the COM): weighted damped least squares, each force
    then clipped to the friction cone."""
    g = cfg.gait
    legs = np.flatnonzero(stance)
    a = np.zeros((6, 3 * len(legs)))
    for k, leg in enumerate(legs):
        a[:3, 3 * k : 3 * k + 3] = np.eye(3)
        a[3:, 3 * k : 3 * k + 3] = _skew(obs.feet_m[leg] - obs.com_m)
    weight = np.diag(g.wrench_weights)
    lhs = a.T @ weight @ a + g.force_damping * np.eye(a.shape[1])
    f = np.linalg.solve(lhs, a.T @ weight @ wrench).reshape(-1, 3)
    forces = np.zeros((4, 3))
    for k, leg in enumerate(legs):
        fz = max(f[k, 2], 0.0)
        fxy = f[k, :2]
        norm = np.linalg.norm(fxy)
        if norm > g.friction_coef * fz:
            fxy = fxy * (g.friction_coef * fz / max(norm, 1e-9))
        forces[leg] = (fxy[0], fxy[1], fz)
    return forces


def touchdown_point(
    obs: RobotObs, cmd: np.ndarray, leg: int, time_left_s: float, cfg: FullBodyCfg
) -> np.ndarray:
    """Raibert's landing point (3,) of a swing foot, on the ground."""
    g = cfg.gait
    r = obs.base_rot
    hip_base = HIP_OFFSETS_M[leg] + np.array([0.0, SIDE[leg] * THIGH_OFFSET_M, 0.0])
    arm_w = r @ hip_base
    hip_w = obs.base_pos_m + arm_w
    v_hip = obs.base_vel_mps + _cross(obs.base_angvel_rps, arm_w)
    yaw = yaw_of(r)
    c, s = np.cos(yaw), np.sin(yaw)
    v_cmd = np.array([c * cmd[0] - s * cmd[1], s * cmd[0] + c * cmd[1], 0.0])
    v_hip_cmd = v_cmd + _cross(np.array([0.0, 0.0, cmd[2]]), arm_w)
    stance_s = 0.5 * g.period_s
    offset = 0.5 * stance_s * v_hip_cmd[:2] + g.raibert_gain_s * (v_hip[:2] - v_hip_cmd[:2])
    # Turning: the landing point moves by the centripetal term of Pratt/MIT's heuristic.
    turn = _cross(v_cmd, [0.0, 0.0, cmd[2]])[:2]
    offset = offset + g.turn_step_gain * np.sqrt(cfg.stand_height_m / GRAVITY_MPS2) * turn
    norm = np.linalg.norm(offset)
    if norm > g.max_step_offset_m:
        offset *= g.max_step_offset_m / norm
    xy = hip_w[:2] + v_hip[:2] * time_left_s + offset
    if g.com_lateral_footholds:
        # The feet straddle the COM, not the trunk's centre line: a trot's diagonals pass
        # under the COM only then (the arm held out sideways moves it by up to 5 cm).
        left = np.array([-s, c])
        xy = xy + left * float(left @ (obs.com_m[:2] - obs.base_pos_m[:2]))
    return np.array([xy[0], xy[1], FOOT_RADIUS_M])


def _swing_foot_base(
    obs: RobotObs, start: np.ndarray, land: np.ndarray, s: float, cfg: FullBodyCfg
) -> np.ndarray:
    """Swing foot (3,) in the trunk frame at progress ``s`` in [0, 1]: a cosine blend from
    liftoff to landing, a sine bump in height, ending ``touchdown_depth_m`` into the ground."""
    blend = 0.5 - 0.5 * np.cos(np.pi * s)
    foot_w = start + (land - start) * blend
    g = cfg.gait
    foot_w[2] = FOOT_RADIUS_M + g.swing_height_m * np.sin(np.pi * s) - g.touchdown_depth_m * s
    return obs.base_rot.T @ (foot_w - obs.base_pos_m)


def slew_command(ref: np.ndarray, cmd: np.ndarray, cfg: FullBodyCfg, dt_s: float) -> np.ndarray:
    """``ref`` (3,) moved toward ``cmd`` (3,) under the base's acceleration limits in one step."""
    lin = cfg.base.max_lin_accel_mps2 * dt_s
    yaw = cfg.base.max_yaw_accel_rps2 * dt_s
    step = np.clip(np.asarray(cmd, float) - ref, [-lin, -lin, -yaw], [lin, lin, yaw])
    return ref + step


def limit_turn(cmd: np.ndarray, max_centripetal_mps2: float) -> np.ndarray:
    """``cmd`` (3,) with its yaw rate held to ``max_centripetal_mps2`` / speed."""
    speed = float(np.hypot(cmd[0], cmd[1]))
    if speed * abs(cmd[2]) <= max_centripetal_mps2:
        return cmd
    return np.array([cmd[0], cmd[1], np.sign(cmd[2]) * max_centripetal_mps2 / speed])


def trot_step(
    obs: RobotObs,
    cmd: np.ndarray,
    state: GaitState,
    cfg: FullBodyCfg,
    stance_fn: Callable = stance_forces,
) -> tuple[JointTargets, GaitState]:
    """One 200 Hz control step of the legs: ``(JointTargets, next GaitState)``.

    ``cmd`` (3,): forward and left velocity (m/s) in the heading frame, yaw rate (rad/s);
    the gait follows it through ``slew_command``. ``stance_fn``: the stance forces
    (``fullbody.stance.STANCE_CONTROLLERS``).
    """
    g = cfg.gait
    dt = 1.0 / cfg.control_hz
    cmd = slew_command(state.cmd_ref, cmd, cfg, dt)
    ref = cmd
    cmd = limit_turn(cmd, g.max_centripetal_mps2)
    moving = bool(np.any(np.abs(cmd) > 1e-3))
    trotting, phase, hold = state.trotting, state.phase, state.hold_xy_m
    if moving and not trotting:
        trotting, phase = True, 0.0
    elif trotting and not moving:
        # Stop at the end of a step, when the swinging pair has just landed.
        nxt = (phase + dt / g.period_s) % 1.0
        if (phase < 0.5 <= nxt) or nxt < phase:
            trotting, hold = False, obs.base_pos_m[:2].copy()
    yaw_ref = state.yaw_ref_rad + cmd[2] * dt if trotting else state.yaw_ref_rad
    # Keep the reference within reach, so a blocked turn cannot wind it up.
    lead = _wrap(yaw_ref - yaw_of(obs.base_rot))
    yaw_ref = yaw_of(obs.base_rot) + np.clip(lead, -g.max_yaw_lead_rad, g.max_yaw_lead_rad)

    half = 0.5 * g.period_s
    swing_pair = 0 if phase < 0.5 else 1
    swing_progress = (phase % 0.5) / 0.5
    stance = np.ones(4, bool) if not trotting else PAIR_OF_LEG != swing_pair
    liftoff = state.liftoff_m.copy()
    # A half cycle's first control step: the pair about to swing records where it lifts off.
    if trotting and (phase % 0.5) * g.period_s < 0.5 * dt:
        for leg in np.flatnonzero(PAIR_OF_LEG == swing_pair):
            liftoff[leg] = obs.feet_m[leg]
    vel_int = state.vel_err_int_m
    _, saturated = horizontal_accel(obs, cmd, state, cfg)
    if trotting and not saturated:
        yaw = yaw_of(obs.base_rot)
        c, s_ = np.cos(yaw), np.sin(yaw)
        v = obs.base_vel_mps
        err = cmd[:2] - np.array([c * v[0] + s_ * v[1], -s_ * v[0] + c * v[1]])
        lim = g.max_vel_int_m
        vel_int = np.clip(vel_int + err * dt, -lim, lim)
    r = obs.base_rot
    tilt = np.array([np.arctan2(r[2, 1], r[2, 2]), -np.arcsin(np.clip(r[2, 0], -1.0, 1.0))])
    tilt_lim = g.mpc.max_tilt_int_rad_s
    tilt_int = np.clip(state.tilt_int_rad_s + tilt * dt, -tilt_lim, tilt_lim)
    next_state = GaitState(
        phase=(phase + dt / g.period_s) % 1.0 if trotting else 0.0,
        trotting=trotting,
        yaw_ref_rad=float(yaw_ref),
        hold_xy_m=hold,
        liftoff_m=liftoff,
        vel_err_int_m=vel_int,
        tilt_int_rad_s=tilt_int,
        cmd_ref=ref,
    )
    cur = dataclasses.replace(
        state, phase=phase, trotting=trotting, yaw_ref_rad=float(yaw_ref), hold_xy_m=hold
    )
    # The forces are held for stance_solve_every periods while the same feet stand.
    age = state.forces_age + 1
    if age < g.stance_solve_every and np.array_equal(stance, state.forces_stance):
        forces = state.forces_n
    else:
        forces, age = stance_fn(obs, cmd, cur, stance, cfg), 0
    next_state = dataclasses.replace(
        next_state, forces_n=forces, forces_stance=stance, forces_age=age
    )

    q_des = obs.leg_q_rad.copy()
    qd_des = np.zeros(12)
    tau = np.zeros(12)
    kp = np.zeros(12)
    kd = np.full(12, g.stance_kd_nms_per_rad)
    for leg in range(4):
        sl = slice(3 * leg, 3 * leg + 3)
        if stance[leg]:
            tau[sl] = -obs.foot_jac[leg].T @ forces[leg]
            continue
        # The path is evaluated one control period ahead: the PD then leads, not lags.
        s = min(swing_progress + dt / half, 1.0)
        s_next = min(s + dt / half, 1.0)
        land = touchdown_point(obs, cmd, leg, (1.0 - s) * half, cfg)
        q_now = leg_ik(_swing_foot_base(obs, liftoff[leg], land, s, cfg), leg)
        q_nxt = leg_ik(_swing_foot_base(obs, liftoff[leg], land, s_next, cfg), leg)
        q_des[sl] = q_now
        qd_des[sl] = (q_nxt - q_now) / dt
        kp[sl] = g.swing_kp_nm_per_rad
        kd[sl] = g.swing_kd_nms_per_rad
    targets = JointTargets(q_des=q_des, qd_des=qd_des, tau_ff=tau, kp=kp, kd=kd)
    return targets, next_state
