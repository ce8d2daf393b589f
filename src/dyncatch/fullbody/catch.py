"""The catch task on the full body: ``dyncatch eval RUN --backend mujoco``.

The episodes, the target, the camera, the reward and the catch test are the JAX world's
(``sim.env``); only the robot is replaced by the MuJoCo Aliengo + Z1 under the trot and the
arm's DLS IK (``FullBodyEnv``). One 50 Hz control step of N episodes at once:

1. **Policy and target (JAX, one jitted call for the batch).** The policy acts on the
   ``EnvState`` and ``Obs`` as in the JAX world. ``plan_target`` splits the state's key as
   ``sim.env.step`` does, lets the behaviour choose its heading from the measured robot and
   moves the target through the step's sub-steps: its ``n_sub + 1`` positions.
2. **Robot (MuJoCo, one ``FullBodyEnv`` per episode).** The step's sub-steps are control
   periods of the full body (4 x 200 Hz): the clipped command goes to the trot; the arm's
   goal, the target's centre ``catch_offset_m`` up (as ``sim.arm`` aims), goes to the IK
   while the target is within ``activation_distance_m`` of the trunk, else the arm stows.
   The catch-point error is taken before each period and after the last, as the JAX world
   takes it before each sub-step and at the end.
3. **The rest (JAX).** The measured robot (trunk position and yaw, heading-frame velocity,
   arm joints, gripper) replaces the reduced one and ``sim.env.finish_step`` does what the
   JAX world does after its physics: the catch, the 2 Hz / 120 degree camera, the reward,
   the frame, the episode's end.

The same key gives the same initial states and target noise as ``run_episodes``, so rows
of both backends compare episode for episode. The reduced model's gait noise has no
counterpart: the trot's own ripple is the noise. A robot that falls stays where it fell and
catches nothing. The full body's physical constants are ``FullBodyCfg``'s defaults with the
world's ``ArmCfg`` (its gait follows ``FullBodyCfg.base``, not the policy's training base:
the robot is the same whatever the policy was trained on); flat, open ground only.
"""

from __future__ import annotations

import dataclasses
import functools
import time
from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.gait import yaw_of
from dyncatch.policies.api import as_recurrent
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.base import clip_command
from dyncatch.sim.behaviors import get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.draws import step_draws
from dyncatch.sim.env import finish_step
from dyncatch.sim.scenes import get_scene
from dyncatch.sim.state import EnvState
from dyncatch.sim.target import move, steer


def check_world(world: WorldCfg, fullbody: FullBodyCfg) -> None:
    """Refuse what the full body cannot run, naming the setting to change."""
    scene = get_scene(world.scene.name)
    if scene.walls or scene.layout is not None or scene.terrain is not None:
        raise ValueError(
            f"--backend mujoco runs on flat open ground only; scene {world.scene.name!r} has "
            "walls, obstacles or terrain: use --world.scene.name open_plane"
        )
    rate = world.episode.control_hz * world.episode.physics_substeps
    if abs(rate - fullbody.control_hz) > 1e-6:
        raise ValueError(
            f"the world's sub-steps run at {rate} Hz (episode.control_hz x "
            f"episode.physics_substeps), the full body's control at {fullbody.control_hz} Hz: "
            "they must be equal"
        )


def plan_target(state: EnvState, action: jax.Array, cfg: WorldCfg):
    """The head of ``sim.env.step`` without the base: ``(command (3,), target after the
    step, target xy before each sub-step and after the last (n_sub + 1, 2), next key,
    camera noise (2,))``, positions in ``state``'s frame."""
    behavior = get_behavior(cfg.target.behavior)
    draws = step_draws(state.key)
    dt_s = cfg.episode.dt_s
    n_sub = cfg.episode.physics_substeps
    heading, behavior_state = behavior.desired_heading(
        state.target, state.robot, cfg, draws.behavior_key
    )
    target = steer(state.target.replace(behavior_state=behavior_state), heading, cfg.target, dt_s)
    xys = [target.xy_m]
    for _ in range(n_sub):
        target = move(
            target,
            cfg.target,
            cfg.arena,
            state.origin_xy_m,
            dt_s / n_sub,
            behavior.reflects_off_walls,
            False,
        )
        xys.append(target.xy_m)
    return clip_command(action, cfg.base), target, jnp.stack(xys), draws.next_key, draws.sense_noise


def finish_measured(state: EnvState, measured: dict, target, best_err, key, sense_noise, cfg):
    """``finish_step`` with the robot replaced by ``measured`` (``RobotState``'s fields,
    positions in ``state``'s frame)."""
    robot = state.robot.replace(**measured)
    return finish_step(state, robot, target, best_err, key, sense_noise, cfg)


_plan = jax.jit(jax.vmap(plan_target, in_axes=(0, 0, None)))
_finish = jax.jit(jax.vmap(finish_measured, in_axes=(0, 0, 0, 0, 0, 0, None)))
_reset = jax.jit(lambda keys, env: jax.vmap(env.reset)(keys))
_observe = jax.jit(lambda state, env: jax.vmap(env.observe)(state))


def _act(pol, carry, state, obs, keys):
    return jax.vmap(pol.step)(carry, state, obs, keys)


_act_pytree = jax.jit(_act)
_act_static = jax.jit(_act, static_argnums=0)


def _act_fn(policy) -> Callable:
    """``(carry, state, obs, keys) -> (carry, actions)`` for a batch, jitted once per
    policy kind: a pytree policy (a trained network) is an argument, a hashable one (a
    baseline) a compile-time constant, as ``evaluation.episodes`` treats them."""
    jitted = _act_pytree if getattr(policy, "is_pytree_policy", False) else _act_static
    return functools.partial(jitted, as_recurrent(policy))


@dataclasses.dataclass
class _Robots:
    """The N full bodies of a batch and what the JAX side reads of them."""

    envs: list
    fallen: np.ndarray

    def measure(self, i: int, origin_xy_m: np.ndarray) -> dict:
        env = self.envs[i]
        d, idx = env.data, env.idx
        vel = env.base_velocity_heading()
        grip = env.gripper_m()
        return {
            "xy_m": d.qpos[:2] - origin_xy_m,
            "yaw_rad": yaw_of(d.xmat[idx.base_body].reshape(3, 3)),
            "vel_body_mps": vel[:2],
            "yaw_rate_rps": vel[2],
            "arm_q_rad": d.qpos[idx.arm_qpos].copy(),
            "gripper_xyz_m": np.concatenate([grip[:2] - origin_xy_m, grip[2:]]),
        }


def _catch_error_m(gripper_m: np.ndarray, target_xyz_m: np.ndarray, world: WorldCfg) -> float:
    """``sim.env.catch_error_m`` in numpy (world frame)."""
    catch_point = gripper_m - np.array([0.0, 0.0, world.arm.catch_offset_m])
    return float(np.linalg.norm(target_xyz_m - catch_point))


def _physics(
    robots: _Robots, i: int, command, target_xy_m: np.ndarray, world: WorldCfg, probe=None
):
    """One control step of episode ``i``: its full body through the sub-steps while the
    target passes ``target_xy_m`` (n_sub + 1, 2) (world frame). Returns the smallest
    catch-point error. ``probe(i, env, goal)``, if given, is called after each sub-step."""
    env = robots.envs[i]
    height = world.target.height_m
    best = np.inf
    for xy in target_xy_m[:-1]:
        target = np.array([xy[0], xy[1], height])
        best = min(best, _catch_error_m(env.gripper_m(), target, world))
        near = np.sum((xy - env.data.qpos[:2]) ** 2) <= world.arm.activation_distance_m**2
        goal = target + np.array([0.0, 0.0, world.arm.catch_offset_m]) if near else None
        env.set_target(target)
        env.step(command, goal)
        if probe is not None:
            probe(i, env, goal)
    last = np.array([*target_xy_m[-1], height])
    env.set_target(last)
    return min(best, _catch_error_m(env.gripper_m(), last, world))


def run_fullbody_episodes(
    policy,
    key: jax.Array,
    env: Environment | WorldCfg,
    num_episodes: int,
    fullbody: FullBodyCfg | None = None,
    record: int | None = None,
    probe: Callable | None = None,
) -> dict[str, np.ndarray]:
    """Play ``num_episodes`` episodes on the full body; the counterpart of
    ``evaluation.episodes.run_episodes`` (same key, same episodes).

    Returns ``success`` (N,) bool, ``catch_time_s`` (N,) (the limit on failure),
    ``return`` (N,), ``fell`` (N,) bool, ``env_steps`` (the 50 Hz steps simulated on the
    full body, over all episodes), ``wall_s`` and ``cpu_s`` (this process's CPU time: the
    honest cost on a shared machine). ``record``: an episode's index whose full-body state
    is kept at every 50 Hz step until it ends, as ``qpos`` (T, nq) and ``target_m`` (T, 3)
    (world frame; ``benchmarks/fullbody_video.py`` replays them). ``probe(i, env, goal)``:
    called after every 200 Hz control period of episode ``i`` with its ``FullBodyEnv`` and
    the arm's goal (None while stowed), for measurements (``benchmarks/fullbody_falls.py``).
    """
    from dyncatch.fullbody.env import FullBodyEnv
    from dyncatch.fullbody.model import build_model

    t0, c0 = time.perf_counter(), time.process_time()
    env = as_env(env)
    world = env.world
    fullbody = FullBodyCfg(arm=world.arm) if fullbody is None else fullbody
    check_world(world, fullbody)
    n, num_steps = num_episodes, int(world.episode.max_steps)

    k_reset, k_act = jax.random.split(key)
    state = _reset(jax.random.split(k_reset, n), env)
    obs = _observe(state, env)
    act = _act_fn(policy)
    carry = jax.vmap(as_recurrent(policy).init_carry)(state, obs)

    built = build_model(fullbody)
    robots = _Robots([FullBodyEnv(fullbody, built) for _ in range(n)], np.zeros(n, bool))
    origin = np.asarray(state.origin_xy_m, float)
    xy0, yaw0 = np.asarray(state.robot.xy_m, float), np.asarray(state.robot.yaw_rad, float)
    for i, body in enumerate(robots.envs):
        body.reset(xy_m=tuple(origin[i] + xy0[i]), yaw_rad=float(yaw0[i]))

    done, success = np.zeros(n, bool), np.zeros(n, bool)
    steps, ret = np.zeros(n, np.int64), np.zeros(n)
    env_steps = 0
    qpos, target_m = [], []
    for t in range(num_steps):
        if done.all():
            break
        keys = jax.random.split(jax.random.fold_in(k_act, t), n)
        carry, action = act(carry, state, obs, keys)
        command, target, target_xy, next_key, sense_noise = _plan(state, action, world)
        command, target_xy = np.asarray(command, float), np.asarray(target_xy, float)
        origin = np.asarray(state.origin_xy_m, float)
        best = np.full(n, np.inf)
        measured = []
        for i in range(n):
            if not (done[i] or robots.fallen[i]):
                best[i] = _physics(robots, i, command[i], target_xy[i] + origin[i], world, probe)
                robots.fallen[i] = robots.envs[i].fallen()
                env_steps += 1
            measured.append(robots.measure(i, origin[i]))
        measured = jax.tree.map(lambda *x: jnp.asarray(np.stack(x), jnp.float32), *measured)
        best = jnp.asarray(best, jnp.float32)
        state, obs, reward, now_done, info = _finish(
            state, measured, target, best, next_key, sense_noise, world
        )
        live = ~done
        got = np.asarray(info["success"])
        steps += live & ~success
        success |= live & got
        ret += np.where(live, np.asarray(reward), 0.0)
        if record is not None and not done[record]:
            qpos.append(robots.envs[record].data.qpos.copy())
            body = robots.envs[record]
            target_m.append(body.data.mocap_pos[body.idx.target_mocap].copy())
        done |= np.asarray(now_done)
    dt = world.episode.dt_s
    recorded = {} if record is None else {"qpos": np.array(qpos), "target_m": np.array(target_m)}
    return {
        "success": success,
        "catch_time_s": np.where(success, steps * dt, num_steps * dt),
        "return": ret,
        "fell": robots.fallen.copy(),
        "env_steps": env_steps,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - c0,
        **recorded,
    }
