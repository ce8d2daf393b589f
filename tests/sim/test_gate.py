"""The batch-level gate of the arm's IK (``sim.gate``) against the ungated reference.

The reference is ``where(active, dls_step(...), 0)`` under the same transformations, with
the arm config passed to ``jit`` as an argument, as the simulator passes it (closed-over
constants are folded by XLA and round differently).
"""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.sim import arm
from dyncatch.sim import env as sim_env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.gate import compact_sizes, reference_where, where_active

CFG = WorldCfg()
A, B = CFG.arm, CFG.base
FRACTIONS = (1 / 64, 1 / 8)
CFG_AXIS = (0, 0, 0, 0, None)


def _inputs(key, shape, active_share):
    """Random in-limit poses, their gripper points, goals 0.2 m away, and active flags."""
    k_q, k_goal, k_act = jax.random.split(key, 3)
    lo, hi = arm.joint_min(A), arm.joint_max(A)
    q = jax.random.uniform(k_q, (*shape, 6), minval=lo, maxval=hi)
    fk = jax.vmap(lambda q: arm.gripper_in_base(q, A, B))
    gripper = fk(q.reshape(-1, 6)).reshape(*shape, 3)
    goal = gripper + 0.2 * jax.random.normal(k_goal, (*shape, 3))
    active = jax.random.uniform(k_act, shape) < active_share
    return active, q, gripper, goal


def _reference(active, q, gripper, goal, cfg):
    return reference_where(arm.dls_step, active, q, gripper, goal, cfg)


def _eqns(jaxpr):
    """Every equation of a jaxpr and of the jaxprs inside it, outermost first."""
    for eqn in jaxpr.eqns:
        yield eqn
        for p in eqn.params.values():
            for sub in p if isinstance(p, tuple) else (p,):
                inner = getattr(sub, "jaxpr", sub)
                if hasattr(inner, "eqns"):
                    yield from _eqns(inner)


def _batched(fn, depth):
    for _ in range(depth):
        fn = jax.vmap(fn, in_axes=CFG_AXIS)
    return jax.jit(fn)


def test_compact_sizes_by_hand():
    # 4096 / 64 = 64 and 4096 / 8 = 512; 100 / 64 rounds up to 2; never 0, never the batch;
    # none below MIN_COMPACT_BATCH (64) environments.
    assert compact_sizes(4096, FRACTIONS) == [64, 512]
    assert compact_sizes(100, FRACTIONS) == [2, 13]
    assert compact_sizes(64, FRACTIONS) == [1, 8]
    assert compact_sizes(63, FRACTIONS) == []
    assert compact_sizes(8, FRACTIONS) == []
    assert compact_sizes(1, FRACTIONS) == []
    assert compact_sizes(4096, ()) == []


def _conds(gated, batch):
    """The cond equations in the jaxpr of ``gated`` vmapped over ``batch`` environments."""
    jaxpr = jax.make_jaxpr(jax.vmap(gated, in_axes=CFG_AXIS))(
        *_inputs(jax.random.key(0), (batch,), 0.0)[:4], A
    )
    return [e for e in _eqns(jaxpr.jaxpr) if e.primitive.name == "cond"]


def test_a_small_batch_runs_nobody_or_everyone():
    # 16 environments, below MIN_COMPACT_BATCH (64): two branches (none active, the whole
    # batch), equal to the reference with none, one, some and all active; fractions () is no
    # gate at all. (With sub-batches, 16 environments would have four branches.)
    batch = 16
    gated = where_active(arm.dls_step, FRACTIONS)
    assert [len(e.params["branches"]) for e in _conds(gated, batch)] == [2]
    assert _conds(where_active(arm.dls_step, ()), batch) == []
    _, q, gripper, goal = _inputs(jax.random.key(9), (batch,), 0.0)
    ref_fn, gated_fn = _batched(_reference, 1), _batched(gated, 1)
    for count in (0, 1, 5, batch):
        active = jnp.arange(batch) < count
        out = gated_fn(active, q, gripper, goal, A)
        np.testing.assert_array_equal(out, ref_fn(active, q, gripper, goal, A))
        assert bool(jnp.all(out[~active] == 0.0))
        assert bool(jnp.all(jnp.any(out[active] != 0.0, axis=-1)))  # the IK ran on each


class TestOneBatch:
    """One vmap over environments: bit-identical to the reference in every branch."""

    # Active shares chosen to land in each branch at 1024 environments (sub-batches of 16
    # and 128 rows): none, ~1 % (16), ~6 % (128), and half or all (the whole batch).
    @pytest.mark.parametrize("share", [0.0, 0.01, 0.06, 0.5, 1.0])
    def test_equals_the_reference(self, share):
        active, q, gripper, goal = _inputs(jax.random.key(0), (1024,), share)
        gated = _batched(where_active(arm.dls_step, FRACTIONS), 1)
        out = gated(active, q, gripper, goal, A)
        ref = _batched(_reference, 1)(active, q, gripper, goal, A)
        np.testing.assert_array_equal(out, ref)
        assert bool(jnp.all(out[~active] == 0.0))

    def test_each_branch_is_taken_where_it_should_be(self):
        # None active computes nothing, 16 fit the 16-row sub-batch, 17 need the 128-row one,
        # 129 the whole batch.
        gated = where_active(arm.dls_step, FRACTIONS)
        (switch,) = _conds(gated, 1024)
        assert len(switch.params["branches"]) == 4  # none, 16 rows, 128 rows, all 1024
        nobody = switch.params["branches"][0].jaxpr
        assert not nobody.eqns or {e.primitive.name for e in nobody.eqns} <= {"broadcast_in_dim"}
        _, q, gripper, goal = _inputs(jax.random.key(1), (1024,), 0.0)
        ref_fn = _batched(_reference, 1)
        gated_fn = _batched(gated, 1)
        order = jax.random.permutation(jax.random.key(8), 1024)
        for count in (0, 1, 16, 17, 128, 129):
            active = jnp.zeros(1024, bool).at[order[:count]].set(True)
            np.testing.assert_array_equal(
                gated_fn(active, q, gripper, goal, A), ref_fn(active, q, gripper, goal, A)
            )

    def test_a_flag_shared_by_the_batch(self):
        # The IK tests vmap over goals with one active flag for all (test_arm._reach).
        _, q, gripper, goal = _inputs(jax.random.key(2), (64,), 0.0)
        gated = where_active(arm.dls_step, FRACTIONS)
        for flag in (True, False):
            out = jax.jit(jax.vmap(gated, in_axes=(None, 0, 0, 0, None)))(
                jnp.array(flag), q, gripper, goal, A
            )
            ref = jax.jit(jax.vmap(_reference, in_axes=(None, 0, 0, 0, None)))(
                jnp.array(flag), q, gripper, goal, A
            )
            np.testing.assert_array_equal(out, ref)

    def test_a_config_batched_with_the_environments(self):
        # Per-environment arm constants are gathered with the rows they belong to. Equal to
        # float rounding only: with the gain a vector XLA:CPU contracts the products into
        # fused multiply-adds differently in the two programs (measured: 2.7e-6 relative).
        active, q, gripper, goal = _inputs(jax.random.key(3), (256,), 0.05)
        gains = jnp.linspace(0.5, 1.5, 256)
        cfgs = jax.vmap(lambda g: A.replace(ik_gain=g))(gains)
        axes = jax.tree.map(lambda _: 0, A).replace(ik_gain=0)
        gated = where_active(arm.dls_step, FRACTIONS)
        out = jax.jit(jax.vmap(gated, in_axes=(0, 0, 0, 0, axes)))(active, q, gripper, goal, cfgs)
        ref = jax.jit(jax.vmap(_reference, in_axes=(0, 0, 0, 0, axes)))(
            active, q, gripper, goal, cfgs
        )
        np.testing.assert_allclose(out, ref, rtol=1e-5, atol=1e-6)
        assert bool(jnp.all(out[~active] == 0.0))


@pytest.mark.parametrize("depth", [1, 2])
def test_a_step_traces_the_arms_control_step_once_for_all_the_gates_branches(monkeypatch, depth):
    # Under vmap the gate has four branches (none, two sub-batches, all) and an unbatched
    # definition. The branches share the batching rule's trace of the reaching arm's control
    # step, inlined into each (so each program is the one a call in each branch gives: the
    # tests above and tests/sim/test_vec.py); the unbatched definition traces it once more
    # where its float arguments differ in weak typing (part of jit's cache key). Each trace
    # costs about 0.25 s of Python: a step traced in 1.0 s with one per branch, 0.5 s now.
    calls = []
    along = sim_env._arm_along

    def counted(*args, **kwargs):
        calls.append(kwargs["reach"])
        return along(*args, **kwargs)

    monkeypatch.setattr(sim_env, "_arm_along", counted)
    keys = jax.random.split(jax.random.key(0), 64)
    state = jax.vmap(sim_env.reset, in_axes=(0, None))(keys, CFG)
    if depth == 2:  # seeds around environments
        state = jax.tree.map(lambda x: jnp.broadcast_to(x, (2, *x.shape)), state)
    step = lambda s, a: sim_env.step(s, a, CFG)  # noqa: E731
    for _ in range(depth):
        step = jax.vmap(step)
    jax.make_jaxpr(step)(state, jnp.zeros((*state.step.shape, 3)))
    assert calls and all(calls) and len(calls) <= 2, calls  # the folding arm: no gate


class TestNestedVmap:
    """A vmap over seeds around a vmap over environments (``rl.seeds``)."""

    @pytest.mark.parametrize("share", [0.02, 1.0])
    def test_equals_the_flat_reference_bitwise(self, share):
        active, q, gripper, goal = _inputs(jax.random.key(4), (3, 512), share)
        out = _batched(where_active(arm.dls_step, FRACTIONS), 2)(active, q, gripper, goal, A)

        def flat(x):
            return x.reshape(3 * 512, *x.shape[2:])

        ref = _batched(_reference, 1)(flat(active), flat(q), flat(gripper), flat(goal), A)
        np.testing.assert_array_equal(flat(out), ref)
        # XLA:CPU compiles the nested reference itself within rounding of the flat one.
        nested_ref = _batched(_reference, 2)(active, q, gripper, goal, A)
        np.testing.assert_allclose(out, nested_ref, rtol=1e-5, atol=1e-5)

    def test_three_levels_and_inputs_batched_on_one_level_only(self):
        # Goals shared by the outer rows, poses per row; flags per environment only.
        active, q, gripper, goal = _inputs(jax.random.key(5), (2, 2, 128), 0.05)
        gated = where_active(arm.dls_step, FRACTIONS)
        inner = jax.vmap(gated, in_axes=CFG_AXIS)
        middle = jax.vmap(inner, in_axes=(None, 0, 0, None, None))
        outer = jax.jit(jax.vmap(middle, in_axes=(0, 0, 0, 0, None)))
        out = outer(active[:, 0], q, gripper, goal[:, 0], A)
        ref_inner = jax.vmap(_reference, in_axes=CFG_AXIS)
        ref = jax.jit(
            jax.vmap(jax.vmap(ref_inner, in_axes=(None, 0, 0, None, None)), in_axes=CFG_AXIS)
        )(active[:, 0], q, gripper, goal[:, 0], A)
        np.testing.assert_allclose(out, ref, rtol=1e-5, atol=1e-5)
        inactive = ~jnp.broadcast_to(active[:, None, 0], (2, 2, 128))
        assert bool(jnp.all(out[inactive] == 0.0))


def test_one_environment_runs_the_ik_only_when_active():
    active, q, gripper, goal = _inputs(jax.random.key(6), (4,), 0.0)
    gated = jax.jit(where_active(arm.dls_step, FRACTIONS))
    for i in range(4):
        np.testing.assert_array_equal(
            gated(jnp.array(True), q[i], gripper[i], goal[i], A),
            jax.jit(arm.dls_step)(q[i], gripper[i], goal[i], A),
        )
        np.testing.assert_array_equal(gated(jnp.array(False), q[i], gripper[i], goal[i], A), 0.0)


def _approach(state, num_envs):
    """Commands that drive each base toward its target, so that arms become active."""
    rel = state.target.xy_m - state.robot.xy_m
    yaw = jnp.arctan2(rel[:, 1], rel[:, 0]) - state.robot.yaw_rad
    return jnp.stack([jnp.full(num_envs, 1.5), jnp.zeros(num_envs), 2.0 * yaw], -1)


def _states_along_a_rollout(cfg, num_envs, num_steps):
    """The states (T, B) of a batched rollout under scan and jit."""

    def run(key, cfg):
        states = jax.vmap(sim_env.reset, in_axes=(0, None))(jax.random.split(key, num_envs), cfg)

        def body(state, _):
            action = _approach(state, num_envs)
            state, *_ = jax.vmap(sim_env.step, in_axes=(0, 0, None))(state, action, cfg)
            return state, state

        return jax.lax.scan(body, states, None, length=num_steps)[1]

    return jax.jit(run)(jax.random.key(7), cfg)


def _one_step_from_each(states, cfg, num_envs):
    """The next state of every state in ``states`` (T, B), one batched step per row."""

    def step_row(state, cfg):
        action = _approach(state, num_envs)
        return jax.vmap(sim_env.step, in_axes=(0, 0, None))(state, action, cfg)[0]

    return jax.jit(lambda s, c: jax.lax.map(lambda row: step_row(row, c), s))(states, cfg)


# With 256 environments the sub-batches have 4 and 32 rows. Starting 2-6 m away and
# approaching, the arms active within 1.5 m number 0-9 over the rollout (both sub-batches),
# within 3 m 50-73 (the whole batch).
@pytest.mark.parametrize(("activation_m", "tiers"), [(1.5, {0, 1}), (3.0, {2})])
def test_env_step_with_the_gate_equals_the_ungated_step(monkeypatch, activation_m, tiers):
    cfg = CFG.replace(arm=A.replace(activation_distance_m=activation_m))
    states = _states_along_a_rollout(cfg, 256, 60)
    gated = _one_step_from_each(states, cfg, 256)
    monkeypatch.setattr(arm, "IK_COMPACT_FRACTIONS", ())
    ungated = _one_step_from_each(states, cfg, 256)
    # To float rounding, not bitwise: ungated, XLA fuses the IK with the forward kinematics
    # and goal around it and contracts products into fused multiply-adds differently
    # (measured: a few 1e-7 rad). Across steps such differences grow where the IK is
    # ill-conditioned, as they do between any two compilations of the same step.
    for a, b in zip(jax.tree.leaves(gated), jax.tree.leaves(ungated), strict=True):
        if jax.dtypes.issubdtype(a.dtype, jax.dtypes.prng_key):
            a, b = jax.random.key_data(a), jax.random.key_data(b)
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-5)
    np.testing.assert_array_equal(gated.success, ungated.success)
    counts = np.asarray((states.distance_m <= activation_m).sum(-1))
    assert set(np.searchsorted([4, 32], counts, side="left").tolist()) == tiers


def _interleaved_physics(robot, target, command, cfg, n_sub, dt_s):
    """The sub-steps as written before the arm was gated per control step: at each, the catch
    check, the arm's update (IK where the target is near), then the base and the target."""
    best_err = jnp.full((), jnp.inf)
    for _ in range(n_sub):
        gripper_base = arm.gripper_in_base(robot.arm_q_rad, cfg.arm, cfg.base)
        best_err = jnp.minimum(
            best_err,
            sim_env.catch_error_m(sim_env.gripper_world(robot, gripper_base), target, cfg),
        )
        goal_base, active = sim_env._arm_goal(robot.xy_m, robot.yaw_rad, target.xy_m, cfg)
        q = arm.arm_substep(robot.arm_q_rad, gripper_base, goal_base, active, cfg.arm, dt_s)
        robot, target = sim_env._bodies_substep(
            robot.replace(arm_q_rad=q), target, command, jnp.zeros(2), cfg, dt_s, False, None, None
        )
    return robot.arm_q_rad, best_err, robot.xy_m, target.xy_m


def _bodies_then_arm(robot, target, command, cfg, n_sub, dt_s):
    """The simulator's order: the bodies' sub-steps, then the arm along their poses."""
    poses = []
    for _ in range(n_sub):
        poses.append((robot.xy_m, robot.yaw_rad, target.xy_m))
        robot, target = sim_env._bodies_substep(
            robot, target, command, jnp.zeros(2), cfg, dt_s, False, None, None
        )
    xy, yaw, txy = (jnp.stack(p) for p in zip(*poses, strict=True))
    q, best_err = sim_env._arm_over_step(robot.arm_q_rad, xy, yaw, txy, cfg, dt_s)
    return q, best_err, robot.xy_m, target.xy_m


def test_moving_the_bodies_first_then_the_arm_equals_the_interleaved_sub_steps():
    # The base and the target never read the arm, so the arm can follow their recorded poses;
    # with the gate (one sub-batch per control step) it equals the interleaved sub-steps.
    cfg = CFG.replace(arm=A.replace(activation_distance_m=1.5))
    states = _states_along_a_rollout(cfg, 256, 60)
    flat = jax.tree.map(lambda x: x.reshape(x.shape[0] * x.shape[1], *x.shape[2:]), states)
    n = flat.step.shape[0]
    command = _approach(flat, n)
    n_sub, dt_s = cfg.episode.physics_substeps, cfg.episode.dt_s / cfg.episode.physics_substeps

    def run(fn):
        return jax.jit(
            jax.vmap(lambda r, t, c, cfg: fn(r, t, c, cfg, n_sub, dt_s), in_axes=(0, 0, 0, None))
        )(flat.robot, flat.target, command, cfg)

    ref, new = run(_interleaved_physics), run(_bodies_then_arm)
    for a, b in zip(ref, new, strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-5)
    near = int((flat.distance_m <= 1.5).sum())
    assert 0 < near < n  # arms that reach and arms that fold
    # The catch itself (best error within the radius) is decided the same way.
    np.testing.assert_array_equal(
        ref[1] <= cfg.arm.catch_radius_m, new[1] <= cfg.arm.catch_radius_m
    )
