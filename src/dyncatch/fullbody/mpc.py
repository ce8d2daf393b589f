"""Stance forces by convex MPC on single-rigid-body dynamics (Di Carlo et al., IROS 2018).

The robot is one rigid body at its centre of mass: state ``x = (roll, pitch, yaw, p, w, v)``
(12,), world frame, with the linearisation of the MIT Cheetah 3 (Euler rates ``Rz(yaw)^T w``,
the inertia rotated by the measured attitude, the feet's lever arms fixed over a step). Over
``MpcCfg.horizon_steps`` steps spanning one trot cycle (``step_durations_s``: the first one
control period long) the timed gait's contact schedule is known, and so are the feet: those
on the ground where they stand, those that will land at Raibert's point
(``gait.touchdown_point``). The arm's measured reaction (``gait.arm_reaction``) enters as a
known disturbance wrench, held over the horizon. The condensed QP (forces of the stance feet
only, friction pyramids, normal-force bounds) is solved by DAQP (``MpcCfg.solver``);
the first step's forces go to the feet as ``-J^T f``, as the least-squares stance does. Roll
and pitch are integrated into the aim (offset-free), and so is the velocity error, clipped.

Why it answers the arm where the least squares cannot: on two feet no force makes a moment
about the line joining them, and a one-step solve gives that part up. Over a cycle the next
pair's line crosses it, and the plan moves the COM now so that the next stance can catch it.
"""

from __future__ import annotations

import functools

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
from dyncatch.fullbody.qp import proxsuite_module, solve_daqp, solve_dense


def _rot_z(yaw: float) -> np.ndarray:
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def step_durations_s(cfg: FullBodyCfg) -> np.ndarray:
    """(N,) durations of the horizon's steps, which together span one trot cycle. With
    ``MpcCfg.short_first_step`` the first lasts the time its forces are really held
    (``GaitCfg.stance_solve_every`` control periods) and the others share the rest;
    otherwise all are equal."""
    g, n = cfg.gait, cfg.gait.mpc.horizon_steps
    if not g.mpc.short_first_step:
        return np.full(n, g.period_s / n)
    first = g.stance_solve_every / cfg.control_hz
    return np.concatenate([[first], np.full(n - 1, (g.period_s - first) / (n - 1))])


def _zoh(b: np.ndarray, rot_t: np.ndarray, dt) -> None:
    """Give the rows of angles and position (0:6) of ``b`` (12, k) their share of a rate
    change (rows 6:12) held over the step, in place: half of it times ``dt`` (a float, or
    (k,) per column; exact for a double integrator under a held input), the angular part
    through ``rot_t`` = ``Rz(yaw)^T``. Without it a force moved the attitude only a step
    later, and the plan, seeing a slower robot, answered a pitch error by half as much."""
    b[0:3] = 0.5 * dt * (rot_t @ b[6:9])
    b[3:6] = 0.5 * dt * b[9:12]


def _skews(v: np.ndarray) -> np.ndarray:
    """(..., 3, 3) cross-product matrices of the vectors ``v`` (..., 3)."""
    out = np.zeros((*v.shape, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


@functools.lru_cache(maxsize=16)
def _pyramids(feet: int, mu: float, fz_min: float, fz_max: float):
    """Friction pyramids ``ineq u <= 0`` (4 feet, 3 feet) and bounds (3 feet,) of ``feet``
    forces; cached (read-only), as only the number of feet changes between solves."""
    cone = np.array([[1.0, 0, -mu], [-1.0, 0, -mu], [0, 1.0, -mu], [0, -1.0, -mu]])
    out = (
        np.kron(np.eye(feet), cone),
        np.tile([-mu * fz_max, -mu * fz_max, fz_min], feet),
        np.tile([mu * fz_max, mu * fz_max, fz_max], feet),
    )
    for a in out:
        a.flags.writeable = False
    return out


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


def transition(dt: float, yaw: float) -> np.ndarray:
    """(12, 12) ``A`` of one step: ``I + dt N``, ``N`` taking the rates to the angles (through
    ``Rz(yaw)^T``) and positions."""
    a = np.eye(12)
    a[0:3, 6:9] = _rot_z(yaw).T * dt
    a[3:6, 9:12] = np.eye(3) * dt
    return a


def condense(
    dts: np.ndarray, yaw: float, blocks: list[np.ndarray], c_k: list[np.ndarray]
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The horizon's states as ``X = Aqp x0 + Bqp U + Cqp`` (``X`` = (x_1, ..., x_N)):
    ``Aqp`` (12N, 12), ``Bqp`` (12N, sum of the blocks' widths), ``Cqp`` (12N,), from the
    steps' durations ``dts`` (N,), inputs ``blocks`` (12, w_k) and offsets ``c_k`` (12,).

    ``N`` squared is zero (rates move angles and positions, nothing moves the rates), so a
    product of transitions is ``A_i ... A_{j+1} = I + (t_i - t_j) N``: every block of ``Bqp``
    is ``B_j + T N B_j``, written at once instead of by N(N + 1)/2 matrix products."""
    n = len(dts)
    nil = transition(1.0, yaw) - np.eye(12)
    t = np.cumsum(dts)  # t_i: the end of step i
    a_qp = np.eye(12)[None] + t[:, None, None] * nil[None]
    widths = [b.shape[1] for b in blocks]
    offsets = np.concatenate([[0], np.cumsum(widths)]).astype(int)
    b_qp = np.zeros((n, 12, int(offsets[-1])))
    for j, b in enumerate(blocks):
        lag = t[j:] - t[j]  # (n - j,): from the end of step j to the end of step i
        b_qp[j:, :, offsets[j] : offsets[j + 1]] = b[None] + lag[:, None, None] * (nil @ b)[None]
    c_qp = np.zeros((n, 12))
    acc = np.zeros(12)
    for i in range(n):
        acc = acc + dts[i] * (nil @ acc) + c_k[i]
        c_qp[i] = acc
    return a_qp.reshape(12 * n, 12), b_qp.reshape(12 * n, -1), c_qp.reshape(-1)


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
    rot_t = _rot_z(yaw).T
    com_path = np.vstack([obs.com_m, ref[:-1, 3:6]])
    lever = inv_i @ _skews(feet - com_path[:, None])  # (N, 4, 3, 3)
    unit_force = np.eye(3)[:, None, :] / m
    blocks, legs_k = [], []
    for k in range(n):
        dt = dts[k]
        legs = np.flatnonzero(sched[k])
        b = np.zeros((12, 3 * len(legs)))
        b[6:9] = lever[k, legs].transpose(1, 0, 2).reshape(3, -1) * dt
        b[9:12].reshape(3, len(legs), 3)[:] = unit_force * dt  # each foot's force / m
        _zoh(b, rot_t, dt)
        blocks.append(b)
        legs_k.append(legs)
    offset_cols = rate[:, None] * dts[None, :]  # (12, N): c_k by column
    _zoh(offset_cols, rot_t, dts)
    c_k = list(offset_cols.T)
    counts = np.array([len(legs) for legs in legs_k])
    offsets = np.concatenate([[0], np.cumsum(3 * counts)])
    nvar = int(offsets[-1])
    a_qp, b_qp, c_qp = condense(dts, yaw, blocks, c_k)

    # Each step's cost counts for its duration; forces are penalised away from the weight
    # shared evenly over the step's stance feet (not away from zero, which would starve the
    # short first step of support).
    share = dts / dts.mean()
    q_diag = (share[:, None] * np.asarray(mp.state_weights, float)).reshape(-1)
    r_diag = np.repeat(mp.force_weight * share, 3 * counts)
    u_nom = np.zeros(nvar)
    u_nom[2::3] = np.repeat(m * GRAVITY_MPS2 / np.maximum(counts, 1), counts)
    free = a_qp @ x0 + c_qp - ref.reshape(-1)
    hess = b_qp.T @ (q_diag[:, None] * b_qp) + np.diag(r_diag)
    grad = b_qp.T @ (q_diag * free) - r_diag * u_nom

    ineq, lb, ub = _pyramids(
        nvar // 3, g.friction_coef, mp.min_normal_force_n, mp.max_normal_force_n
    )
    ineq_ub = np.zeros(len(ineq))
    if mp.leg_torque_share is not None and obs.leg_torque_limit_nm is not None:
        rows, limits = torque_rows(obs, sched, feet, legs_k, offsets, mp.leg_torque_share)
        ineq, ineq_ub = np.vstack([ineq, rows]), np.concatenate([ineq_ub, limits])
    # Solved in units of the robot's weight, the cost scaled to a unit largest curvature:
    # in newtons the curvature is ~1e-6 and the solver's tolerances would leave tens of
    # newtons unresolved.
    unit = m * GRAVITY_MPS2
    hess_u, grad_u = hess * unit**2, grad * unit
    scale = 1.0 / np.max(np.diag(hess_u))
    u = _solve(hess_u * scale, grad_u * scale, ineq, ineq_ub / unit, lb / unit, ub / unit, mp)
    if u is None:
        return stance_forces(obs, cmd, state, stance, cfg)
    forces = np.zeros((4, 3))
    forces[legs_k[0]] = unit * u[: offsets[1]].reshape(-1, 3)
    return forces


def torque_rows(
    obs: RobotObs,
    sched: np.ndarray,
    feet: np.ndarray,
    legs_k: list[np.ndarray],
    offsets: np.ndarray,
    share: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Rows ``G u <= h`` (newtons, N m) holding each standing foot's joint torques
    ``|J^T f|`` within ``share`` of its motors' limits, at every step while the foot stays
    where it stands now (its Jacobian now; a foot that lands within the horizon is not
    bounded: its leg's posture there is not known)."""
    nvar = int(offsets[-1])
    limits = np.asarray(obs.leg_torque_limit_nm, float).reshape(4, 3) * share
    # (N, 4): the foot stands now and, at step k, where it stands now.
    stays = sched[0][None] & np.isclose(feet, obs.feet_m[None]).all(axis=-1)
    picks = [
        (int(offsets[k]) + 3 * j, leg)
        for k, legs in enumerate(legs_k)
        for j, leg in enumerate(legs)
        if stays[k, leg]
    ]
    if not picks:
        return np.zeros((0, nvar)), np.zeros(0)
    rows = np.zeros((len(picks), 2, 3, nvar))
    for i, (col, leg) in enumerate(picks):
        rows[i, 0, :, col : col + 3] = obs.foot_jac[leg].T
    rows[:, 1] = -rows[:, 0]
    bounds = np.repeat(limits[[leg for _, leg in picks]][:, None], 2, axis=1)
    return rows.reshape(-1, nvar), bounds.reshape(-1)


def _solve(hess, grad, ineq, ineq_ub, lb, ub, mp) -> np.ndarray | None:
    """The QP ``hess``, ``grad``, ``ineq u <= ineq_ub``, ``lb <= u <= ub`` by
    ``MpcCfg.solver``."""
    if mp.solver == "daqp":
        return solve_daqp(hess, grad, ineq, ineq_ub, lb, ub, mp.solver_tolerance)
    if mp.solver == "proxqp":
        return solve_dense(
            hess, grad, ineq, ineq_ub, lb, ub, mp.solver_tolerance, mp.retry_primal_inf
        )
    # Another solver of qpsolvers (an optional dependency); imported here, after
    # fullbody.qp has loaded ProxSuite's reproducible build, which qpsolvers then shares.
    proxsuite_module()
    import qpsolvers

    return qpsolvers.solve_qp(
        hess,
        grad,
        ineq,
        ineq_ub,
        lb=lb,
        ub=ub,
        solver=mp.solver,
        eps_abs=mp.solver_tolerance,
    )
