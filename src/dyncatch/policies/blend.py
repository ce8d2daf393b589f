"""Collision avoidance at deployment, the paper's eq. 10: A = w_p pi_catch + w_c pi_collid.

The paper blends its catch policy with a pre-trained visual navigation model [40] for
collision avoidance, by weights ``w_p, w_c = g(d_rob,obst)`` of the robot's distance to its
nearest obstacle, in rooms and woods only, never in RL training. Ours:

- ``pi_collid`` is a classical controller, **free-corridor steering** (a vector-field-
  histogram-style steer-away rule) on a range scan of its own: of the direction pi_catch
  commands and the scan's ray directions, it takes the one nearest the commanded one along
  which the robot's footprint, grown by a margin, can travel ``lookahead_m`` without
  touching any scan point (if none can, the one it can travel farthest; ties: left first),
  at pi_catch's speed and yaw rate. Where the catch's way is clear, pi_collid is pi_catch,
  so the blend changes nothing; where it is blocked, it is turned aside. (The paper's
  pi_collid(s_t) is a navigation model that has a goal of its own; ours takes the catch
  command as its goal.)
- ``g`` is a linear ramp: ``w_c = w_c_max * clip((d_on - d) / (d_on - d_full), 0, 1)``,
  ``w_p = 1 - w_c``; d is ``sim.scan.robot_clearance_m`` (footprint to the nearest wall or
  obstacle, from the simulator, as the paper's d_rob,obst).
- ``Blended`` wraps any policy (learned or scripted) in the recurrent protocol
  (``policies.api``); docs/scenes.md gives every constant.
"""

from __future__ import annotations

from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.policies.api import as_recurrent
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.fields import static
from dyncatch.sim.geometry import unit, wrap_angle
from dyncatch.sim.scan import range_scan, robot_clearance_m
from dyncatch.sim.scenes import CLUTTERED_SCAN_RAYS, get_scene
from dyncatch.sim.state import EnvState, Obs

_TIE_RAD = 1e-5
"""Added to a right turn's angle: far below a ray's spacing, far above float rounding."""


@struct.dataclass
class CollidCfg:
    """pi_collid, free-corridor steering on a range scan of its own."""

    scan_rays: int = static(CLUTTERED_SCAN_RAYS)
    """Rays of pi_collid's own scan (and its candidate directions), the rooms' and woods'
    s_env, read whatever scan the catch policy was trained with."""
    margin_m: float = 0.15
    """Ours: the corridor is the footprint circle (0.36 m) grown by this, so a direction
    that grazes an obstacle is not free (gait noise 0.05 m/s per step, three sigma in 1 s);
    0.3 m gave fewer contacts and fewer catches (docs/scenes.md)."""
    lookahead_m: float = 1.5
    """Ours: a direction is free when the corridor is clear this far along it (0.75 s at
    the 2 m/s top speed, beyond the blend's 1 m onset, so pi_collid turns before g hands it
    the robot)."""


@struct.dataclass
class BlendCfg:
    """g of eq. 10: the weights of pi_catch and pi_collid from d_rob,obst."""

    on_m: float = 1.0
    """Ours: below this clearance pi_collid starts to count (0.5 s at the 2 m/s top speed,
    five tracking lags)."""
    full_m: float = 0.1
    """Ours: at or below this clearance w_c reaches ``w_c_max`` (within one control step of
    contact at top speed: 0.04 m, plus gait noise)."""
    w_c_max: float = 0.9
    """Ours: w_c at contact; pi_catch keeps 0.1 so the robot never forgets its target."""
    collid: CollidCfg = CollidCfg()


def blend_weights(d_m: jax.Array, cfg: BlendCfg) -> tuple[jax.Array, jax.Array]:
    """(w_p, w_c) of eq. 10 at clearance ``d_m`` (any shape; +inf: none near)."""
    ramp = jnp.clip((cfg.on_m - d_m) / (cfg.on_m - cfg.full_m), 0.0, 1.0)
    w_c = cfg.w_c_max * ramp
    return 1.0 - w_c, w_c


def corridor_free_m(scan_m: jax.Array, cap_m, radius_m, dirs_rad: jax.Array) -> jax.Array:
    """How far a disc of ``radius_m`` at the scan's origin can move along each body-frame
    direction ``dirs_rad`` (D,) before it touches a scan point, (D,), +inf where nothing is
    in the way.

    ``scan_m`` (N,) are ranges along body angles 2 pi i / N (ray 0 ahead); a ray at
    ``cap_m`` hit nothing and gives no point. A point at along-track a > 0 and cross-track
    b < radius is met after a - sqrt(radius^2 - b^2); points behind never block.
    """
    n = scan_m.shape[-1]
    pts = scan_m[:, None] * unit(2.0 * jnp.pi * jnp.arange(n) / n)  # (N, 2) hit points
    hit = scan_m < cap_m
    a = unit(dirs_rad) @ pts.T  # (D, N)
    b2 = jnp.sum(pts * pts, axis=-1)[None] - a * a
    blocks = hit[None] & (a > 0.0) & (b2 < radius_m**2)
    t = a - jnp.sqrt(jnp.maximum(radius_m**2 - b2, 0.0))
    return jnp.min(jnp.where(blocks, jnp.maximum(t, 0.0), jnp.inf), axis=-1)


def collid_action(
    scan_m: jax.Array,
    catch_action: jax.Array,
    world: WorldCfg,
    cfg: CollidCfg,
) -> jax.Array:
    """pi_collid: base command (3,) from a scan (N,) and pi_catch's command (3,), the way
    the catch wants to go.

    The candidate directions are the catch command's own and the N ray directions; the
    speed and the yaw rate are the catch command's (the lateral part clipped to the base's
    limit)."""
    n = scan_m.shape[-1]
    v = catch_action[:2]
    want = jnp.arctan2(v[1], v[0])
    cand = jnp.concatenate([want[None], 2.0 * jnp.pi * jnp.arange(n) / n])
    free = corridor_free_m(
        scan_m, world.scene.scan_range_m, world.base.radius_m + cfg.margin_m, cand
    )
    turn = wrap_angle(cand - want)
    # Equally near directions on both sides: left first (rounding must not decide).
    off = jnp.abs(turn) + _TIE_RAD * (turn < 0.0)
    # Open directions by their angle to the wanted one; closed ones after all of them, the
    # farthest-reaching first.
    score = jnp.where(free >= cfg.lookahead_m, off, 2.0 * jnp.pi + cfg.lookahead_m - free)
    heading = cand[jnp.argmin(score)]
    b = world.base
    speed = jnp.linalg.norm(v)
    vx = jnp.clip(speed * jnp.cos(heading), -b.max_backward_mps, b.max_forward_mps)
    vy = jnp.clip(speed * jnp.sin(heading), -b.max_lateral_mps, b.max_lateral_mps)
    return jnp.stack([vx, vy, catch_action[2]])


def collid_scan_m(state: EnvState, world: WorldCfg, cfg: CollidCfg) -> jax.Array:
    """pi_collid's own range scan of the state, (cfg.scan_rays,)."""
    own = world.replace(scene=world.scene.replace(scan_rays=cfg.scan_rays))
    robot = state.robot
    return range_scan(
        robot.xy_m + state.origin_xy_m, robot.yaw_rad, own, state.obstacles, robot.xy_m
    )


@struct.dataclass
class Blended:
    """``catch`` blended with pi_collid by eq. 10, in the recurrent protocol.

    A pytree when ``catch`` is one (a trained network: ``is_pytree_policy``), so evaluation
    passes it to jit as an argument; otherwise hashable, a static argument like the
    scripted baselines. Build it with ``blended``.
    """

    catch: Any
    world: WorldCfg
    """The world it is deployed in (its scene, walls and base limits)."""
    cfg: BlendCfg = BlendCfg()
    is_pytree_policy: bool = struct.field(pytree_node=False, default=False)
    on: Any = None
    """None: always blended. Else the blend as a flag, () bool: a leaf of a pytree policy,
    so blended and plain cells share one compiled program (``jax.lax.cond`` runs one
    branch: off, the action is ``catch``'s, bit for bit, and pays no scan); a Python bool
    of a hashable one (a static argument: each value compiles)."""

    def weights(self, state: EnvState) -> tuple[jax.Array, jax.Array]:
        """(w_p, w_c) in ``state``."""
        return blend_weights(robot_clearance_m(state, self.world), self.cfg)

    def init_carry(self, state: EnvState, obs: Obs):
        return as_recurrent(self.catch).init_carry(state, obs)

    def step(self, carry, state: EnvState, obs: Obs, key: jax.Array):
        carry, a_catch = as_recurrent(self.catch).step(carry, state, obs, key)
        if self.on is None or self.on is True:
            return carry, self._blend(state, a_catch)
        if self.on is False:
            return carry, a_catch
        return carry, jax.lax.cond(self.on, self._blend, lambda _, a: a, state, a_catch)

    def _blend(self, state: EnvState, a_catch: jax.Array) -> jax.Array:
        scan = collid_scan_m(state, self.world, self.cfg.collid)
        a_collid = collid_action(scan, a_catch, self.world, self.cfg.collid)
        w_p, w_c = self.weights(state)
        return w_p * a_catch + w_c * a_collid


def blended(catch, world: WorldCfg, cfg: BlendCfg | None = None, on: bool | None = None) -> Blended:
    """``catch`` (any policy of ``policies.api``) with eq. 10's collision avoidance; with
    ``on``, the blend is a flag (``Blended.on``: traced for a pytree ``catch``)."""
    pytree = getattr(catch, "is_pytree_policy", False)
    if not pytree:
        hash(catch)  # a static jit argument must be hashable: fail here, not in jit
    if on is not None:
        on = jnp.asarray(on, bool) if pytree else bool(on)
    return Blended(catch, world, cfg or BlendCfg(), is_pytree_policy=pytree, on=on)


@struct.dataclass
class PlaneScan:
    """``catch`` shown its training plane's range scan (every ray at ``cap_m``, what the
    open plane reads) wherever it is deployed: a policy trained on the plane never saw a
    wall in its scan, and its observation normaliser (zero variance there) turns one into
    an input at the clip (docs/scenes.md measures it: 0.075 success in ``room_8`` against
    0.830 with this view). Obstacles then reach the robot through eq. 10's pi_collid only,
    as in the paper. A pytree when ``catch`` is one, else hashable; see ``plane_scan``."""

    catch: Any
    cap_m: float
    is_pytree_policy: bool = struct.field(pytree_node=False, default=False)

    def init_carry(self, state: EnvState, obs: Obs):
        return as_recurrent(self.catch).init_carry(state, self._view(obs))

    def step(self, carry, state: EnvState, obs: Obs, key: jax.Array):
        return as_recurrent(self.catch).step(carry, state, self._view(obs), key)

    def _view(self, obs: Obs) -> Obs:
        return obs.replace(scan_m=jnp.full_like(obs.scan_m, self.cap_m))


def plane_scan(catch, world: WorldCfg) -> PlaneScan:
    """``catch`` reading the open plane's scan (capped at ``world.scene.scan_range_m``)."""
    pytree = getattr(catch, "is_pytree_policy", False)
    return PlaneScan(catch, world.scene.scan_range_m, is_pytree_policy=pytree)


def reads_nothing(world: WorldCfg) -> bool:
    """Whether the range scan of ``world``'s scene always reads its cap (no walls, no
    obstacles: the open plane)."""

    scene = get_scene(world.scene.name)
    return not scene.walls and scene.layout is None


def deploy(
    policy,
    trained_world: WorldCfg | None,
    world: WorldCfg,
    blend: bool = False,
    scan=None,
    blend_as_flag: bool = False,
):
    """A policy as deployed in ``world``: a learned one (``trained_world`` given) trained
    where its scan read nothing, deployed where it reads something, is shown the plane's
    scan (``plane_scan``) unless ``scan`` says ``"own"`` (``"plane"`` forces that view,
    ``None`` decides by the scenes); then eq. 10's blend if ``blend``. With
    ``blend_as_flag`` it is a ``Blended`` either way, ``blend`` its flag (``Blended.on``),
    so a learned policy's blended and plain cells share one compiled evaluation, with the
    same numbers. Fig. 9 and ``dyncatch eval`` deploy this way."""
    if scan not in (None, "own", "plane"):
        raise ValueError(f"scan must be None, 'own' or 'plane', got {scan!r}")
    auto = trained_world is not None and reads_nothing(trained_world) and not reads_nothing(world)
    if scan == "plane" or (scan is None and auto):
        policy = plane_scan(policy, world)
    if blend_as_flag:
        return blended(policy, world, on=blend)
    return blended(policy, world) if blend else policy
