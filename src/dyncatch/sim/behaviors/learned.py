"""A target that runs a trained evader (``learned``), and the one an outer trainer steers
(``commanded``).

Both see what a fleeing animal could: ``evader_features`` of (target, robot), the same pure
function the evader's trainer (``dyncatch.rl.evader``) observes. Each step the evader picks an
angle; the desired heading is its action frame (``ACTION_FRAMES``: its own heading by
default, the flee direction, or the eq. 11-12 heading) plus it, and the body then turns toward it
under the turn-rate limit and runs at the episode's speed cap, exactly as the scripted
targets do (``sim.target.steer``). An evader trained with a speed action (``speed_action``,
recorded in its file) also picks its speed, up to the cap (``speed_share``); one without runs
at the cap. Its view is a whole turn by default, or a field of view centred on its heading
(``evader_features``' ``fov_rad``, recorded in the evader's file).

``learned`` evaluates the frozen actor in ``target.evader_checkpoint`` deterministically
(its mean turn; ``target.evader_sample`` draws around it as in training); ``commanded``
applies the turn the evader trainer writes into its state.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.behaviors.base import Behavior, Check, uniform_init
from dyncatch.sim.behaviors.evader_net import (
    FULL_VIEW_RAD,
    EvaderCheckpointError,
    EvaderNet,
    load_evader,
)
from dyncatch.sim.behaviors.reactive import flee_and_dodge
from dyncatch.sim.fields import static
from dyncatch.sim.geometry import rotate, world_to_body, wrap_angle
from dyncatch.sim.state import RobotState, TargetState

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg

FEATURE_NAMES = (
    "robot_rel_fwd_m",
    "robot_rel_left_m",
    "robot_rel_vel_fwd_mps",
    "robot_rel_vel_left_mps",
    "speed_mps",
    "wall_west_m",
    "wall_east_m",
    "wall_south_m",
    "wall_north_m",
    "heading_cos",
    "heading_sin",
)
"""The evader's observation, in order (``evader_features``)."""
EVADER_OBS_DIM = len(FEATURE_NAMES)
FOV_FEATURE_NAMES = (*FEATURE_NAMES, "robot_visible")
"""The observation of an evader with a field of view narrower than a whole turn: the same,
then whether the robot is inside it (1) or not (0)."""
SPEED_FEATURE = "speed_cap_mps"
"""The feature an evader with a speed action sees besides ``FEATURE_NAMES`` (after them,
before ``robot_visible``): the episode's speed cap, which its own speed no longer tells."""


def feature_names(fov_rad: float = FULL_VIEW_RAD, speed_action: bool = False) -> tuple[str, ...]:
    """The names of ``evader_features`` at field of view ``fov_rad``, with or without the
    speed action."""
    names = FEATURE_NAMES + ((SPEED_FEATURE,) if speed_action else ())
    return names if fov_rad >= FULL_VIEW_RAD else (*names, "robot_visible")


def check_fov(fov_rad: float, flag: str = "fov_rad") -> None:
    """ValueError naming ``flag`` unless 0 < ``fov_rad`` <= a whole turn."""
    if not 0.0 < fov_rad <= FULL_VIEW_RAD:
        raise ValueError(
            f"{flag} {fov_rad}: give the evader's field of view in (0, 2 pi] rad "
            f"(2 pi = {FULL_VIEW_RAD:.6f}, the default, sees everywhere)"
        )


TURN_LIMIT_RAD = math.pi
"""The default range of the evader's action, an angle in [-pi, pi] from its action frame
(``ACTION_FRAMES``) per control step (the body's turn-rate limit then clips what it can do
in one step, 0.2 rad at 10 rad/s and 50 Hz)."""


def off_heading(angle_rad: jax.Array, target: TargetState, robot: RobotState, cfg: WorldCfg):
    """The action is the heading change itself, () rad."""
    del target, robot, cfg
    return angle_rad


def off_flee_direction(
    angle_rad: jax.Array, target: TargetState, robot: RobotState, cfg: WorldCfg
) -> jax.Array:
    """The action is the desired heading relative to the direction straight away from the
    robot, atan2(x_obj - x_rob), as eq. 11-12 write the reactive target's (a 60 deg dodge
    is then one constant action); the heading change to it, () rad in [-pi, pi)."""
    del cfg
    d = target.xy_m - robot.xy_m
    return wrap_angle(jnp.arctan2(d[1], d[0]) + angle_rad - target.heading_rad)


def off_reactive(
    angle_rad: jax.Array, target: TargetState, robot: RobotState, cfg: WorldCfg
) -> jax.Array:
    """The action is a correction to the eq. 11-12 target's heading without gamma (flee,
    plus the alpha dodge within r_ev, with the world's ``target.*`` reactive fields): an
    action of 0 is that rule; the heading change to it, () rad in [-pi, pi)."""
    return wrap_angle(flee_and_dodge(target, robot, cfg) + angle_rad - target.heading_rad)


ActionFrame = Literal["heading", "flee", "reactive"]
ACTION_FRAMES = {"heading": off_heading, "flee": off_flee_direction, "reactive": off_reactive}
"""What the evader's action, an angle in [-turn_limit, turn_limit], is measured from: each
entry gives the heading change it asks for (the body then turns by at most the turn-rate
limit). ``heading``: the target's own heading; ``flee``: the flee direction; ``reactive``:
the eq. 11-12 heading without gamma (a residual on the scripted rule)."""


def speed_share_of(action: jax.Array) -> jax.Array:
    """The share of the speed cap, () in [0, 1], that a speed action in [-1, 1] asks for:
    ``clip(1 + action, 0, 1)`` (the reading ``speed_action``: an action of 0, an untrained
    policy's mean, runs at the cap as every scripted target and the turn-only evader do, so
    training starts from them and slows down only where slowing pays; -1 stands still; the
    half above 0 is the cap too)."""
    return jnp.clip(1.0 + jnp.clip(action, -1.0, 1.0), 0.0, 1.0)


def turn_of(
    angle_rad: jax.Array, target: TargetState, robot: RobotState, frame: str, cfg: WorldCfg
) -> jax.Array:
    """The heading change, () rad, that the action ``angle_rad`` in ``frame`` asks for."""
    return ACTION_FRAMES[frame](angle_rad, target, robot, cfg)


@struct.dataclass
class LearnedCfg:
    evader_checkpoint: str = static("")
    """learned: the trained evader, a file or run folder written by ``dyncatch evader train``
    (static: a compile-time constant, loaded once per file)."""
    evader_sample: bool = static(False)
    """learned: draw each turn from the trained Gaussian policy (mean + std x N(0, 1), with
    the behaviour's key) as in training, instead of its mean (False, the default)."""


@struct.dataclass
class EvaderState:
    """The state of ``learned`` and ``commanded`` targets."""

    turn_rad: jax.Array
    """commanded: the turn the trainer set for this step, (); learned: the last turn; both
    the desired heading less the heading, rad, whatever the action frame."""
    corner_xy_m: jax.Array
    """The arena square's lower corner (the scene frame's origin) in the local frame, (2,);
    it moves with the frame (``sim.frame.recentre``), so the walls are known at each step."""
    speed_share: jax.Array
    """The share of the speed cap it runs at, () in [0, 1]: commanded, set by the trainer;
    learned, its speed action's (``speed_share_of``), 1 without one."""


def evader_init(key: jax.Array, cfg: WorldCfg) -> tuple[jax.Array, jax.Array, EvaderState]:
    """Placed as the scripted targets are; reset runs in the scene frame, so the corner is 0."""
    xy, heading, _ = uniform_init(key, cfg)
    return xy, heading, EvaderState(jnp.zeros(()), jnp.zeros(2), jnp.ones(()))


def evader_features(
    target: TargetState,
    robot: RobotState,
    cfg: WorldCfg,
    fov_rad: float = FULL_VIEW_RAD,
    speed_action: bool = False,
) -> jax.Array:
    """What the evader sees, named in ``feature_names(fov_rad, speed_action)``:

    - the robot's position relative to the target, m, in the target's heading frame
      (forward, left);
    - the robot's velocity relative to the target's, m/s, in the same frame;
    - the target's own speed, m/s;
    - the distances from the target's centre to the four sides of the arena square (x low,
      x high, y low, y high), m: the walls, so it does not run into a corner blindly;
    - cos and sin of its heading in the square's frame (which way the walls lie ahead);
    - with ``speed_action``, the episode's speed cap, m/s.

    Obstacles are not observed (in the rooms and the woods the world's free-direction rule
    still turns every non-reflecting target away from them).

    With ``fov_rad`` below a whole turn (a reading of "optionally only within its own field
    of view": a cone of that full angle centred on the target's heading, any range, no
    memory), the robot outside the cone reads as 0 in the four relative features, and a last
    feature says whether it is inside (1) or not (0)."""
    state: EvaderState = target.behavior_state
    rel = world_to_body(robot.xy_m - target.xy_m, target.heading_rad)
    robot_vel = rotate(robot.vel_body_mps, robot.yaw_rad)
    rel_vel = world_to_body(robot_vel - target.vel_mps, target.heading_rad)
    p = target.xy_m - state.corner_xy_m
    size = cfg.arena.size_m
    walls = jnp.stack([p[0], size - p[0], p[1], size - p[1]])
    heading = jnp.stack([jnp.cos(target.heading_rad), jnp.sin(target.heading_rad)])
    own = [target.speed_mps[None], walls, heading]
    if speed_action:
        own.append(target.speed_cap_mps[None])
    if fov_rad >= FULL_VIEW_RAD:
        return jnp.concatenate([rel, rel_vel, *own])
    visible = jnp.abs(jnp.arctan2(rel[1], rel[0])) <= 0.5 * fov_rad
    seen = lambda x: jnp.where(visible, x, 0.0)  # noqa: E731
    return jnp.concatenate([seen(rel), seen(rel_vel), *own, visible.astype(rel.dtype)[None]])


def evader_net(cfg: WorldCfg) -> EvaderNet:
    """The network of ``cfg.target.evader_checkpoint`` (cached per file)."""
    return load_evader(cfg.target.evader_checkpoint, feature_names)


def learned_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, EvaderState]:
    """The frozen actor's mean turn (deterministic; ``key`` unused), or a turn drawn around
    it with ``key`` where ``target.evader_sample``, added to its action frame (the file's
    ``action_frame``: the current heading or the flee direction); with the file's
    ``speed_action``, the speed share its second action asks for (``speed_share_of``)."""
    net = evader_net(cfg)
    features = evader_features(target, robot, cfg, net.fov_rad, net.speed_action)
    action = net.action_mean(features)
    if cfg.target.evader_sample:
        action = action + net.std_vector() * jax.random.normal(key, action.shape)
    turn = turn_of(net.turn(action[0]), target, robot, net.action_frame, cfg)
    state = target.behavior_state.replace(turn_rad=turn)
    if net.speed_action:
        state = state.replace(speed_share=speed_share_of(action[1]))
    return target.heading_rad + turn, state


def evader_speed_share(state: EvaderState, cfg: WorldCfg) -> jax.Array:
    """The share of the cap in the state (1 unless a speed action set it)."""
    del cfg
    return state.speed_share


def commanded_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, EvaderState]:
    """Current heading plus the turn in the state (written by ``rl.evader.EvaderEnv``)."""
    del robot, cfg, key
    return target.heading_rad + target.behavior_state.turn_rad, target.behavior_state


def learned_validate(cfg: WorldCfg) -> list[Check]:
    try:
        evader_net(cfg)
    except EvaderCheckpointError as err:
        return [(False, "target.evader_checkpoint", str(err))]
    net = evader_net(cfg)
    no_std = cfg.target.evader_sample and (
        net.action_std is None or (net.speed_action and net.speed_action_std is None)
    )
    why = "its file records no action std (written before it was recorded); retrain it"
    frame = f"its action frame {net.action_frame!r} is none of {', '.join(ACTION_FRAMES)}"
    return [
        (not no_std, "target.evader_sample", why),
        (net.action_frame in ACTION_FRAMES, "target.evader_checkpoint", frame),
    ]


LEARNED = Behavior(
    desired_heading=learned_heading,
    cfg_cls=LearnedCfg,
    init_state=evader_init,
    validate=learned_validate,
    speed_share=evader_speed_share,
    scripted=False,
    doc="a trained PPO evader (target.evader_checkpoint), at its cap or its chosen speed",
)

COMMANDED = Behavior(
    desired_heading=commanded_heading,
    init_state=evader_init,
    speed_share=evader_speed_share,
    scripted=False,
    doc="turns as an outer controller sets it (the evader trainer); alone, runs straight",
)
