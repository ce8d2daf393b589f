"""Small planar-geometry helpers shared by the simulator layers."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

TWO_PI = 2.0 * jnp.pi


def wrap_angle(angle_rad: jax.Array) -> jax.Array:
    """Wrap to [-pi, pi). Uses floor: ``%`` is an order of magnitude slower on XLA CPU."""
    return angle_rad - TWO_PI * jnp.floor((angle_rad + jnp.pi) / TWO_PI)


def rotate(vec: jax.Array, angle_rad: jax.Array) -> jax.Array:
    """Rotate planar vectors (..., 2) by an angle (...)."""
    c, s = jnp.cos(angle_rad), jnp.sin(angle_rad)
    x, y = vec[..., 0], vec[..., 1]
    return jnp.stack([c * x - s * y, s * x + c * y], axis=-1)


def world_to_body(vec_world: jax.Array, yaw_rad: jax.Array) -> jax.Array:
    return rotate(vec_world, -yaw_rad)


def bearing(from_xy: jax.Array, from_yaw_rad: jax.Array, to_xy: jax.Array) -> jax.Array:
    """Angle of ``to`` seen from a body at ``from`` facing ``from_yaw``, in [-pi, pi)."""
    d = to_xy - from_xy
    return wrap_angle(jnp.arctan2(d[..., 1], d[..., 0]) - from_yaw_rad)


def unit(angle_rad: jax.Array) -> jax.Array:
    return jnp.stack([jnp.cos(angle_rad), jnp.sin(angle_rad)], axis=-1)


def fan(angle_rad: jax.Array, offsets_rad) -> jax.Array:
    """``unit(angle_rad + offsets_rad)`` (N, 2) for fixed ``offsets_rad`` (N,), a numpy
    array: one cosine and one sine of ``angle_rad`` rotate the offsets' constant unit
    vectors, instead of a pair per direction (equal to float rounding)."""
    offsets = np.asarray(offsets_rad, np.float64)
    fixed = np.stack([np.cos(offsets), np.sin(offsets)], axis=-1).astype(np.float32)
    return rotate(jnp.asarray(fixed), angle_rad)
