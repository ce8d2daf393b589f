"""How fast the full-body trot settles under each swing-leg stiffness (GaitCfg.swing_kp_nm_per_rad).

``python benchmarks/swing_stiffness.py [--kps-nm-per-rad 150 225 300 450] [--fullbody.*]``
holds each command of ``COMMANDS`` for 3 s from standing, arm stowed, under each swing
stiffness, and reads the trunk's heading-frame velocity and yaw rate, the mean of the last
1.5 s (as ``fullbody_tracking.settled_velocity``). Prints one JSON object: per stiffness and
command the settled (vx, vy, yaw rate), its ground speed (the norm of vx and vy) and whether
the trunk fell; and the process's CPU seconds (docs/fullbody.md, "The trot's envelope").
"""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np
import tyro

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv

COMMANDS = (  # vx m/s, vy m/s, yaw rate rad/s: BaseCfg's box corner, its sides, a diagonal
    (2.0, 1.0, 0.0),
    (1.5, 1.0, 0.0),
    (2.0, 0.0, 0.0),
    (0.0, 1.0, 0.0),
)


@dataclasses.dataclass(frozen=True)
class SwingCmd:
    kps_nm_per_rad: tuple[float, ...] = (150.0, 225.0, 300.0, 450.0)
    """Swing-leg joint stiffnesses to try (``GaitCfg.swing_kp_nm_per_rad``)."""
    hold_s: float = 3.0
    """How long each command is held from standing."""
    measure_s: float = 1.5
    """The settled velocity is the mean over this last part of the hold."""
    fullbody: FullBodyCfg = FullBodyCfg()


def settle(fullbody: FullBodyCfg, command, hold_s: float, measure_s: float):
    """The mean heading-frame velocity and yaw rate (3,) over the last ``measure_s`` of
    ``command`` held ``hold_s`` from standing, arm stowed; and whether the trunk fell."""
    env = FullBodyEnv(fullbody)
    env.reset()
    n, m = round(hold_s * fullbody.control_hz), round(measure_s * fullbody.control_hz)
    vel, fell = [], False
    for _ in range(n):
        env.step(np.asarray(command, float))
        vel.append(env.base_velocity_heading())
        fell = fell or env.fallen()
    return np.mean(vel[-m:], axis=0), fell


def main(cmd: SwingCmd) -> dict:
    t0 = time.process_time()
    rows = []
    for kp in cmd.kps_nm_per_rad:
        gait = dataclasses.replace(cmd.fullbody.gait, swing_kp_nm_per_rad=float(kp))
        fullbody = dataclasses.replace(cmd.fullbody, gait=gait)
        for command in COMMANDS:
            vel, fell = settle(fullbody, command, cmd.hold_s, cmd.measure_s)
            rows.append(
                {
                    "swing_kp_nm_per_rad": kp,
                    "command": list(command),
                    "settled": np.round(vel, 3).tolist(),
                    "ground_speed_mps": round(float(np.hypot(vel[0], vel[1])), 3),
                    "fell": fell,
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    out = {"rows": rows, "cpu_s": round(time.process_time() - t0, 1)}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main(tyro.cli(SwingCmd))
