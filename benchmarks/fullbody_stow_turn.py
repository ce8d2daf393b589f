"""The arm's joint speeds while it stows from a side reach and the trunk turns hard.

``python benchmarks/fullbody_stow_turn.py [--fullbody.*]`` (e.g.
``--fullbody.z1.stow-speed-fraction 0.5``): twelve runs of 2.5 s on ``FullBodyEnv``, each a
forward speed (1.0, 1.6 m/s) and a yaw rate (1.5, 2.0, 2.5 rad/s) that flips sign at 1.25 s,
the arm reaching from 0.5 to 1.2 s for a goal 0.35 m ahead, 0.55 m to one side (left, right)
and 0.15 m below the trunk, then stowing: the moment a trained policy's arm went over its
speed limit (docs/fullbody.md, "The arm's limits"). Prints one JSON object: per run the
largest arm joint speed over the Z1's limit while reaching and while stowing (the driver's,
over every physics step), whether it fell, and the largest of each over the runs.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import time

import numpy as np
import tyro

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv

SPEEDS_MPS = (1.0, 1.6)
YAW_RATES_RPS = (1.5, 2.0, 2.5)
SIDES = (1.0, -1.0)  # the reach's side, +1 left


@dataclasses.dataclass(frozen=True)
class StowTurnCmd:
    reach_s: tuple[float, float] = (0.5, 1.2)
    """When the arm reaches (from, until); it stows before and after."""
    flip_s: float = 1.25
    """When the yaw command changes sign."""
    duration_s: float = 2.5
    """Length of one run."""
    fullbody: FullBodyCfg = FullBodyCfg()


def side_goal(env: FullBodyEnv, side: float) -> np.ndarray:
    """(3,) 0.35 m ahead of the trunk, 0.55 m to ``side``, 0.15 m below it (world)."""
    rot = env.data.xmat[env.idx.base_body].reshape(3, 3)
    c, s = rot[0, 0], rot[1, 0]
    norm = np.hypot(c, s)
    c, s, lat = c / norm, s / norm, 0.55 * side
    return env.data.qpos[:3] + np.array([0.35 * c - lat * s, 0.35 * s + lat * c, -0.15])


def one_run(env: FullBodyEnv, cmd: StowTurnCmd, speed: float, yaw: float, side: float) -> dict:
    env.reset()
    limit = env.cfg.arm.max_joint_vel_rps
    peaks = {"reaching": 0.0, "stowing": 0.0}
    phase, fell_s = None, None
    for k in range(round(cmd.duration_s * env.cfg.control_hz)):
        t = k / env.cfg.control_hz
        reaching = cmd.reach_s[0] <= t < cmd.reach_s[1]
        now = "reaching" if reaching else ("stowing" if t >= cmd.reach_s[1] else None)
        if now != phase:  # the driver's peaks from the start of each phase
            env.arm_driver.reset_peaks()
            phase = now
        goal = side_goal(env, side) if reaching else None
        env.step(np.array([speed, 0.0, yaw if t < cmd.flip_s else -yaw]), goal)
        if phase is not None:
            peaks[phase] = max(peaks[phase], env.arm_driver.peak_speed_rps / limit)
        if env.fallen():
            fell_s = round(env.time_s, 2)
            break
    return {
        "cmd": [speed, yaw, side],
        "fell_s": fell_s,
        **{f"{k}_speed_over_limit": round(v, 4) for k, v in peaks.items()},
    }


def main(cmd: StowTurnCmd) -> dict:
    env = FullBodyEnv(cmd.fullbody)
    c0 = time.process_time()
    runs = [one_run(env, cmd, *run) for run in itertools.product(SPEEDS_MPS, YAW_RATES_RPS, SIDES)]
    result = {
        "stow_speed_fraction": cmd.fullbody.z1.stow_speed_fraction,
        "largest_reaching": max(r["reaching_speed_over_limit"] for r in runs),
        "largest_stowing": max(r["stowing_speed_over_limit"] for r in runs),
        "fell": sum(r["fell_s"] is not None for r in runs),
        "runs": runs,
        "cpu_s": round(time.process_time() - c0, 1),
    }
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    main(tyro.cli(StowTurnCmd))
