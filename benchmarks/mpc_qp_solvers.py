"""The MPC's QP solvers on the plans of real episodes: time, failures and distance to the optimum.

``python benchmarks/mpc_qp_solvers.py [--episodes N] [--every K] [--repeats R]`` plays N
episodes of the pursuit baseline against the reactive target at 1.2 m/s (4 s each, one
process, the default ``FullBodyCfg``) and keeps every K-th plan the MPC solves (its Hessian,
gradient, rows and bounds, and how many of its forces are the first step's, the ones applied).
Each solver then solves every kept plan, best of R passes timed: ``daqp``
(``qp.solve_daqp``), ``proxqp`` (``qp.solve_dense``, the bounds as ProxQP's box constraints,
the retry at ``retry_primal_inf``), and ``proxqp_rows`` (the bounds as identity rows of the
inequalities, as ``solve_dense`` posed them before). Per solver it prints the mean time per
solve, the plans it gave up on (None), the largest constraint violation, the optimality
residual (the stationarity left by the best non-negative multipliers of the active
constraints, over the gradient's norm: 0 at the exact optimum, whatever the solver) and the
applied first-step forces' largest distance, in newtons, from DAQP's. Timings need an idle
machine; the rest does not.
"""

from __future__ import annotations

import dataclasses
import json
import time

import jax
import numpy as np
import scipy.optimize
import tyro

import dyncatch.fullbody.mpc as mpc
from dyncatch.evaluation.backends import run_fullbody_episodes
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.gait import GRAVITY_MPS2
from dyncatch.fullbody.qp import proxsuite_module, solve_daqp, solve_dense
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


@dataclasses.dataclass(frozen=True)
class SolversCmd:
    episodes: int = 2
    """Episodes played to harvest the plans."""
    every: int = 5
    """Keep every this-th plan."""
    repeats: int = 3
    """Timed passes over the plans per solver (the best is kept)."""


def _proxqp_rows(hess, grad, ineq, ineq_ub, lb, ub, eps_abs, retry):
    """ProxQP with the bounds as identity rows of the inequalities (no box constraints),
    and the same retry: ``solve_dense`` as it was before it used the box."""
    qp = proxsuite_module().proxqp
    n = len(grad)
    c = np.vstack([ineq, np.eye(n)])
    lower = np.concatenate([np.full(ineq.shape[0], -np.inf), lb])
    upper = np.concatenate([ineq_ub, ub])
    result = qp.dense.solve(hess, grad, None, None, c, lower, upper, eps_abs=eps_abs)
    if result.info.status == qp.QPSolverOutput.PROXQP_PRIMAL_INFEASIBLE and retry is not None:
        again = qp.dense.QP(n, 0, c.shape[0])
        again.settings.eps_abs = eps_abs
        again.settings.eps_primal_inf = retry
        again.init(hess, grad, None, None, c, lower, upper)
        again.solve()
        result = again.results
    return result.x if result.info.status == qp.QPSolverOutput.PROXQP_SOLVED else None


def harvest(cmd: SolversCmd, cfg: FullBodyCfg) -> list[dict]:
    """The kept plans of ``cmd.episodes`` pursuit episodes (one process, so the patches
    below see every solve)."""
    plans, now, count = [], [], [0]
    plan_fn, solve_fn = mpc.contact_plan, mpc._solve

    def contact_plan(obs, cmd_, state, stance, cfg_):
        now.append((int(np.sum(stance)), obs.mass_kg))
        return plan_fn(obs, cmd_, state, stance, cfg_)

    def solve(hess, grad, ineq, ineq_ub, lb, ub, mp):
        count[0] += 1
        if count[0] % cmd.every == 0:
            args = (hess, grad, ineq, ineq_ub, lb, ub)
            feet, mass_kg = now[-1]
            plans.append({"args": [np.array(a) for a in args], "first": 3 * feet, "kg": mass_kg})
        return solve_fn(hess, grad, ineq, ineq_ub, lb, ub, mp)

    world = WorldCfg().with_speed(1.2)
    world = world.replace(episode=world.episode.replace(duration_s=4.0))
    mpc.contact_plan, mpc._solve = contact_plan, solve
    try:
        run_fullbody_episodes(
            BASELINES["pursuit"](world), jax.random.key(0), world, cmd.episodes, cfg, workers=1
        )
    finally:
        mpc.contact_plan, mpc._solve = plan_fn, solve_fn
    return plans


def optimality_residual(args, x) -> float:
    """Stationarity left by the best non-negative multipliers of the constraints active at
    ``x`` (within 1e-7), over the gradient's norm."""
    hess, grad, ineq, ineq_ub, lb, ub = args
    n = len(grad)
    rows = np.vstack([ineq, np.eye(n), -np.eye(n)])
    bounds = np.concatenate([ineq_ub, ub, -lb])
    active = np.flatnonzero(rows @ x - bounds > -1e-7)
    if len(active) == 0:  # scipy 1.17's nnls frees twice on an empty matrix
        return float(np.linalg.norm(hess @ x + grad) / np.linalg.norm(grad))
    _, residual = scipy.optimize.nnls(rows[active].T, -(hess @ x + grad))
    return float(residual / np.linalg.norm(grad))


def main(cmd: SolversCmd) -> dict:
    cfg = FullBodyCfg()
    proxsuite_module()
    mp = cfg.gait.mpc
    plans = harvest(cmd, cfg)
    solvers = {
        "daqp": lambda *a: solve_daqp(*a, mp.solver_tolerance),
        "proxqp": lambda *a: solve_dense(*a, mp.solver_tolerance, mp.retry_primal_inf),
        "proxqp_rows": lambda *a: _proxqp_rows(*a, mp.solver_tolerance, mp.retry_primal_inf),
    }
    answers, result = {}, {"plans": len(plans), "episodes": cmd.episodes, "every": cmd.every}
    for name, solve in solvers.items():
        best = np.inf
        for _ in range(cmd.repeats):
            t0 = time.perf_counter()
            out = [solve(*p["args"]) for p in plans]
            best = min(best, time.perf_counter() - t0)
        answers[name] = out
        ok = [(p, x) for p, x in zip(plans, out, strict=True) if x is not None]
        viol = [
            max(np.max(a[2] @ x - a[3]), np.max(a[4] - x), np.max(x - a[5]))
            for a, x in ((p["args"], x) for p, x in ok)
        ]
        resid = np.array([optimality_residual(p["args"], x) for p, x in ok])
        result[name] = {
            "ms_per_solve": round(1e3 * best / len(plans), 4),
            "gave_up": sum(x is None for x in out),
            "max_violation": float(np.max(viol)),
            "optimality_residual_p50": float(np.median(resid)),
            "optimality_residual_p99": float(np.quantile(resid, 0.99)),
            "optimality_residual_max": float(np.max(resid)),
        }
    for name in ("proxqp", "proxqp_rows"):
        diffs = [  # the forces are solved in units of the robot's weight
            p["kg"] * GRAVITY_MPS2 * np.max(np.abs(a[: p["first"]] - b[: p["first"]]))
            for p, a, b in zip(plans, answers["daqp"], answers[name], strict=True)
            if a is not None and b is not None
        ]
        result[name]["first_step_force_from_daqp_n"] = {
            "p50": round(float(np.median(diffs)), 4),
            "p99": round(float(np.quantile(diffs, 0.99)), 4),
            "max": round(float(np.max(diffs)), 4),
        }
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(SolversCmd))
