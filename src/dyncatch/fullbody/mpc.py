"""Stance forces by convex MPC on single-rigid-body dynamics (Di Carlo et al., IROS 2018).

The robot is one rigid body at its centre of mass: state ``x = (roll, pitch, yaw, p, w, v)``
(12,), world frame, with the linearisation of the MIT Cheetah 3 (Euler rates ``Rz(yaw)^T w``,
the inertia rotated by the measured attitude, the feet's lever arms fixed over a step). Over
``MpcCfg.horizon_steps`` steps spanning one trot cycle (``step_durations_s``: the first one
control period long) the timed gait's contact schedule is known, and so are the feet: those
on the ground where they stand, those that will land at Raibert's point
(``gait.touchdown_point``). The arm's measured reaction (``gait.arm_reaction``) enters as a
known disturbance wrench, held over the horizon. The condensed QP (forces of the stance feet
only, friction pyramids, normal-force bounds) is solved by ``qpsolvers`` (``MpcCfg.solver``);
the first step's forces go to the feet as ``-J^T f``, as the least-squares stance does. Roll
and pitch are integrated into the aim (offset-free), and so is the velocity error, clipped.

Why it answers the arm where the least squares cannot: on two feet no force makes a moment
about the line joining them, and a one-step solve gives that part up. Over a cycle the next
pair's line crosses it, and the plan moves the COM now so that the next stance can catch it.
"""

from __future__ import annotations

import numpy as np

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.gait import (
    GRAVITY_MPS2,
    PAIR_OF_LEG,
    GaitState,
    RobotObs,
    arm_reaction,
    horizontal_accel,
    stance_forces,
    touchdown_point,
    yaw_of,
)
from dyncatch.fullbody.qp import solve_dense


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])


def _rot_z(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def step_durations_s(cfg: FullBodyCfg) -> np.ndarray:
    """(N,) durations of the horizon's steps, which together span one trot cycle. With
    ``MpcCfg.short_first_step`` the first lasts one control period (the time its forces are
    really held) and the others share the rest; otherwise all are equal."""
    g, n = cfg.gait, cfg.gait.mpc.horizon_steps
    if not g.mpc.short_first_step:
        return np.full(n, g.period_s / n)
    first = 1.0 / cfg.control_hz
    return np.concatenate([[first], np.full(n - 1, (g.period_s - first) / (n - 1))])


def _zoh(b: np.ndarray, yaw: float, dt: float) -> None:
    """Give the rows of angles and position (0:6) of ``b`` (12, k) their share of a rate
    change (rows 6:12) held over the step, in place: half of it times ``dt`` (exact for a
    double integrator under a held input). Without it a force moved the attitude only a step
    later, and the plan, seeing a slower robot, answered a pitch error by half as much."""
    b[0:3] = 0.5 * dt * (_rot_z(yaw).T @ b[6:9])
    b[3:6] = 0.5 * dt * b[9:12]


def contact_plan(
    obs: RobotObs, cmd: np.ndarray, state: GaitState, stance: np.ndarray, cfg: FullBodyCfg
) -> tuple[np.ndarray, np.ndarray]:
    """The horizon's contact schedule (N, 4) bool and feet (N, 4, 3) (world), step 0 now.

    A foot on the ground stays where it is until it lifts off; a foot that lands within the
    horizon lands at Raibert's point for that time. Standing, all four stay down."""
    g, n = cfg.gait, cfg.gait.mpc.horizon_steps
    half = 0.5 * g.period_s
    sched = np.ones((n, 4), bool)
    feet = np.repeat(obs.feet_m[None], n, axis=0)
    sched[0] = stance
    if not state.trotting:
        return sched, feet
    t_end = (0.5 - state.phase % 0.5) * g.period_s  # the current half cycle ends
    t = np.concatenate([[0.0], np.cumsum(step_durations_s(cfg))[:-1]])  # step starts
    for k in range(1, n):
        swing_pair = 0 if (state.phase + t[k] / g.period_s) % 1.0 < 0.5 else 1
        sched[k] = PAIR_OF_LEG != swing_pair
    for leg in range(4):
        # Swinging now: lands at the half's end; standing now: lands a half cycle later.
        t_land = t_end if not stance[leg] else t_end + half
        if t_land < t[-1]:
            land = touchdown_point(obs, cmd, leg, t_land, cfg)
            feet[t >= t_land - 1e-9, leg] = land
    return sched, feet


def _reference(
    obs: RobotObs, cmd: np.ndarray, state: GaitState, cfg: FullBodyCfg, yaw: float
) -> np.ndarray:
    """(N, 12) desired states at steps 1..N: level, at the standing height, at the command's
    velocity and yaw rate (integrated from now), or holding the stop while standing."""
    g, n = cfg.gait, cfg.gait.mpc.horizon_steps
    dts = step_durations_s(cfg)
    t = np.cumsum(dts)  # step ends
    ref = np.zeros((n, 12))
    yaw0 = yaw + (state.yaw_ref_rad - yaw + np.pi) % (2 * np.pi) - np.pi
    yaw_t = yaw0 + cmd[2] * t
    ref[:, 2] = yaw_t
    # Offset-free: a steady tilt (what the rigid body does not model: the legs' swing, the
    # joints' friction) moves the level the plan aims at until the trunk is level.
    ref[:, 0:2] = -g.mpc.ki_tilt_per_s * state.tilt_int_rad_s
    com_z = obs.com_m[2] + cfg.stand_height_m - obs.base_pos_m[2]
    if state.trotting:
        # The velocity integral lifts the aim over the command (joint friction's lag).
        v_int = g.mpc.vel_int_share * (_rot_z(yaw)[:2, :2] @ state.vel_err_int_m)
        norm = float(np.linalg.norm(v_int))
        if norm > g.mpc.max_vel_int_mps:
            v_int *= g.mpc.max_vel_int_mps / norm
        c, s = np.cos(yaw_t), np.sin(yaw_t)
        vx = c * cmd[0] - s * cmd[1] + v_int[0]
        vy = s * cmd[0] + c * cmd[1] + v_int[1]
        ref[:, 9], ref[:, 10] = vx, vy
        ref[:, 3] = obs.com_m[0] + np.cumsum(vx * dts)
        ref[:, 4] = obs.com_m[1] + np.cumsum(vy * dts)
    else:
        ref[:, 3:5] = obs.com_m[:2] + state.hold_xy_m - obs.base_pos_m[:2]
    ref[:, 5] = com_z
    ref[:, 8] = cmd[2]
    return ref


def mpc_stance_forces(
    obs: RobotObs, cmd: np.ndarray, state: GaitState, stance: np.ndarray, cfg: FullBodyCfg
) -> np.ndarray:
    """Ground reaction forces (4, 3) on the stance feet (zeros elsewhere): the first step of
    the convex MPC's plan. Falls back to the least-squares stance if the QP fails."""
    g, mp = cfg.gait, cfg.gait.mpc
    n, m = mp.horizon_steps, obs.mass_kg
    r = obs.base_rot
    roll = np.arctan2(r[2, 1], r[2, 2])
    pitch = -np.arcsin(np.clip(r[2, 0], -1.0, 1.0))
    yaw = yaw_of(r)
    x0 = np.concatenate([[roll, pitch, yaw], obs.com_m, obs.base_angvel_rps, obs.base_vel_mps])
    sched, feet = contact_plan(obs, cmd, state, stance, cfg)
    ref = _reference(obs, cmd, state, cfg, yaw)

    inertia_w = r @ np.diag(g.inertia_kgm2) @ r.T
    inv_i = np.linalg.inv(inertia_w)
    # Known affine terms: gravity and the arm's reaction (held over the horizon).
    dist = np.zeros(6)
    if g.arm_reaction:
        acc = np.zeros(3)
        acc[:2], _ = horizontal_accel(obs, cmd, state, cfg)
        acc[2] = GRAVITY_MPS2
        dist = arm_reaction(obs, acc)
    rate = np.zeros(12)
    rate[6:9] = -inv_i @ dist[3:]
    rate[9:12] = np.array([0.0, 0.0, -GRAVITY_MPS2]) - dist[:3] / m

    # Step k: x_{k+1} = A_k x_k + B_k u_k + c_k, B_k over the stance feet of step k; the COM
    # moves along the reference.
    dts = step_durations_s(cfg)
    com_path = np.vstack([obs.com_m, ref[:-1, 3:6]])
    a_k, blocks, c_k, legs_k = [], [], [], []
    for k in range(n):
        dt = dts[k]
        a = np.eye(12)
        a[0:3, 6:9] = _rot_z(yaw).T * dt
        a[3:6, 9:12] = np.eye(3) * dt
        legs = np.flatnonzero(sched[k])
        b = np.zeros((12, 3 * len(legs)))
        for j, leg in enumerate(legs):
            b[6:9, 3 * j : 3 * j + 3] = inv_i @ _skew(feet[k, leg] - com_path[k]) * dt
            b[9:12, 3 * j : 3 * j + 3] = np.eye(3) * dt / m
        _zoh(b, yaw, dt)
        c = rate * dt
        _zoh(c[:, None], yaw, dt)
        a_k.append(a)
        blocks.append(b)
        c_k.append(c)
        legs_k.append(legs)
    offsets = np.concatenate([[0], np.cumsum([b.shape[1] for b in blocks])])
    nvar = int(offsets[-1])

    # Condensed: X = Aqp x0 + Bqp U + Cqp, X = (x_1, ..., x_N).
    a_qp = np.zeros((12 * n, 12))
    b_qp = np.zeros((12 * n, nvar))
    c_qp = np.zeros(12 * n)
    x_free, acc_c = np.eye(12), np.zeros(12)
    for i in range(n):
        x_free = a_k[i] @ x_free
        acc_c = a_k[i] @ acc_c + c_k[i]
        a_qp[12 * i : 12 * i + 12] = x_free
        c_qp[12 * i : 12 * i + 12] = acc_c
    for j in range(n):
        prop = blocks[j]
        for i in range(j, n):
            if i > j:
                prop = a_k[i] @ prop
            b_qp[12 * i : 12 * i + 12, offsets[j] : offsets[j + 1]] = prop
    # Each step's cost counts for its duration; forces are penalised away from the weight
    # shared evenly over the step's stance feet (not away from zero, which would starve the
    # short first step of support).
    share = dts / dts.mean()
    q_diag = (share[:, None] * np.asarray(mp.state_weights, float)).reshape(-1)
    r_diag = np.concatenate(
        [np.full(b.shape[1], mp.force_weight * w) for b, w in zip(blocks, share, strict=True)]
    )
    u_nom = np.concatenate(
        [np.tile([0.0, 0.0, m * GRAVITY_MPS2 / max(len(legs), 1)], len(legs)) for legs in legs_k]
    )
    free = a_qp @ x0 + c_qp - ref.reshape(-1)
    hess = b_qp.T @ (q_diag[:, None] * b_qp) + np.diag(r_diag)
    grad = b_qp.T @ (q_diag * free) - r_diag * u_nom

    mu, fz_max = g.friction_coef, mp.max_normal_force_n
    feet_n = nvar // 3
    cone = np.array([[1.0, 0, -mu], [-1.0, 0, -mu], [0, 1.0, -mu], [0, -1.0, -mu]])
    ineq = np.kron(np.eye(feet_n), cone)
    lb = np.tile([-mu * fz_max, -mu * fz_max, mp.min_normal_force_n], feet_n)
    ub = np.tile([mu * fz_max, mu * fz_max, fz_max], feet_n)
    # Solved in units of the robot's weight, the cost scaled to a unit largest curvature:
    # in newtons the curvature is ~1e-6 and the solver's tolerances would leave tens of
    # newtons unresolved.
    unit = m * GRAVITY_MPS2
    hess_u, grad_u = hess * unit**2, grad * unit
    scale = 1.0 / np.max(np.diag(hess_u))
    u = _solve(hess_u * scale, grad_u * scale, ineq, lb / unit, ub / unit, mp)
    if u is None:
        return stance_forces(obs, cmd, state, stance, cfg)
    forces = np.zeros((4, 3))
    forces[legs_k[0]] = unit * u[: offsets[1]].reshape(-1, 3)
    return forces


def _solve(hess, grad, ineq, lb, ub, mp) -> np.ndarray | None:
    """The QP ``hess``, ``grad``, ``ineq u <= 0``, ``lb <= u <= ub`` by ``MpcCfg.solver``."""
    if mp.solver == "proxqp":
        return solve_dense(hess, grad, ineq, np.zeros(len(ineq)), lb, ub, mp.solver_tolerance)
    # Another solver of qpsolvers (an optional dependency); imported here, after
    # fullbody.qp has loaded ProxSuite's reproducible build, which qpsolvers then shares.
    import qpsolvers

    return qpsolvers.solve_qp(
        hess,
        grad,
        ineq,
        np.zeros(len(ineq)),
        lb=lb,
        ub=ub,
        solver=mp.solver,
        eps_abs=mp.solver_tolerance,
    )
