"""The catch world: pure ``reset`` and ``step`` of one environment.

``reset(key, cfg) -> state`` and ``step(state, action, cfg) -> (state, obs, reward, done,
info)`` are pure, ``jit``-able and ``vmap``-able; batching and auto-reset live in
``dyncatch.sim.vec``. ``action`` is the base command (vx, vy, yaw rate) in m/s and rad/s,
clipped to the base's limits.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp

from dyncatch.sim import arm
from dyncatch.sim.arm import arm_substep, gripper_in_base, stow_substep
from dyncatch.sim.base import add_gait_noise, base_substep, clip_command
from dyncatch.sim.behaviors import get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.draws import step_draws
from dyncatch.sim.frame import recentre
from dyncatch.sim.gate import where_active
from dyncatch.sim.geometry import bearing, rotate, world_to_body
from dyncatch.sim.obstacles import (
    Obstacles,
    cell_block,
    free_heading,
    line_of_sight,
    nearest,
    no_obstacles,
    own_cell,
    push_out,
)
from dyncatch.sim.reward import reward_terms, total_reward
from dyncatch.sim.scan import range_scan
from dyncatch.sim.scenes import get_scene
from dyncatch.sim.sensing import initial_sensor, sensor_tick, takes_frame
from dyncatch.sim.state import EnvState, Obs, RobotState, SensorState, TargetState
from dyncatch.sim.target import move, steer

_ROBOT_PLACEMENT_TRIES = 8
_LAYOUT_STREAM = 0x0B5
"""The obstacle layout's key is folded from the reset key, so the scenes without obstacles
draw exactly what they drew before obstacles existed."""
LINE_OF_SIGHT_COMPACT_FRACTIONS = (1 / 16, 1 / 8)
"""Under ``vmap`` the camera's line of sight through the obstacles is computed only for the
environments that take a frame at this step (one step in 25 at 50 Hz and 2 Hz), on a compact
sub-batch of 1/16 or 1/8 of the batch (``sim.gate``; below ``MIN_COMPACT_BATCH``
environments, the whole batch at a frame). Episodes that started together take
their frames together (the whole batch that step, none the next 24); once catches have
spread their phases, about 1/25 of the batch does at each step, which 1/16 holds. Results
do not depend on it; measured in docs/performance.md ("The woods")."""


def gripper_world(robot: RobotState, gripper_base: jax.Array) -> jax.Array:
    """Gripper point in the world, (3,), from its base-frame position."""
    xy = robot.xy_m + rotate(gripper_base[:2], robot.yaw_rad)
    return jnp.concatenate([xy, gripper_base[2:]])


def target_xyz(target: TargetState, cfg: WorldCfg) -> jax.Array:
    return jnp.concatenate([target.xy_m, jnp.full((1,), cfg.target.height_m)])


def _catch_point(gripper_xyz_m, cfg: WorldCfg):
    return gripper_xyz_m - jnp.array([0.0, 0.0, cfg.arm.catch_offset_m])


def _catch_error_at(gripper_base, robot_xy, robot_yaw, target_xy, cfg: WorldCfg):
    """``catch_error_m`` of the gripper at ``gripper_base`` (3,) on a base at ``robot_xy``,
    ``robot_yaw``, written per component: as a norm over a (3,) axis XLA:CPU compiles it to
    a reduction that recomputes the forward kinematics feeding it for each component."""
    c, s = jnp.cos(robot_yaw), jnp.sin(robot_yaw)
    dx = target_xy[0] - (robot_xy[0] + c * gripper_base[0] - s * gripper_base[1])
    dy = target_xy[1] - (robot_xy[1] + s * gripper_base[0] + c * gripper_base[1])
    dz = cfg.target.height_m - (gripper_base[2] - cfg.arm.catch_offset_m)
    return jnp.sqrt(dx * dx + dy * dy + dz * dz)


def catch_error_m(gripper_xyz_m: jax.Array, target: TargetState, cfg: WorldCfg) -> jax.Array:
    """Distance from the target centre to the catch point 0.10 m below the gripper."""
    return jnp.linalg.norm(target_xyz(target, cfg) - _catch_point(gripper_xyz_m, cfg))


def _place_robot(key: jax.Array, target_xy: jax.Array, cfg: WorldCfg) -> jax.Array:
    """A point at a random distance from the target; with walls, inside them (a few tries,
    then clip)."""
    k_a, k_d = jax.random.split(key)
    angles = jax.random.uniform(k_a, (_ROBOT_PLACEMENT_TRIES,), minval=-jnp.pi, maxval=jnp.pi)
    dists = jax.random.uniform(
        k_d,
        (_ROBOT_PLACEMENT_TRIES,),
        minval=cfg.episode.init_distance_min_m,
        maxval=cfg.episode.init_distance_max_m,
    )
    cands = target_xy + dists[:, None] * jnp.stack([jnp.cos(angles), jnp.sin(angles)], -1)
    if not get_scene(cfg.scene.name).walls:
        return cands[0]
    lo, hi = cfg.base.radius_m, cfg.arena.size_m - cfg.base.radius_m
    ok = jnp.all((cands >= lo) & (cands <= hi), axis=-1)
    return jnp.clip(cands[jnp.argmax(ok)], lo, hi)


def obstacles_in_play(state: EnvState, cfg: WorldCfg) -> Obstacles | None:
    """The episode's obstacles, or None (statically) in a scene that has none."""
    return None if get_scene(cfg.scene.name).layout is None else state.obstacles


def _line_of_sight(obstacles, robot: RobotState, target: TargetState):
    return None if obstacles is None else line_of_sight(obstacles, robot.xy_m, target.xy_m)


def _line_of_sight_at_frames(obstacles, robot: RobotState, target: TargetState, step, cfg):
    """The line of sight where the camera takes a frame at control step ``step`` (the only
    steps ``sensing.sensor_tick`` reads it), False elsewhere."""
    if obstacles is None:
        return None
    gated = where_active(line_of_sight, LINE_OF_SIGHT_COMPACT_FRACTIONS)
    return gated(takes_frame(step, cfg), obstacles, robot.xy_m, target.xy_m)


def reset(key: jax.Array, cfg: WorldCfg) -> EnvState:
    """A new episode: target placed by its behaviour, robot 2-6 m away facing anywhere, both
    moved out of the scene's obstacles (drawn afresh); the state is returned in the frame
    centred on the robot (``sim.frame``)."""
    behavior = get_behavior(cfg.target.behavior)
    scene = get_scene(cfg.scene.name)
    obstacles = None
    if scene.layout is not None:
        obstacles = scene.layout(jax.random.fold_in(key, _LAYOUT_STREAM), cfg)
    k_target, k_speed, k_place, k_yaw, k_sense, k_next = jax.random.split(key, 6)
    t_xy, t_heading, behavior_state = behavior.init_state(k_target, cfg)
    speed = jax.random.uniform(
        k_speed, (), minval=cfg.target.speed_min_mps, maxval=cfg.target.speed_max_mps
    )
    if obstacles is not None:
        t_xy, _ = push_out(obstacles, t_xy, cfg.target.radius_m)
    target = TargetState(
        xy_m=t_xy,
        heading_rad=t_heading,
        speed_mps=speed,
        speed_cap_mps=speed,
        behavior_state=behavior_state,
    )
    q = jnp.asarray(cfg.arm.stow_rad, jnp.float32)
    r_xy = _place_robot(k_place, t_xy, cfg)
    if obstacles is not None:
        r_xy, _ = push_out(obstacles, r_xy, cfg.base.radius_m)
    robot = RobotState(
        xy_m=r_xy,
        yaw_rad=jax.random.uniform(k_yaw, (), minval=-jnp.pi, maxval=jnp.pi),
        vel_body_mps=jnp.zeros(2),
        yaw_rate_rps=jnp.zeros(()),
        arm_q_rad=q,
        gripper_xyz_m=jnp.zeros(3),
    )
    robot = robot.replace(gripper_xyz_m=gripper_world(robot, gripper_in_base(q, cfg.arm, cfg.base)))
    step0 = jnp.zeros((), jnp.int32)
    # The reset frame counts as a tick; start the clock one step early so its age reads 0.
    sensor = initial_sensor(robot).replace(
        time_since_seen_s=jnp.full((), -cfg.episode.dt_s, jnp.float32)
    )
    sensor = sensor_tick(
        sensor,
        robot,
        target,
        step0,
        jax.random.normal(k_sense, (2,)),
        cfg,
        _line_of_sight(obstacles, robot, target),
    )
    state = EnvState(
        robot=robot,
        target=target,
        sensor=sensor,
        step=step0,
        key=k_next,
        success=jnp.zeros((), bool),
        distance_m=jnp.linalg.norm(t_xy - robot.xy_m),
        origin_xy_m=jnp.zeros(2),
        anchor_xy_m=jnp.zeros(2),
        obstacles=no_obstacles() if obstacles is None else obstacles,
    )
    return recentre(state)


def turn_target(
    target: TargetState, robot: RobotState, obstacles, key: jax.Array, cfg: WorldCfg
) -> TargetState:
    """The target at a step's start (shared with other physics backends,
    ``dyncatch.fullbody.catch``): its behaviour picks a heading from ``robot`` (the robot as
    the target sees it) with ``key``, turned away from ``obstacles`` (None: none) unless it
    reflects off them, and the body steers toward it."""
    behavior = get_behavior(cfg.target.behavior)
    heading, behavior_state = behavior.desired_heading(target, robot, cfg, key)
    if obstacles is not None and not behavior.reflects_off_walls:
        heading = free_heading(
            _flee_obstacles(obstacles, target.xy_m),
            target.xy_m,
            heading,
            cfg.target.radius_m,
            cfg.avoid.lookahead_m,
            cfg.avoid.directions,
        )
    share = None if behavior.speed_share is None else behavior.speed_share(behavior_state, cfg)
    return steer(
        target.replace(behavior_state=behavior_state), heading, cfg.target, cfg.episode.dt_s, share
    )


def _bodies_substep(
    robot, target, command, origin, cfg: WorldCfg, dt_s, reflect, robot_obstacles, target_obstacles
):
    """The base and the target over one physics sub-step, each stopped by its own obstacles
    (``_reachable_obstacles``); neither depends on the arm."""
    scene = get_scene(cfg.scene.name)
    walls, terrain = scene.walls, None if scene.terrain is None else scene.terrain(cfg)
    robot = base_substep(
        robot, command, cfg.base, cfg.arena, origin, dt_s, walls, robot_obstacles, terrain
    )
    target = move(target, cfg.target, cfg.arena, origin, dt_s, reflect, walls, target_obstacles)
    return robot, target


def _reachable_obstacles(obstacles, robot_xy, target_xy):
    """The obstacles the robot's and the target's sub-steps test: the one nearest each at the
    step's start (in a gridded layout, the woods, the one of the body's own cell, which is
    that one whenever any is in reach: ``obstacles.own_cell``). The layouts' gaps exceed
    twice a body's reach in a step (a config check, ``layouts.step_reach_m``), so no other
    obstacle can be touched and its push-out would be exactly zero; the sub-steps, run for
    both bodies four times a step, test one obstacle instead of all (the woods hold 25)."""
    if obstacles is None or obstacles.radius_m.shape[-1] == 0:  # room_0 has none
        return obstacles, obstacles
    pick = own_cell if obstacles.grid_cells else nearest
    return pick(obstacles, robot_xy), pick(obstacles, target_xy)


def _flee_obstacles(obstacles: Obstacles, xy_m):
    """The obstacles the target's free-direction rule tests: in a gridded layout those of
    the 2 x 2 cells nearest it, the only ones within its lookahead (a config check,
    ``layouts.woods_checks``); elsewhere all."""
    return cell_block(obstacles, xy_m) if obstacles.grid_cells else obstacles


def _arm_goal(robot_xy, robot_yaw, target_xy, cfg: WorldCfg):
    """The arm's goal in the base frame (3,), and whether the target is near enough to reach."""
    rel = target_xy - robot_xy
    goal_base = jnp.concatenate(
        [
            world_to_body(rel, robot_yaw),
            jnp.full((1,), cfg.target.height_m + cfg.arm.catch_offset_m),
        ]
    )
    return goal_base, jnp.sum(rel * rel) <= cfg.arm.activation_distance_m**2


def _arm_along(q, robot_xy, robot_yaw, target_xy, cfg: WorldCfg, dt_s, aim=None, *, reach: bool):
    """The arm over one control step's sub-steps, along the bodies' poses at the start of each
    (``robot_xy`` (n, 2), ``robot_yaw`` (n,), ``target_xy`` (n, 2)): the catch is checked
    before each arm update, then the arm reaches (``reach``, where its aim is near) or folds.
    ``aim`` is None (the arm aims at the target) or ``(aim_xy (n, 2), aim_ok ())`` for
    ``arm.aim = sighting`` (``_aim``). Returns the joints and the smallest catch-point error
    over the sub-steps."""

    def substep(carry, pose):
        return _arm_substep(carry, pose, cfg, dt_s, reach, None if aim is None else aim[1]), None

    init = (q, jnp.full((), jnp.inf))
    poses = (robot_xy, robot_yaw, target_xy) + (() if aim is None else (aim[0],))
    return jax.lax.scan(substep, init, poses)[0]


def _arm_substep(carry, pose, cfg: WorldCfg, dt_s, reach: bool, aim_ok=None):
    """One sub-step of ``_arm_along``: ``carry`` is (joints, smallest error so far), ``pose``
    (robot xy, yaw, target xy[, aim xy]); ``aim_ok`` () bool where the pose has an aim."""
    q, best_err = carry
    xy, yaw, txy = pose[:3]
    gripper_base = gripper_in_base(q, cfg.arm, cfg.base)
    best_err = jnp.minimum(best_err, _catch_error_at(gripper_base, xy, yaw, txy, cfg))
    if reach:
        goal_base, active = _arm_goal(xy, yaw, pose[3] if len(pose) > 3 else txy, cfg)
        if aim_ok is not None:
            active = active & aim_ok
        q = arm_substep(q, gripper_base, goal_base, active, cfg.arm, dt_s)
    else:
        q = stow_substep(q, cfg.arm, dt_s)
    return q, best_err


def _aim(sensor: SensorState, target_xy: jax.Array, cfg: WorldCfg):
    """What the arm reaches for over a step's sub-steps (``arm.aim``): None for the target
    itself, else ``(aim_xy (n, 2), aim_ok ())``, the last delivered sighting (held over the
    step) and whether there is one."""
    if cfg.arm.aim == "true":
        return None
    return jnp.broadcast_to(sensor.obs_xy_m, target_xy.shape), sensor.ever_seen


def _arm_over_step(q, robot_xy, robot_yaw, target_xy, cfg: WorldCfg, dt_s, folded=None, aim=None):
    """``_arm_along`` with the IK paid for only where the arm is active at some sub-step:
    under ``vmap`` those environments are gathered once per control step (``sim.gate``); the
    others fold toward the stow pose, which is what the IK's branch does for them too.
    ``folded`` is ``_arm_along(..., reach=False)`` where the caller has it already; ``aim``
    as ``_arm_along``'s."""
    aim_xy = target_xy if aim is None else aim[0]
    near = jnp.any(jax.vmap(lambda *p: _arm_goal(*p, cfg)[1])(robot_xy, robot_yaw, aim_xy))
    if aim is not None:
        near = near & aim[1]
    if folded is None:
        folded = _arm_along(q, robot_xy, robot_yaw, target_xy, cfg, dt_s, reach=False)
    reaching = where_active(partial(_arm_along, reach=True), arm.IK_COMPACT_FRACTIONS)(
        near, q, robot_xy, robot_yaw, target_xy, cfg, dt_s, aim
    )
    return jax.tree.map(lambda a, b: jnp.where(near, a, b), reaching, folded)


def observe(state: EnvState, cfg: WorldCfg) -> Obs:
    """The egocentric observation (``Obs``): nothing in it depends on where the world is."""
    robot, sensor = state.robot, state.sensor
    return Obs(
        robot_vel_body_mps=robot.vel_body_mps,
        robot_yaw_rate_rps=robot.yaw_rate_rps,
        target_obs_body_m=world_to_body(sensor.obs_xy_m - robot.xy_m, robot.yaw_rad),
        time_since_seen_s=sensor.time_since_seen_s,
        visible=sensor.visible.astype(jnp.float32),
        scan_m=range_scan(
            robot.xy_m + state.origin_xy_m,
            robot.yaw_rad,
            cfg,
            obstacles_in_play(state, cfg),
            robot.xy_m,
        ),
        staleness=cfg.observation.staleness_inputs,
    )


def step(state: EnvState, action: jax.Array, cfg: WorldCfg):
    """Advance one control step (1 / control_hz) under the base command ``action`` (3,).

    Returns ``(state, obs, reward, done, info)``; ``info`` holds the reward terms as
    ``reward/<name>``, ``success``, ``terminated``, ``truncated``, ``distance_m`` and
    ``catch_error_m`` (the smallest catch-point error over the step's sub-steps).
    """
    behavior = get_behavior(cfg.target.behavior)
    scene = get_scene(cfg.scene.name)
    obstacles = obstacles_in_play(state, cfg)
    draws = step_draws(state.key)
    dt_s = cfg.episode.dt_s
    n_sub = cfg.episode.physics_substeps
    command = clip_command(action, cfg.base)

    terrain = None if scene.terrain is None else scene.terrain(cfg)
    robot = add_gait_noise(state.robot, draws.gait_noise, cfg.base, terrain)
    target = turn_target(state.target, robot, obstacles, draws.behavior_key, cfg)

    # The bodies move first (neither depends on the arm), then the arm follows their poses:
    # the catch is checked at every sub-step (200 Hz), before each arm update and at the end.
    # Both as scans over the sub-steps, with one gate for the arm's IK per control step:
    # measured 5.2 -> 3.5 ms per step of 4096 environments against the unrolled sub-steps
    # with a gate in each, and a smaller program to compile (docs/performance.md).
    robot_obstacles, target_obstacles = _reachable_obstacles(
        obstacles, state.robot.xy_m, state.target.xy_m
    )

    def bodies(carry, _):
        robot, target, folding = carry
        pose = (robot.xy_m, robot.yaw_rad, target.xy_m)
        # The folding arm rides along in the same loop (it reads only the poses).
        folding = _arm_substep(folding, pose, cfg, dt_s / n_sub, reach=False)
        robot, target = _bodies_substep(
            robot,
            target,
            command,
            state.origin_xy_m,
            cfg,
            dt_s / n_sub,
            behavior.reflects_off_walls,
            robot_obstacles,
            target_obstacles,
        )
        return (robot, target, folding), pose

    init = (robot, target, (robot.arm_q_rad, jnp.full((), jnp.inf)))
    (robot, target, folded), (robot_xy, robot_yaw, target_xy) = jax.lax.scan(
        bodies, init, length=n_sub
    )
    q, best_err = _arm_over_step(
        robot.arm_q_rad,
        robot_xy,
        robot_yaw,
        target_xy,
        cfg,
        dt_s / n_sub,
        folded,
        _aim(state.sensor, target_xy, cfg),
    )
    robot = robot.replace(arm_q_rad=q)
    gripper = gripper_world(robot, gripper_in_base(q, cfg.arm, cfg.base))
    best_err = jnp.minimum(best_err, catch_error_m(gripper, target, cfg))
    robot = robot.replace(gripper_xyz_m=gripper)
    return finish_step(state, robot, target, best_err, draws.next_key, draws.sense_noise, cfg)


def finish_step(
    state: EnvState,
    robot: RobotState,
    target: TargetState,
    best_err: jax.Array,
    key: jax.Array,
    sense_noise: jax.Array,
    cfg: WorldCfg,
):
    """The end of ``step`` once the bodies have moved (shared with other physics backends,
    ``dyncatch.fullbody.catch``): the catch from ``best_err`` (the step's smallest
    catch-point error), the camera, the reward, the frame and the episode's end.
    ``robot`` and ``target`` are in ``state``'s frame; ``key`` becomes the next state's key and
    ``sense_noise`` (2,) is the camera's standard-normal noise (``sim.draws``)."""
    obstacles = obstacles_in_play(state, cfg)
    dt_s = cfg.episode.dt_s
    success = best_err <= cfg.arm.catch_radius_m
    step_count = state.step + 1
    sensor = sensor_tick(
        state.sensor,
        robot,
        target,
        step_count,
        sense_noise,
        cfg,
        _line_of_sight_at_frames(obstacles, robot, target, step_count, cfg),
    )
    distance = jnp.linalg.norm(target.xy_m - robot.xy_m)
    terms = reward_terms(
        state.distance_m,
        distance,
        bearing(robot.xy_m, robot.yaw_rad, target.xy_m),
        success,
        cfg.sensor,
    )
    new_state = recentre(
        EnvState(
            robot=robot,
            target=target,
            sensor=sensor,
            step=step_count,
            key=key,
            success=success,
            distance_m=distance,
            origin_xy_m=state.origin_xy_m,
            anchor_xy_m=state.anchor_xy_m,
            obstacles=state.obstacles,
        )
    )
    # Eq. 8 read as a terminal event ends the episode at the catch; read as a state
    # indicator it is paid while the catch holds and the episode runs on.
    terminated = success if cfg.reward.success_per == "terminal" else jnp.zeros((), bool)
    truncated = (step_count >= cfg.episode.max_steps) & ~terminated
    info = {f"reward/{name}": value for name, value in terms.items()}
    info.update(
        success=success,
        terminated=terminated,
        truncated=truncated,
        distance_m=distance,
        catch_error_m=best_err,
    )
    return (
        new_state,
        observe(new_state, cfg),
        total_reward(terms, cfg.reward, dt_s),
        terminated | truncated,
        info,
    )
