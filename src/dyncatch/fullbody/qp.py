"""ProxSuite's dense QP solver from its SSE2 build, so that a solve repeats to the bit.

ProxSuite's wheel ships builds for AVX-512, AVX2 and SSE2 and loads the widest the CPU has.
In the wide builds Eigen's vectorised loops peel up to the first 32- or 64-byte boundary of
each of the solver's heap buffers, which malloc aligns to 16 bytes only: the same QP gives
answers that differ in their last bits with where the workspace landed (measured: 60 MPC
solves of one trot, the same inputs, two different answers; the SSE2 build, whose 16-byte
packets match the heap's alignment, gives one). Over a trot those bits grow into different
episodes, so neither the same key played twice nor episodes split over worker processes
repeated one another. One build can be loaded per process (they register the same Python
types): ``proxsuite_module`` loads the SSE2 build when it is the first to import ProxSuite
(the first solve calls it, and ``mpc._solve`` before it imports ``qpsolvers``); if another
build was loaded before it, it warns once and solves with that one. Importing this module
imports no ProxSuite, an optional dependency (the fullbody extra), so that the core library
(``dyncatch train``, evaluation) runs without it. ``solve_daqp`` solves the same QP by DAQP
(the default ``MpcCfg.solver``), whose answers repeat to the bit without such care.
"""

from __future__ import annotations

import sys
import types
import warnings

import numpy as np

SSE2_BUILD = "proxsuite.proxsuite_pywrap"
"""The module of ProxSuite's SSE2 build (``proxsuite/__init__.py`` picks among three)."""


_PROXSUITE = None
"""The ProxSuite build in use, once ``proxsuite_module`` has loaded it."""


def proxsuite_module():
    """ProxSuite's SSE2 build, loaded on first use (a warning if another build came first)."""
    global _PROXSUITE
    if _PROXSUITE is None:
        _PROXSUITE = _load_sse2()
        if _PROXSUITE.__name__ != SSE2_BUILD:
            warnings.warn(
                f"ProxSuite was imported with its {_PROXSUITE.__name__} build before "
                "dyncatch.fullbody.qp loaded it: the MPC's solves (and full-body episodes) "
                "will not repeat to the bit; solve with dyncatch.fullbody before importing "
                "qpsolvers or proxsuite",
                stacklevel=2,
            )
    return _PROXSUITE


def _load_sse2():
    if "proxsuite" not in sys.modules:
        # proxsuite/__init__.py asks proxsuite.instructionset which wide build the CPU runs;
        # answered "none", it loads the SSE2 build.
        shim = types.ModuleType("proxsuite.instructionset")
        shim.has_AVX512F = shim.has_AVX2 = lambda: False
        sys.modules["proxsuite.instructionset"] = shim
        try:
            import proxsuite  # noqa: F401
        finally:
            del sys.modules["proxsuite.instructionset"]
    return sys.modules["proxsuite"]._submodule


def solve_dense(
    hess: np.ndarray,
    grad: np.ndarray,
    ineq: np.ndarray,
    ineq_ub: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    eps_abs: float,
    retry_primal_inf: float | None = None,
) -> np.ndarray | None:
    """``argmin 1/2 x' hess x + grad' x`` s.t. ``ineq x <= ineq_ub``, ``lb <= x <= ub`` by
    ProxSuite's dense ProxQP; None if it does not converge. ``hess`` (n, n), ``ineq`` (m, n).

    A solve that ProxQP reports primal infeasible is solved again with its infeasibility
    tolerance ``eps_primal_inf`` at ``retry_primal_inf`` (None: no second solve), for
    problems the caller knows to be feasible; a solve that converges the first time is
    returned as it is."""
    n, rows = grad.shape[0], ineq.shape[0]
    lower = np.full(rows, -np.inf)
    qp = proxsuite_module().proxqp
    # The bounds as ProxQP's box constraints, not as identity rows of ``ineq``: the same
    # answers, 13 % less time a solve (benchmarks/mpc_qp_solvers.py).
    result = qp.dense.solve(
        hess, grad, None, None, ineq, lower, ineq_ub, l_box=lb, u_box=ub, eps_abs=eps_abs
    )
    status = result.info.status
    if status == qp.QPSolverOutput.PROXQP_PRIMAL_INFEASIBLE and retry_primal_inf is not None:
        # The functional API has no infeasibility tolerance; the QP object has.
        again = qp.dense.QP(n, 0, rows, box_constraints=True)
        again.settings.eps_abs = eps_abs
        again.settings.eps_primal_inf = retry_primal_inf
        again.init(hess, grad, None, None, ineq, lower, ineq_ub, lb, ub)
        again.solve()
        result, status = again.results, again.results.info.status
    if status != qp.QPSolverOutput.PROXQP_SOLVED:
        return None
    return result.x


def solve_daqp(
    hess: np.ndarray,
    grad: np.ndarray,
    ineq: np.ndarray,
    ineq_ub: np.ndarray,
    lb: np.ndarray,
    ub: np.ndarray,
    primal_tol: float,
) -> np.ndarray | None:
    """The same QP as ``solve_dense`` by DAQP (Arnstrom, Bemporad and Axehill, IEEE TAC
    2022), a dual active-set method for the small dense QPs of MPC: it ends on the exact
    optimum of an active set (within ``primal_tol`` of each constraint), where an
    interior or proximal method stops within a tolerance of it. None if it does not
    report an optimum. Imported on first use (the fullbody extra)."""
    import daqp

    # Bounds longer than the rows of ``ineq``: DAQP reads the first ones as simple bounds.
    upper = np.concatenate([ub, ineq_ub])
    lower = np.concatenate([lb, np.full(ineq.shape[0], -np.inf)])
    # DAQP's Cython signature takes writable buffers only (the cached pyramids are not).
    hess, grad, ineq = (np.require(a, np.float64, ["C", "W"]) for a in (hess, grad, ineq))
    x, _, exitflag, _ = daqp.solve(
        hess,
        grad,
        ineq,
        upper,
        lower,
        np.zeros(len(upper), dtype=np.int32),
        primal_tol=primal_tol,
    )
    return x if exitflag in (1, 2) else None
