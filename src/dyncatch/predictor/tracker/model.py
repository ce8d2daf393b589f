"""The self-aware tracker: the target's current position and velocity, with a Gaussian
uncertainty, at every control step, from its last sightings and the robot's own motion.

The network works in the newest capture frame (``memory``). Its mean is a residual on the
constant-velocity extrapolation of the last two sightings (the sighting plus the chord
velocity times the time since the capture; the sighting alone before there are two), so a
fresh network already tracks a straight mover. Its head is a diagonal Gaussian over position
and over velocity, trained by negative log-likelihood (``train.py``).

``Tracker`` is a frozen, hashable dataclass (a static argument of a jitted rollout); its
parameters are the same dict pytree as the predictor's::

    {"mlp": <flax params>, "in_mean": (D,), "in_std": (D,)}
"""

from __future__ import annotations

from dataclasses import dataclass

import flax.linen as nn
import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.predictor.config import TRACKER
from dyncatch.predictor.tracker.config import TrackerCfg
from dyncatch.predictor.tracker.memory import Memory, blank_memory, capture_frame_point, ingest
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import reset
from dyncatch.sim.geometry import rotate, world_to_body, wrap_angle
from dyncatch.sim.state import EnvState

Parts = dict[str, jax.Array]


class TrackerNet(nn.Module):
    """An MLP whose last layer starts at zero: a fresh tracker is its constant-turn base
    with unit standard deviations."""

    hidden: tuple[int, ...]

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        for width in self.hidden:
            x = nn.gelu(nn.Dense(width)(x))
        return nn.Dense(8, kernel_init=nn.initializers.zeros)(x)


@struct.dataclass
class Gaussian:
    """The network's estimate in the newest capture frame (leading axes for batches)."""

    pos_m: jax.Array
    """Mean target position, (2,)."""
    vel_mps: jax.Array
    """Mean target velocity, (2,)."""
    pos_std_m: jax.Array
    """Standard deviation of each position axis, (2,)."""
    vel_std_mps: jax.Array
    """Standard deviation of each velocity axis, (2,)."""


@struct.dataclass
class Estimate:
    """What a policy reads: the estimate in the robot's current base frame."""

    pos_body_m: jax.Array
    """Target position relative to the robot, (forward, left), (2,)."""
    vel_body_mps: jax.Array
    """Target velocity in the base frame, (2,)."""
    pos_std_m: jax.Array
    """RMS of the two position standard deviations (rotation-invariant), ()."""
    vel_std_mps: jax.Array
    """RMS of the two velocity standard deviations, ()."""
    defined: jax.Array
    """1.0 once a sighting was made, else 0.0 (then every other field is 0), ()."""


def chord_velocities(memory: Memory, dt_s: float) -> jax.Array:
    """(K-1, 2): the mean velocity between successive remembered sightings (0 where either
    is missing), in the newest capture frame."""
    pair = memory.valid[1:] & memory.valid[:-1]
    gap = jnp.maximum(memory.age_s[1:] - memory.age_s[:-1], dt_s)
    chord = (memory.sight_m[:-1] - memory.sight_m[1:]) / gap[:, None]
    return jnp.where(pair[:, None], chord, 0.0)


def constant_turn(
    memory: Memory, tau_s: jax.Array, dt_s: float, max_turn_rps: float
) -> tuple[jax.Array, jax.Array, jax.Array]:
    """The classical constant-turn extrapolation of the remembered sightings:
    (position (2,), velocity (2,), turn rate ()) ``tau_s`` after the newest capture.

    The newest chord is the mean velocity over its gap, so it points along the heading at
    the gap's middle and its length is ``speed * sinc(turn * gap / 2)``; the turn rate is the
    angle between the last two chords over the time between their middles (0 with fewer
    than three sightings: constant velocity; clipped to ``max_turn_rps``). It is exact on a
    circle at constant speed, whatever the gaps.
    """
    chord = chord_velocities(memory, dt_s)
    gap = jnp.where(memory.valid[1], memory.age_s[1], 0.0)
    prev_gap = jnp.where(memory.valid[2], memory.age_s[2] - memory.age_s[1], 0.0)
    heading = jnp.arctan2(chord[:, 1], chord[:, 0])
    turning = memory.valid[2] & jnp.all(jnp.sum(chord * chord, -1) > 1e-8)
    turn = wrap_angle(heading[0] - heading[1]) / jnp.maximum(0.5 * (gap + prev_gap), dt_s)
    turn = jnp.where(turning, jnp.clip(turn, -max_turn_rps, max_turn_rps), 0.0)
    # jnp.sinc(x) is sin(pi x) / (pi x).
    # Past half a turn per gap the chord's length says little; the floor keeps it finite.
    speed = jnp.linalg.norm(chord[0]) / jnp.maximum(jnp.sinc(turn * gap / (2 * jnp.pi)), 0.5)
    start = heading[0] + 0.5 * turn * gap
    now = start + turn * tau_s
    travel = speed * tau_s * jnp.sinc(turn * tau_s / (2 * jnp.pi))
    pos = memory.sight_m[0] + travel * jnp.stack(
        [jnp.cos(0.5 * (start + now)), jnp.sin(0.5 * (start + now))]
    )
    vel = speed * jnp.stack([jnp.cos(now), jnp.sin(now)])
    moving = memory.valid[1]
    return (
        jnp.where(moving, pos, memory.sight_m[0]),
        jnp.where(moving, vel, 0.0),
        turn,
    )


@dataclass(frozen=True)
class Tracker:
    """What a checkpoint must match: the network config and the control period."""

    cfg: TrackerCfg
    control_dt_s: float
    """Control period, the world's ``episode.dt_s``: the memory's clock advances by it each
    step."""

    kind = TRACKER
    stateful = True
    """Carries a ``Memory`` per environment (a frame predictor does not)."""

    @classmethod
    def for_world(cls, cfg: TrackerCfg, world: WorldCfg) -> Tracker:
        return cls(cfg, float(world.episode.dt_s))

    def init_carry(self) -> Memory:
        """The memory at the start of every episode."""
        return blank_memory(self.cfg.memory)

    def ingest(self, memory: Memory, state: EnvState) -> Memory:
        return ingest(memory, state, self.control_dt_s)

    def parts(self, memory: Memory, state: EnvState) -> tuple[Parts, jax.Array, jax.Array]:
        """(named inputs, base position (2,), base velocity (2,)): the base is the
        constant-velocity extrapolation the network's mean is a residual on."""
        s, robot = state.sensor, state.robot
        ok = memory.valid.astype(jnp.float32)
        sight = memory.sight_m * ok[:, None]
        chord = chord_velocities(memory, self.control_dt_s)
        tau = jnp.where(memory.valid[0], s.time_since_seen_s, 0.0)
        base_p, base_v, turn = constant_turn(memory, tau, self.control_dt_s, self.cfg.max_turn_rps)
        base_p = base_p * ok[0]
        pose = s.robot_pose
        robot_xy = capture_frame_point(state, robot.xy_m) * ok[0]
        robot_yaw = wrap_angle(robot.yaw_rad - pose[2]) * ok[0]
        cap_yaw = memory.robot_pose[1:, 2]
        hold = sight[0] - robot_xy
        parts = {
            "sight_m": sight.reshape(-1),
            "sight_age_s": memory.age_s[1:] * ok[1:],
            "sight_valid": ok[1:],
            "chord_vel_mps": chord.reshape(-1),
            "capture_robot_xy_m": (memory.robot_pose[1:, :2] * ok[1:, None]).reshape(-1),
            "capture_robot_yaw_cos_sin": (
                jnp.stack([jnp.cos(cap_yaw), jnp.sin(cap_yaw)], -1) * ok[1:, None]
            ).reshape(-1),
            "time_since_capture_s": tau[None],
            "turn_rate_rps": turn[None],
            "robot_xy_m": robot_xy,
            "robot_yaw_cos_sin": jnp.stack([jnp.cos(robot_yaw), jnp.sin(robot_yaw)]),
            "robot_vel_body_mps": robot.vel_body_mps,
            "robot_yaw_rate_rps": robot.yaw_rate_rps[None],
            "hold_offset_m": hold,
            "hold_dist_m": jnp.sqrt(jnp.sum(hold * hold) + 1e-12)[None],
            "extrapolated_offset_m": base_p - robot_xy,
        }
        return parts, base_p, base_v

    def encode(self, memory: Memory, state: EnvState) -> tuple[jax.Array, jax.Array]:
        """(inputs (D,), base (4,): position then velocity) for one environment."""
        parts, base_p, base_v = self.parts(memory, state)
        return jnp.concatenate(list(parts.values())), jnp.concatenate([base_p, base_v])

    def layout(self) -> tuple[tuple[str, int], ...]:
        """(name, size) of each part of the input vector, in order."""
        names: list[str] = []

        def values(memory, state):
            parts = self.parts(memory, state)[0]
            names.extend(parts)
            return list(parts.values())

        shapes = jax.eval_shape(values, self.init_carry(), _dummy_state())
        return tuple((name, int(v.shape[0])) for name, v in zip(names, shapes, strict=True))

    @property
    def input_dim(self) -> int:
        return sum(size for _, size in self.layout())

    @property
    def net(self) -> TrackerNet:
        return TrackerNet(self.cfg.hidden)

    def init(self, key: jax.Array) -> dict:
        """Fresh parameters with identity input normalisation."""
        d = self.input_dim
        mlp = self.net.init(key, jnp.zeros((d,)))["params"]
        return {"mlp": mlp, "in_mean": jnp.zeros(d), "in_std": jnp.ones(d)}

    def apply_encoded(self, params: dict, x: jax.Array, base: jax.Array) -> Gaussian:
        """The Gaussian (capture frame) from inputs (..., D) and bases (..., 4)."""
        z = (x - params["in_mean"]) / params["in_std"]
        out = self.net.apply({"params": params["mlp"]}, z)
        log_std = jnp.minimum(out[..., 4:], self.cfg.max_log_std)
        std = jnp.exp(log_std)
        return Gaussian(
            pos_m=base[..., :2] + out[..., :2],
            vel_mps=base[..., 2:] + out[..., 2:4],
            pos_std_m=self.cfg.min_pos_std_m + std[..., :2],
            vel_std_mps=self.cfg.min_vel_std_mps + std[..., 2:],
        )

    def gaussian(self, params: dict, memory: Memory, state: EnvState) -> Gaussian:
        x, base = self.encode(memory, state)
        return self.apply_encoded(params, x, base)

    def estimate(self, params: dict, memory: Memory, state: EnvState) -> Estimate:
        """The current estimate in the base frame (zeros, ``defined`` 0, before a sighting)."""
        g = self.gaussian(params, memory, state)
        pose, robot = state.sensor.robot_pose, state.robot
        pos = world_to_body(pose[:2] + rotate(g.pos_m, pose[2]) - robot.xy_m, robot.yaw_rad)
        vel = world_to_body(rotate(g.vel_mps, pose[2]), robot.yaw_rad)
        rms = lambda std: jnp.sqrt(jnp.mean(std * std))  # noqa: E731
        ok = memory.valid[0]
        z = jnp.zeros(())
        return Estimate(
            pos_body_m=jnp.where(ok, pos, 0.0),
            vel_body_mps=jnp.where(ok, vel, 0.0),
            pos_std_m=jnp.where(ok, rms(g.pos_std_m), z),
            vel_std_mps=jnp.where(ok, rms(g.vel_std_mps), z),
            defined=ok.astype(jnp.float32),
        )


def _dummy_state() -> EnvState:

    return jax.eval_shape(reset, jax.random.key(0), WorldCfg())
