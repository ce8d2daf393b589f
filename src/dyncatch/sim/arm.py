"""A 6-DOF arm on the base: forward kinematics and damped-least-squares IK.

Joint order and axes (in the frame of the base: x forward, y left, z up):
1 yaw about z at the mount; 2, 3, 4 pitch (positive raises the link); 5 yaw about the
wrist's own z; 6 roll about the last link. The gripper point lies on the roll axis, so
joint 6 orients the gripper but does not move the point the position-only IK drives.

Everything is written with scalar components so that a ``vmap`` over environments gives
wide, contiguous vectors for XLA to fuse.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.config import ArmCfg, BaseCfg

IK_COMPACT_FRACTIONS = (1 / 64, 1 / 8)
"""Under ``vmap`` the arm's control step with IK (``sim.env``) runs on a compact sub-batch of
the environments whose arm is active at some sub-step, 1/64 or 1/8 of the batch, whichever
holds them all, or on the whole batch when more are active (``sim.gate``; below
``sim.gate.MIN_COMPACT_BATCH`` environments, the whole batch when any is active). Results do
not depend on it (``()`` turns the gate off), so it is a constant rather than a config field,
which would enter checkpoint headers and cache keys. The sizes: arms are active in 0.03 % of
environments under random commands (1/64 holds them) and in 4-5.5 % under the pursuit
baseline, at most 7.5 % at any step (1/8 holds them); the IK's cost grows with the rows it
solves (docs/performance.md)."""


def _chain(q: jax.Array, cfg: ArmCfg):
    """Points of the chain in the frame of joint 1 (rotated by q1, origin at the shoulder)."""
    phi2 = q[1]
    phi3 = phi2 + q[2]
    phi4 = phi3 + q[3]
    c2, s2 = jnp.cos(phi2), jnp.sin(phi2)
    c3, s3 = jnp.cos(phi3), jnp.sin(phi3)
    c4, s4 = jnp.cos(phi4), jnp.sin(phi4)
    c5, s5 = jnp.cos(q[4]), jnp.sin(q[4])
    p3 = (cfg.upper_arm_m * c2, 0.0, cfg.upper_arm_m * s2)
    p4 = (p3[0] + cfg.forearm_m * c3, 0.0, p3[2] + cfg.forearm_m * s3)
    p5 = (p4[0] + cfg.wrist_m * c4, 0.0, p4[2] + cfg.wrist_m * s4)
    reach = cfg.wrist2_m + cfg.gripper_m
    # Direction of the last links after the wrist yaw: cos q5 * x_wrist + sin q5 * y.
    d = (c5 * c4, s5, c5 * s4)
    pg = (p5[0] + reach * d[0], reach * d[1], p5[2] + reach * d[2])
    z_wrist = (-s4, 0.0, c4)
    return p3, p4, p5, pg, z_wrist


def _shoulder_base(cfg: ArmCfg, base: BaseCfg):
    return cfg.mount_x_m, base.height_m + cfg.shoulder_height_m


def gripper_in_base(q: jax.Array, cfg: ArmCfg, base: BaseCfg) -> jax.Array:
    """Gripper point in the base frame (origin under the base centre, on the ground), (3,)."""
    _, _, _, pg, _ = _chain(q, cfg)
    sx, sz = _shoulder_base(cfg, base)
    c1, s1 = jnp.cos(q[0]), jnp.sin(q[0])
    return jnp.stack([sx + c1 * pg[0] - s1 * pg[1], s1 * pg[0] + c1 * pg[1], sz + pg[2]])


def jacobian_local(q: jax.Array, cfg: ArmCfg) -> jax.Array:
    """Position Jacobian of the gripper in the joint-1 frame, (3, 6)."""
    cols = _jacobian_columns(q, cfg)
    return jnp.stack([jnp.stack([jnp.asarray(c[i], q.dtype) for c in cols]) for i in range(3)])


def _jacobian_columns(q: jax.Array, cfg: ArmCfg):
    """Columns of the position Jacobian in the joint-1 frame, as tuples of scalars.

    Revolute joint i with axis w_i through o_i contributes w_i x (p_gripper - o_i).
    """
    p3, p4, p5, pg, zw = _chain(q, cfg)

    def pitch_col(o):  # axis -y through o: (-y) x r = (-r_z, 0, r_x)
        return (o[2] - pg[2], 0.0, pg[0] - o[0])

    r = (pg[0] - p5[0], pg[1], pg[2] - p5[2])
    col5 = (zw[1] * r[2] - zw[2] * r[1], zw[2] * r[0] - zw[0] * r[2], zw[0] * r[1] - zw[1] * r[0])
    return [
        (-pg[1], pg[0], 0.0),  # yaw about z through the shoulder
        pitch_col((0.0, 0.0, 0.0)),
        pitch_col(p3),
        pitch_col(p4),
        col5,
        (0.0, 0.0, 0.0),  # roll about the last link: the gripper point lies on its axis
    ]


def _solve_spd3(a, b):
    """Solve a symmetric 3x3 system given as scalars ``a = (a00, a01, a02, a11, a12, a22)``.

    Cofactors, written out: far cheaper than a batched LU for tiny systems.
    """
    a00, a01, a02, a11, a12, a22 = a
    c00 = a11 * a22 - a12 * a12
    c01 = a02 * a12 - a01 * a22
    c02 = a01 * a12 - a02 * a11
    c11 = a00 * a22 - a02 * a02
    c12 = a01 * a02 - a00 * a12
    c22 = a00 * a11 - a01 * a01
    inv_det = 1.0 / (a00 * c00 + a01 * c01 + a02 * c02)
    return (
        inv_det * (c00 * b[0] + c01 * b[1] + c02 * b[2]),
        inv_det * (c01 * b[0] + c11 * b[1] + c12 * b[2]),
        inv_det * (c02 * b[0] + c12 * b[1] + c22 * b[2]),
    )


def dls_step(q: jax.Array, gripper_base: jax.Array, goal_base: jax.Array, cfg: ArmCfg) -> jax.Array:
    """Joint change (6,) moving the gripper (at ``gripper_base``, (3,)) toward ``goal_base``.

    dq = J^T (J J^T + lambda^2 I)^-1 e, with e the gripper error scaled by ``ik_gain``.
    """
    err = cfg.ik_gain * (goal_base - gripper_base)
    c1, s1 = jnp.cos(q[0]), jnp.sin(q[0])
    # The DLS step is invariant to a common rotation of J and e: solve in the joint-1 frame.
    e = (c1 * err[0] + s1 * err[1], -s1 * err[0] + c1 * err[1], err[2])
    cols = _jacobian_columns(q, cfg)[:5]
    damp = cfg.ik_damping**2

    def jjt(r, c):
        return sum(col[r] * col[c] for col in cols)

    a = (jjt(0, 0) + damp, jjt(0, 1), jjt(0, 2), jjt(1, 1) + damp, jjt(1, 2), jjt(2, 2) + damp)
    y = _solve_spd3(a, e)
    dq = [col[0] * y[0] + col[1] * y[1] + col[2] * y[2] for col in cols]
    # Without the barrier XLA fuses the whole solve into the stack and redoes it per joint.
    dq = jax.lax.optimization_barrier(dq)
    return jnp.stack(dq + [jnp.zeros_like(dq[0])])


def joint_min(cfg: ArmCfg) -> jax.Array:
    return jnp.asarray(cfg.joint_min_rad, jnp.float32)


def joint_max(cfg: ArmCfg) -> jax.Array:
    return jnp.asarray(cfg.joint_max_rad, jnp.float32)


def arm_substep(
    q: jax.Array,
    gripper_base: jax.Array,
    goal_base: jax.Array,
    active: jax.Array,
    cfg: ArmCfg,
    dt_s: float,
) -> jax.Array:
    """One 200 Hz arm update: reach for ``goal_base`` when ``active``, else fold to the stow pose.

    ``gripper_base`` is ``gripper_in_base(q)``, passed in because the caller needs it too.
    Joint velocities are clipped to their limit and the result to the joint limits. The IK is
    computed and then selected: the simulator gates whole control steps of the arm instead
    (``sim.env``, ``IK_COMPACT_FRACTIONS``).
    """
    dq = jnp.where(active, dls_step(q, gripper_base, goal_base, cfg), stow_delta(q, cfg))
    return _limited(q, dq, cfg, dt_s)


def stow_substep(q: jax.Array, cfg: ArmCfg, dt_s: float) -> jax.Array:
    """``arm_substep`` of an arm that is not active: fold toward the stow pose (no IK)."""
    return _limited(q, stow_delta(q, cfg), cfg, dt_s)


def stow_delta(q: jax.Array, cfg: ArmCfg) -> jax.Array:
    return jnp.asarray(cfg.stow_rad, jnp.float32) - q


def _limited(q: jax.Array, dq: jax.Array, cfg: ArmCfg, dt_s: float) -> jax.Array:
    max_dq = cfg.max_joint_vel_rps * dt_s
    q_new = q + jnp.clip(dq, -max_dq, max_dq)
    return jnp.clip(q_new, joint_min(cfg), joint_max(cfg))
