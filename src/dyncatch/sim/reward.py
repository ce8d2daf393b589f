"""Reward of eq. 6-9 as named terms, each reported on its own."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.config import RewardCfg, SensorCfg


def reward_terms(
    prev_distance_m: jax.Array,
    distance_m: jax.Array,
    bearing_rad: jax.Array,
    success: jax.Array,
    sensor: SensorCfg,
) -> dict[str, jax.Array]:
    """Unweighted terms. Visibility holds when the true target lies in the FoV cone
    (|bearing| <= theta_FoV / 2; eq. 7 with theta_FoV the full cone)."""
    return {
        "pursuit": prev_distance_m - distance_m,
        "visibility": (jnp.abs(bearing_rad) <= 0.5 * sensor.fov_rad).astype(jnp.float32),
        "success": success.astype(jnp.float32),
    }


def weights(cfg: RewardCfg, dt_s: float) -> dict[str, float]:
    """Per-control-step weight of each term (w2 read as ``cfg.visibility_per`` says)."""
    return {
        "pursuit": cfg.pursuit,
        "visibility": cfg.visibility_weight(dt_s),
        "success": cfg.success,
    }


def total_reward(terms: dict[str, jax.Array], cfg: RewardCfg, dt_s: float) -> jax.Array:
    """Eq. 9: w1 * pursuit + w2 * visibility + w3 * success, per control step of ``dt_s``."""
    w = weights(cfg, dt_s)
    return sum(w[name] * value for name, value in terms.items())
