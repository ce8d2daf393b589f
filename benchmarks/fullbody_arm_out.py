"""How level the trunk stays while it trots and turns with the arm held out sideways.

``python benchmarks/fullbody_arm_out.py [--fullbody.gait.controller trot_dls|mpc]
[--fullbody.*]``: six runs of 4 s on ``FullBodyEnv``, each a forward speed with a yaw rate
that flips to minus half of it every second, the arm's goal 0.35 m ahead of the trunk and
0.55 m (then 0.22 m, every 0.75 s) to one side, 0.15 m below it, from 0.5 s on: what the
catch policies do while the arm reaches (docs/fullbody.md, "Falls"). Prints one JSON object:
per run the largest roll and pitch (rad), whether and when it fell, and the arm's largest
joint speed over the Z1's limit; and the process's CPU seconds.
"""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np
import tyro

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv

RUNS = (  # forward m/s, yaw rate rad/s, arm side (+1 left)
    (1.4, 1.5, 1.0),
    (1.4, 1.5, -1.0),
    (1.0, 2.0, 1.0),
    (1.0, 2.0, -1.0),
    (1.6, -1.2, 1.0),
    (0.5, 2.5, -1.0),
)


@dataclasses.dataclass(frozen=True)
class ArmOutCmd:
    duration_s: float = 4.0
    """Length of one run."""
    fullbody: FullBodyCfg = FullBodyCfg()


def one_run(env: FullBodyEnv, speed: float, yaw_rate: float, side: float, steps: int) -> dict:
    env.reset()
    roll = pitch = ratio = 0.0
    fell_s = None
    for k in range(steps):
        goal = None
        if k >= 100:
            rot = env.data.xmat[env.idx.base_body].reshape(3, 3)
            c, s = rot[0, 0], rot[1, 0]
            norm = np.hypot(c, s)
            c, s = c / norm, s / norm
            lat = 0.55 * side * (1.0 if (k // 150) % 2 == 0 else 0.4)
            goal = env.data.qpos[:3] + np.array([0.35 * c - lat * s, 0.35 * s + lat * c, -0.15])
        cmd = np.array([speed, 0.0, yaw_rate * (1.0 if (k // 200) % 2 == 0 else -0.5)])
        env.step(cmd, goal)
        rot = env.data.xmat[env.idx.base_body].reshape(3, 3)
        roll = max(roll, abs(float(np.arctan2(rot[2, 1], rot[2, 2]))))
        pitch = max(pitch, abs(float(np.arcsin(np.clip(rot[2, 0], -1.0, 1.0)))))
        qd = np.abs(env.data.qvel[env.idx.arm_dof]).max() / env.cfg.arm.max_joint_vel_rps
        ratio = max(ratio, float(qd))
        if env.fallen():
            fell_s = round(env.time_s, 2)
            break
    return {
        "cmd": [speed, yaw_rate, side],
        "max_roll_rad": round(roll, 3),
        "max_pitch_rad": round(pitch, 3),
        "fell_s": fell_s,
        "arm_speed_max_over_limit": round(ratio, 3),
    }


def main(cmd: ArmOutCmd) -> dict:
    env = FullBodyEnv(cmd.fullbody)
    c0 = time.process_time()
    steps = round(cmd.duration_s * cmd.fullbody.control_hz)
    runs = [one_run(env, *run, steps) for run in RUNS]
    result = {
        "controller": cmd.fullbody.gait.controller,
        "runs": runs,
        "max_roll_rad": max(r["max_roll_rad"] for r in runs),
        "max_pitch_rad": max(r["max_pitch_rad"] for r in runs),
        "fell": sum(r["fell_s"] is not None for r in runs),
        "cpu_s": round(time.process_time() - c0, 1),
    }
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main(tyro.cli(ArmOutCmd))
