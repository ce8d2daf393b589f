"""Does the full body go where the policy sends it? Commands against motion on both backends.

``python benchmarks/fullbody_tracking.py --policy RUN [--predictor CKPT] [--episodes N]
[--speed-mps V] [--seed S] [--fullbody.*]`` plays ``dyncatch eval RUN --speeds V --episodes
N --seed S``'s episodes (the same key) on the reduced JAX model and on the full body, and
records every step: the policy's clipped command (vx, vy, yaw rate), the base's heading-frame
velocity and yaw rate, the distance from the trunk to the target and whether the arm reaches.
On the full body the command is the one the trot follows (``GaitState.cmd_ref``, the policy's
under ``BaseCfg``'s accelerations), sampled every 200 Hz control period, with the yaw rate
after the gait's turn limit (``GaitCfg.max_centripetal_mps2``). Prints one JSON object: per
backend, how the commands are spread (how often at a limit), how closely the base follows
them, how fast the gap to the target closes, the reach (time from the arm's first activation
to the catch; closest catch-point error) and the catches; and first, the trot's settled
velocity under each command of ``--settled`` (``settled``).
"""

from __future__ import annotations

import dataclasses
import json
from collections import defaultdict

import jax
import jax.numpy as jnp
import mujoco
import numpy as np
import tyro

from dyncatch.evaluation.backends import run_fullbody_episodes
from dyncatch.evaluation.grid import EVAL_STREAM
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv
from dyncatch.fullbody.gait import limit_turn
from dyncatch.policies.api import as_recurrent
from dyncatch.rl.resolve import resolve_policy
from dyncatch.sim.api import as_env
from dyncatch.sim.base import clip_command
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


@dataclasses.dataclass(frozen=True)
class TrackingCmd:
    policy: str
    """A trained run's folder (or a baseline's name)."""
    predictor: str | None = None
    """Predictor checkpoint for a run (as ``dyncatch eval --predictor``)."""
    episodes: int = 10
    speed_mps: float = 1.6
    """Target speed (reactive)."""
    seed: int = 0
    """``dyncatch eval --seed``: the same episodes."""
    fullbody: FullBodyCfg = FullBodyCfg()
    """The full body (its ``arm`` is replaced by the world's)."""
    workers: int | None = None
    """Worker processes for the full bodies (None: one per core)."""
    skip_fullbody: bool = False
    """Only the reduced model (seconds, not minutes)."""
    settled: tuple[tuple[float, float, float], ...] = (
        (2.0, 1.0, 0.0),
        (1.5, 1.0, 0.0),
        (0.0, 1.0, 0.0),
        (2.0, 0.0, 0.0),
    )
    """Commands (forward, left m/s, yaw rate rad/s) held 3 s from standing on the full
    body alone; the mean velocity over the last 1.5 s is printed as ``settled`` (the trot's
    envelope at the corners of the command box the policy drives at)."""
    traces: str | None = None
    """Also save every control period's probe rows here (``.npz``, one array per episode)."""


class Probe:
    """Per full-body episode, one row per 200 Hz control period (``FIELDS``)."""

    FIELDS = (
        "t_s",
        "cmd_vx",
        "cmd_vy",
        "cmd_wz",
        "follow_wz",
        "vx",
        "vy",
        "wz",
        "dist_m",
        "active",
        "reach_err_m",
        "ik_err_m",
        "pd_err_m",
        "roll_rad",
    )

    def __init__(self, max_centripetal_mps2: float):
        self.max_centripetal = max_centripetal_mps2
        self.rows: dict[int, list] = defaultdict(list)

    def __call__(self, i: int, env, goal) -> None:
        d, idx = env.data, env.idx
        ref = env.gait.cmd_ref
        follow = limit_turn(ref, self.max_centripetal)
        vel = env.base_velocity_heading()
        target = d.mocap_pos[idx.target_mocap]
        rot = d.xmat[idx.base_body].reshape(3, 3)
        # The gripper of the commanded joints (the IK's targets) at the measured trunk: its
        # distance to the goal is the IK's lag, its distance to the gripper the PD's.
        k = env._scratch
        k.qpos[:] = d.qpos
        k.qpos[idx.arm_qpos] = env.arm_q_des
        mujoco.mj_kinematics(env.model, k)
        commanded = k.site_xpos[idx.gripper_site]
        gripper = env.gripper_m()
        self.rows[i].append(
            (
                env.time_s,
                *ref,
                follow[2],
                *vel,
                float(np.hypot(*(target[:2] - d.qpos[:2]))),
                goal is not None,
                np.inf if goal is None else float(np.linalg.norm(gripper - goal)),
                np.inf if goal is None else float(np.linalg.norm(commanded - goal)),
                float(np.linalg.norm(gripper - commanded)),
                float(np.arctan2(rot[2, 1], rot[2, 2])),
            )
        )

    def merge(self, other: Probe) -> None:
        self.rows.update(other.rows)

    def arrays(self, i: int) -> dict[str, np.ndarray]:
        rows = np.array(self.rows[i], float)
        return {k: rows[:, j] for j, k in enumerate(self.FIELDS)}


def jax_traces(policy, key, world: WorldCfg, n: int) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """``evaluation.episodes.run_episodes``' episodes on the JAX world with every 50 Hz
    step's command, velocity, distance to the target and catch-point error, each (T, n)."""
    env = as_env(world)
    k_reset, k_act = jax.random.split(key)
    state = jax.vmap(env.reset)(jax.random.split(k_reset, n))
    obs = jax.vmap(env.observe)(state)
    pol = as_recurrent(policy)
    vpolicy, vstep = jax.vmap(pol.step), jax.vmap(env.step)

    def body(carry, t):
        state, obs, pcarry, done = carry
        keys = jax.random.split(jax.random.fold_in(k_act, t), n)
        pcarry, action = vpolicy(pcarry, state, obs, keys)
        cmd = clip_command(action, world.base)
        new, obs, _, now_done, info = vstep(state, action)
        r = new.robot
        rec = {
            "cmd": cmd,
            "vel": jnp.concatenate([r.vel_body_mps, r.yaw_rate_rps[:, None]], axis=1),
            "dist_m": jnp.linalg.norm(new.target.xy_m - r.xy_m, axis=1),
            "err_m": info["catch_error_m"],
            "success": info["success"],
            "live": ~done,
        }
        return (new, obs, pcarry, done | now_done), rec

    pcarry = jax.vmap(pol.init_carry)(state, obs)
    init = (state, obs, pcarry, jnp.zeros(n, bool))
    steps = int(world.episode.max_steps)
    _, rec = jax.jit(lambda c: jax.lax.scan(body, c, jnp.arange(steps)))(init)
    rec = {k: np.asarray(v) for k, v in rec.items()}
    first = np.argmax(rec["success"], axis=0)
    caught = rec["success"].any(axis=0)
    return rec, np.where(caught, first, -1)


def settled_velocity(fullbody: FullBodyCfg, command, hold_s: float = 3.0, measure_s: float = 1.5):
    """The full body's heading-frame velocity and yaw rate (3,), the mean over the last
    ``measure_s`` of ``command`` (3,) held ``hold_s`` from standing, arm stowed."""
    env = FullBodyEnv(fullbody)
    env.reset()
    n, m = round(hold_s * fullbody.control_hz), round(measure_s * fullbody.control_hz)
    vel = []
    for _ in range(n):
        env.step(np.asarray(command, float))
        vel.append(env.base_velocity_heading())
    return np.mean(vel[-m:], axis=0)


def _share(x: np.ndarray, at: float) -> float:
    return round(float(np.mean(np.abs(x) >= at - 1e-3)), 3) if x.size else float("nan")


def _cmd_stats(cmd: np.ndarray, vel: np.ndarray, base, max_centripetal: float) -> dict:
    """Commands (k, 3) and velocities (k, 3) over live samples."""
    speed = np.hypot(cmd[:, 0], cmd[:, 1])
    err = vel - cmd
    return {
        "samples": len(cmd),
        "cmd_vx_mean": round(float(cmd[:, 0].mean()), 3),
        "cmd_vx_at_max_share": _share(np.maximum(cmd[:, 0], 0), base.max_forward_mps),
        "cmd_abs_vy_mean": round(float(np.abs(cmd[:, 1]).mean()), 3),
        "cmd_vy_at_max_share": _share(cmd[:, 1], base.max_lateral_mps),
        "cmd_abs_wz_mean": round(float(np.abs(cmd[:, 2]).mean()), 3),
        "cmd_wz_at_max_share": _share(cmd[:, 2], base.max_yaw_rate_rps),
        "cmd_turn_over_centripetal_share": round(
            float(np.mean(speed * np.abs(cmd[:, 2]) > max_centripetal + 1e-6)), 3
        ),
        "vx_mean": round(float(vel[:, 0].mean()), 3),
        "abs_wz_mean": round(float(np.abs(vel[:, 2]).mean()), 3),
        "track_err_rms": np.round(np.sqrt(np.mean(err**2, axis=0)), 3).tolist(),
        "track_err_mean": np.round(np.mean(err, axis=0), 3).tolist(),
    }


def _reach_stats(active: list, caught_at: list, closest: list, dt: float) -> dict:
    """Per episode: index of the first active step (or -1), the catch step (or -1), the
    smallest error."""
    a, c = np.array(active), np.array(caught_at)
    both = (a >= 0) & (c >= 0)
    return {
        "episodes_reaching": int((a >= 0).sum()),
        "caught": int((c >= 0).sum()),
        "first_reach_to_catch_s_mean": round(float(((c - a)[both] * dt).mean()), 2)
        if both.any()
        else None,
        "first_reach_s_mean": round(float(a[a >= 0].mean() * dt), 2) if (a >= 0).any() else None,
        "closest_err_m_p50": round(float(np.median(closest)), 3) if closest else None,
    }


def main(cmd: TrackingCmd) -> dict:
    policy, method, trained = resolve_policy(cmd.policy, WorldCfg(), None, cmd.predictor)
    world = (WorldCfg() if trained is None else trained).with_behavior("reactive")
    world = world.with_speed(cmd.speed_mps)
    key = jax.random.fold_in(jax.random.fold_in(jax.random.key(cmd.seed), EVAL_STREAM), 0)
    cent = cmd.fullbody.gait.max_centripetal_mps2
    out: dict = {"policy": method, "speed_mps": cmd.speed_mps, "episodes": cmd.episodes}

    if not cmd.skip_fullbody:
        fb_cfg = dataclasses.replace(cmd.fullbody, arm=world.arm)
        out["settled"] = {
            str(list(c)): np.round(settled_velocity(fb_cfg, c), 3).tolist() for c in cmd.settled
        }
    rec, first = jax_traces(policy, key, world, cmd.episodes)
    live = rec["live"]
    dt = world.episode.dt_s
    out["jax"] = _cmd_stats(rec["cmd"][live], rec["vel"][live], world.base, cent)
    dist = rec["dist_m"]
    closing = -np.diff(dist, axis=0) / dt
    out["jax"]["closing_mps_mean"] = round(float(closing[live[1:]].mean()), 3)
    act = dist <= world.arm.activation_distance_m
    first_act = [int(np.argmax(act[:, e])) if act[:, e].any() else -1 for e in range(cmd.episodes)]
    closest = [float(rec["err_m"][live[:, e], e].min()) for e in range(cmd.episodes)]
    out["jax"]["reach"] = _reach_stats(first_act, list(first), closest, dt)
    out["jax"]["catch_step_s"] = [round(float(f * dt), 2) if f >= 0 else None for f in first]
    if cmd.skip_fullbody:
        print(json.dumps(out))
        return out

    fullbody = dataclasses.replace(cmd.fullbody, arm=world.arm)
    probe = Probe(cent)
    fb = run_fullbody_episodes(
        policy, key, world, cmd.episodes, fullbody, probe=probe, workers=cmd.workers
    )
    per = [probe.arrays(i) for i in range(cmd.episodes)]
    cat = {k: np.concatenate([p[k] for p in per]) for k in Probe.FIELDS}
    c = np.stack([cat["cmd_vx"], cat["cmd_vy"], cat["cmd_wz"]], axis=1)
    v = np.stack([cat["vx"], cat["vy"], cat["wz"]], axis=1)
    out["fullbody"] = _cmd_stats(c, v, world.base, cent)
    out["fullbody"]["followed_wz_err_rms"] = round(
        float(np.sqrt(np.mean((cat["wz"] - cat["follow_wz"]) ** 2))), 3
    )
    out["fullbody"]["turn_limit_cut_rps_mean"] = round(
        float(np.mean(np.abs(cat["cmd_wz"]) - np.abs(cat["follow_wz"]))), 3
    )
    pdt = 1.0 / fullbody.control_hz
    out["fullbody"]["closing_mps_mean"] = round(
        float(np.mean(np.concatenate([-np.diff(p["dist_m"]) / pdt for p in per]))), 3
    )
    steps_per = round(dt / pdt)
    first_act = [
        int(np.argmax(p["active"] > 0.5)) // steps_per if (p["active"] > 0.5).any() else -1
        for p in per
    ]
    caught = [
        int(round(t / dt)) - 1 if ok else -1
        for t, ok in zip(fb["catch_time_s"], fb["success"], strict=True)
    ]
    closest = [float(p["reach_err_m"].min()) for p in per if np.isfinite(p["reach_err_m"]).any()]
    out["fullbody"]["reach"] = _reach_stats(first_act, caught, closest, dt)
    act = cat["active"] > 0.5
    out["fullbody"]["reach"]["while_reaching_p50_m"] = {
        k: round(float(np.median(cat[k][act])), 3) if act.any() else None
        for k in ("reach_err_m", "ik_err_m", "pd_err_m")
    }
    if cmd.traces:
        np.savez_compressed(
            cmd.traces,
            fields=np.array(Probe.FIELDS),
            **{f"ep{i}": np.array(probe.rows[i]) for i in range(cmd.episodes)},
        )
    out["fullbody"]["catch_step_s"] = [c * dt if c >= 0 else None for c in caught]
    out["fullbody"]["fell"] = fb["fell"].astype(int).tolist()
    out["fullbody"]["roll_abs_p99_rad"] = round(
        float(np.percentile(np.abs(cat["roll_rad"]), 99)), 3
    )
    out["fullbody"]["wall_s"] = round(fb["wall_s"], 1)
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(TrackingCmd))
