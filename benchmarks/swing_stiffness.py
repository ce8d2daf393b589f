"""How fast the full-body trot settles under each swing-leg stiffness (GaitCfg.swing_kp_nm_per_rad).

``python benchmarks/swing_stiffness.py [--kps-nm-per-rad 150 225 300 450] [--fullbody.*]``
holds each command of ``STEPS`` for 3 s from standing, arm stowed, under each swing
stiffness, and reads the trunk's heading-frame velocity and yaw rate, the mean of the last
1.5 s: the base calibration's step responses (``fullbody.calibration.fullbody_responses``
and ``settled``). Prints one JSON object: per stiffness and command the settled (vx, vy,
yaw rate), its ground speed (the norm of vx and vy) and whether the trunk fell; and the
process's CPU seconds (docs/fullbody.md, "The trot's envelope").
"""

from __future__ import annotations

import dataclasses
import json
import time

import numpy as np
import tyro

from dyncatch.fullbody.calibration import CalibrationCfg, fullbody_responses, settled
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv

STEPS = CalibrationCfg(  # BaseCfg's box corner, a diagonal, its sides
    forward_mps=(2.0,),
    backward_mps=(),
    lateral_mps=(1.0,),
    yaw_rps=(),
    turns=(),
    diagonals=((2.0, 1.0), (1.5, 1.0)),
)


@dataclasses.dataclass(frozen=True)
class SwingCmd:
    kps_nm_per_rad: tuple[float, ...] = (150.0, 225.0, 300.0, 450.0)
    """Swing-leg joint stiffnesses to try (``GaitCfg.swing_kp_nm_per_rad``)."""
    fullbody: FullBodyCfg = FullBodyCfg()


def main(cmd: SwingCmd) -> dict:
    t0 = time.process_time()
    rows = []
    for kp in cmd.kps_nm_per_rad:
        gait = dataclasses.replace(cmd.fullbody.gait, swing_kp_nm_per_rad=float(kp))
        env = FullBodyEnv(dataclasses.replace(cmd.fullbody, gait=gait))
        for r in fullbody_responses(env, STEPS):
            vel = settled(r, STEPS, env.cfg.control_hz)
            rows.append(
                {
                    "swing_kp_nm_per_rad": kp,
                    "command": list(r.command),
                    "settled": np.round(vel, 3).tolist(),
                    "ground_speed_mps": round(float(np.hypot(vel[0], vel[1])), 3),
                    "fell": r.fell,
                }
            )
            print(json.dumps(rows[-1]), flush=True)
    out = {"rows": rows, "cpu_s": round(time.process_time() - t0, 1)}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main(tyro.cli(SwingCmd))
