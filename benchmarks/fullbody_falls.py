"""What the full body does while the arm reaches: the measurements behind docs/fullbody.md's falls.

``python benchmarks/fullbody_falls.py [--policy RUN_OR_BASELINE [--predictor CKPT]]
[--episodes N] [--speed-mps V] [--duration-s T] [--stowed] [--fullbody.*]`` plays a policy
(pursuit by default, or a trained run in its training world) against the reactive target on
the full body (``run_fullbody_episodes``, the code ``dyncatch eval --backend mujoco`` runs;
with ``--eval-key`` the key ``dyncatch eval --speeds V --episodes N --seed S`` uses, so the
episodes are that command's) and probes every
200 Hz control period: the trunk's roll and pitch, the arm's joint speeds and torques against
their limits, the arm's centre of mass in the trunk frame and the wrench the arm puts on the
trunk (MuJoCo's ``cfrc_int`` of the arm's first link, less the arm's weight: its dynamic
part). Prints one JSON object: the fall rate, and per figure its value with the arm reaching
and stowed, over all episodes.
"""

from __future__ import annotations

import dataclasses
import json
from collections import defaultdict

import jax
import mujoco
import numpy as np
import tyro

from dyncatch.evaluation.backends import run_fullbody_episodes
from dyncatch.evaluation.grid import EVAL_STREAM
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.policies.registry import BASELINES
from dyncatch.rl.resolve import resolve_policy
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax

GRAVITY_MPS2 = 9.81


@dataclasses.dataclass(frozen=True)
class FallsCmd:
    episodes: int = 20
    """Episodes (seed ``seed``: the same episodes as ``dyncatch eval pursuit``)."""
    speed_mps: float = 1.2
    """Target speed (reactive)."""
    duration_s: float = 10.0
    """Episode limit."""
    seed: int = 0
    policy: str = "pursuit"
    """A baseline's name or a trained run's folder."""
    predictor: str | None = None
    """Predictor checkpoint for a run (as ``dyncatch eval --predictor``)."""
    eval_key: bool = False
    """Use ``dyncatch eval``'s key for a single speed (``evaluation.grid``), not
    ``jax.random.key(seed)``."""
    stowed: bool = False
    """Keep the arm stowed (activation distance 0.01 m): no catch, the trot alone."""
    fullbody: FullBodyCfg = FullBodyCfg()
    """The full body (its ``arm`` is replaced by the world's)."""
    workers: int | None = None
    """Worker processes the episodes are split over (None: one per core)."""


class Probe:
    """Per episode, one row per control period of the figures named in ``FIELDS``."""

    FIELDS = (
        "t_s",
        "active",
        "roll_rad",
        "pitch_rad",
        "qd_ratio",
        "qd_joint",
        "sat",
        "arm_com_y_m",
        "arm_com_x_m",
        "dyn_mx_nm",
        "dyn_my_nm",
        "dyn_mz_nm",
        "dyn_f_n",
        "speed_mps",
        "yaw_rate_rps",
        "reach_err_m",
    )

    def __init__(self, vel_limit_rps: float, torque_limit_nm: np.ndarray):
        self.vel_limit = vel_limit_rps
        self.torque_limit = np.asarray(torque_limit_nm)
        self.rows: dict[int, list] = defaultdict(list)

    def __call__(self, i: int, env, goal) -> None:
        m, d, idx = env.model, env.data, env.idx
        mujoco.mj_rnePostConstraint(m, d)
        rot = d.xmat[idx.base_body].reshape(3, 3)
        yaw = np.arctan2(rot[1, 0], rot[0, 0])
        c, s = np.cos(yaw), np.sin(yaw)
        heading = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
        link1 = m.body("arm_link1").id
        arm_mass = m.body_subtreemass[link1]
        com = d.subtree_com[idx.base_body]
        arm_com = d.subtree_com[link1]
        torque, force = d.cfrc_int[link1, :3], d.cfrc_int[link1, 3:]
        weight = np.array([0.0, 0.0, arm_mass * GRAVITY_MPS2])
        # The wrench the trunk puts on the arm (about the robot's COM) less what holds its
        # weight: what a rigid-body gait model that knows the arm's mass does not see.
        dyn_m = heading @ (torque - np.cross(arm_com - com, weight))
        dyn_f = force - weight
        arm_b = rot.T @ (arm_com - d.xpos[idx.base_body])
        qd = d.qvel[idx.arm_dof]
        tau = d.actuator_force[idx.arm_ctrl]
        vel = env.base_velocity_heading()
        self.rows[i].append(
            (
                env.time_s,
                goal is not None,
                np.arctan2(rot[2, 1], rot[2, 2]),
                -np.arcsin(np.clip(rot[2, 0], -1, 1)),
                np.max(np.abs(qd)) / self.vel_limit,
                np.argmax(np.abs(qd)),
                bool(np.any(np.abs(tau) >= 0.999 * self.torque_limit)),
                arm_b[1],
                arm_b[0],
                *dyn_m,
                np.linalg.norm(dyn_f),
                np.hypot(*vel[:2]),
                vel[2],
                np.inf if goal is None else np.linalg.norm(env.gripper_m() - goal),
            )
        )

    def merge(self, other: Probe) -> None:
        """Take the rows a copy saw in a worker process (``FullBodies``)."""
        self.rows.update(other.rows)

    def arrays(self, i: int) -> dict[str, np.ndarray]:
        rows = np.array(self.rows[i], float)
        return {k: rows[:, j] for j, k in enumerate(self.FIELDS)}


def summarise(probe: Probe, fell: np.ndarray, success: np.ndarray) -> dict:
    per = [probe.arrays(i) for i in range(len(fell))]
    cat = {k: np.concatenate([p[k] for p in per]) for k in Probe.FIELDS}
    reach = cat["active"] > 0.5

    def pct(x, q):
        return round(float(np.percentile(np.abs(x), q)), 3) if x.size else None

    out = {
        "episodes": len(fell),
        "fell": int(fell.sum()),
        "success": int(success.sum()),
        "control_periods": {"reaching": int(reach.sum()), "stowed": int((~reach).sum())},
    }
    for name, sel in (("reaching", reach), ("stowed", ~reach)):
        out[name] = {
            "roll_p99_rad": pct(cat["roll_rad"][sel], 99),
            "pitch_p99_rad": pct(cat["pitch_rad"][sel], 99),
            "arm_speed_over_limit_frac": round(float(np.mean(cat["qd_ratio"][sel] > 1.0)), 4)
            if sel.any()
            else None,
            "arm_speed_max_over_limit": round(float(cat["qd_ratio"][sel].max()), 2)
            if sel.any()
            else None,
            "arm_over_limit_by_joint": np.bincount(
                cat["qd_joint"][sel & (cat["qd_ratio"] > 1.0)].astype(int), minlength=6
            ).tolist(),
            "arm_torque_saturated_frac": round(float(np.mean(cat["sat"][sel])), 4)
            if sel.any()
            else None,
            "arm_com_lateral_p99_m": pct(cat["arm_com_y_m"][sel], 99),
            "arm_com_forward_p50_m": round(float(np.median(cat["arm_com_x_m"][sel])), 3)
            if sel.any()
            else None,
            "arm_dyn_roll_moment_p99_nm": pct(cat["dyn_mx_nm"][sel], 99),
            "arm_dyn_pitch_moment_p99_nm": pct(cat["dyn_my_nm"][sel], 99),
            "arm_dyn_yaw_moment_p99_nm": pct(cat["dyn_mz_nm"][sel], 99),
            "arm_dyn_force_p99_n": pct(cat["dyn_f_n"][sel], 99),
            "speed_p50_mps": pct(cat["speed_mps"][sel], 50),
            "gripper_to_goal_p50_m": pct(cat["reach_err_m"][sel], 50),
            "yaw_rate_p90_rps": pct(cat["yaw_rate_rps"][sel], 90),
        }
    falls = []
    for i in np.flatnonzero(fell):
        p = per[i]
        t_fall = p["t_s"][-1]
        act = np.flatnonzero(p["active"] > 0.5)
        last = p["t_s"] > t_fall - 1.0
        falls.append(
            {
                "episode": int(i),
                "t_fall_s": round(float(t_fall), 2),
                "first_reach_s": round(float(p["t_s"][act[0]]), 2) if act.size else None,
                "reaching_in_last_1s_frac": round(float(p["active"][last].mean()), 2),
                "roll_at_fall_rad": round(float(p["roll_rad"][-1]), 2),
                "pitch_at_fall_rad": round(float(p["pitch_rad"][-1]), 2),
                "arm_com_lateral_last_1s_mean_m": round(float(p["arm_com_y_m"][last].mean()), 3),
                "speed_last_1s_mean_mps": round(float(p["speed_mps"][last].mean()), 2),
                "abs_yaw_rate_last_1s_mean_rps": round(
                    float(np.abs(p["yaw_rate_rps"][last]).mean()), 2
                ),
            }
        )
    out["falls"] = falls
    return out


def _at_peak(i: int, rows: dict[str, np.ndarray]) -> dict:
    k = int(np.argmax(rows["qd_ratio"]))
    t, active = rows["t_s"], rows["active"] > 0
    dt = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    return {
        "episode": int(i),
        **{f: round(float(rows[f][k]), 3) for f in Probe.FIELDS},
        "sat_within_50ms": bool(rows["sat"][max(k - 10, 0) : k + 1].any()),
        # What led to the peak: how long since the arm last reached (inf: never in this
        # episode), the arm's speed 0.1 s before, and the trunk's largest yaw acceleration
        # over the last 50 ms (its heading-frame yaw rate differenced over control periods).
        "s_since_reaching": round(float(t[k] - t[:k][active[:k]].max()), 3)
        if active[:k].any()
        else np.inf,
        "qd_ratio_100ms_before": round(float(rows["qd_ratio"][max(k - 20, 0)]), 3),
        "yaw_accel_max_50ms_rps2": round(
            float(
                np.abs(np.diff(rows["yaw_rate_rps"][max(k - 10, 0) : k + 1]) / dt).max(initial=0.0)
            ),
            1,
        ),
    }


def main(cmd: FallsCmd) -> dict:
    policy, method, trained = resolve_policy(cmd.policy, WorldCfg(), None, cmd.predictor)
    world = (WorldCfg() if trained is None else trained).with_behavior("reactive")
    world = world.with_speed(cmd.speed_mps)
    world = world.replace(episode=world.episode.replace(duration_s=cmd.duration_s))
    if cmd.stowed:
        world = world.replace(arm=world.arm.replace(activation_distance_m=0.01))
    if trained is None:
        policy = BASELINES[cmd.policy](world)
    fullbody = dataclasses.replace(cmd.fullbody, arm=world.arm)
    probe = Probe(world.arm.max_joint_vel_rps, np.asarray(fullbody.z1.max_torque_nm))
    key = jax.random.key(cmd.seed)
    if cmd.eval_key:
        key = jax.random.fold_in(jax.random.fold_in(key, EVAL_STREAM), 0)
    out = run_fullbody_episodes(
        policy, key, world, cmd.episodes, fullbody, probe=probe, workers=cmd.workers
    )
    result = {"policy": method, **summarise(probe, out["fell"], out["success"])}
    ok = out["success"]
    result["catch_time_of_catches_s"] = (
        round(float(out["catch_time_s"][ok].mean()), 2) if ok.any() else None
    )
    # The closest the gripper came to its goal (the target's centre, catch_offset_m up) in
    # each episode that reached; a catch needs catch_radius_m (5 cm).
    closest = [
        float(np.min(probe.arrays(i)["reach_err_m"]))
        for i in range(cmd.episodes)
        if np.isfinite(probe.arrays(i)["reach_err_m"]).any()
    ]
    result["closest_gripper_to_goal_m"] = {
        "episodes_reaching": len(closest),
        "under_5cm": int(np.sum(np.array(closest) < 0.05)),
        "p50": round(float(np.median(closest)), 3) if closest else None,
    }
    # Every physics step (the probe sees control periods only): FullBodyEnv.arm_driver.
    result["physics_steps"] = {
        "arm_speed_max_over_limit": round(float(out["arm_speed_ratio"].max()), 4),
        "arm_torque_max_over_limit": round(float(out["arm_torque_ratio"].max()), 4),
        "episodes_over_limit": int(out["arm_over_limit"].sum()),
    }
    # Where an episode left a physics step over an arm limit: its control period of the
    # largest joint speed, and what the trunk and the arm did there.
    result["over_limit_episodes"] = [
        _at_peak(i, probe.arrays(i)) for i in np.flatnonzero(out["arm_over_limit"])
    ]
    result["per_episode"] = {
        "success": ok.astype(int).tolist(),
        "fell": out["fell"].astype(int).tolist(),
        "catch_time_s": np.round(out["catch_time_s"], 2).tolist(),
        "arm_speed_ratio": np.round(out["arm_speed_ratio"], 4).tolist(),
        "arm_torque_ratio": np.round(out["arm_torque_ratio"], 4).tolist(),
    }
    result["wall_s"] = round(out["wall_s"], 1)
    result["cpu_s"] = round(out["cpu_s"], 1)
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(FallsCmd))
