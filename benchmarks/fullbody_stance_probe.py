"""Whether the stance legs give the forces the plan asks of them, episode by episode, and
whether they fall short before a fall (docs/fullbody.md, "Sim-to-sim with a trained policy").

``python benchmarks/fullbody_stance_probe.py [fullbody_falls.py's flags] --workers 1``
plays ``fullbody_falls.py``'s episodes (its flags, its JSON's ``falls``) and reads, every
200 Hz control period, the stance feet the gait planned forces for: their planned normal
force (``GaitState.forces_n``), the normal force the ground gave them (MuJoCo's contact
forces on the foot), and whether a joint of their leg ran at its motor's limit (the model's
``ctrlrange``). Prints one JSON object: over all periods, over the last 0.5 s of the episodes
that fell and over the last 0.5 s of those that stayed up, the share of stance legs with a
joint at its limit and the sums of planned and given normal force per period.
A diagnostic: it reads the gait's state in this process, so it needs ``--workers 1``.
"""

from __future__ import annotations

import contextlib
import io
import json
from collections import defaultdict

import fullbody_falls as falls
import mujoco
import numpy as np
import tyro

from dyncatch.utils.jax_setup import setup_jax

LAST_S = 0.5
"""The window before an episode's end (a fall ends it) counted apart."""
AT_LIMIT = 0.999
"""A joint's torque at or over this share of its motor's limit counts as at the limit."""


def contact_normal_n(model, data, feet: np.ndarray) -> np.ndarray:
    """(4,) the normal force the ground gives each foot body now."""
    out, wrench = np.zeros(len(feet)), np.zeros(6)
    for c in range(data.ncon):
        con = data.contact[c]
        bodies = model.geom_bodyid[con.geom1], model.geom_bodyid[con.geom2]
        for k, foot in enumerate(feet):
            if foot in bodies:
                mujoco.mj_contactForce(model, data, c, wrench)
                out[k] += wrench[0]
    return out


def window(rows: list[tuple]) -> dict:
    """The figures of ``rows`` (time, stance legs, legs at the limit, planned, given)."""
    if not rows:
        return {"periods": 0}
    _, legs, limited, planned, given = np.array(rows, float).T
    return {
        "periods": len(rows),
        "stance_legs_at_limit_share": round(float(limited.sum() / max(legs.sum(), 1)), 4),
        "planned_normal_n_mean": round(float(planned.mean()), 1),
        "given_normal_n_mean": round(float(given.mean()), 1),
    }


def main(cmd: falls.FallsCmd) -> dict:
    if cmd.workers != 1:
        raise SystemExit("--workers 1: the gait's state is read in this process")
    per: dict[int, list] = defaultdict(list)
    probe_call = falls.Probe.__call__

    def call(self, i, env, goal):
        m, d, idx = env.model, env.data, env.idx
        stance = np.asarray(env.gait.forces_stance, bool)
        limit = m.actuator_ctrlrange[idx.leg_ctrl, 1]
        at_limit = (np.abs(d.ctrl[idx.leg_ctrl]) >= AT_LIMIT * limit).reshape(4, 3).any(1)
        given = contact_normal_n(m, d, idx.foot_body)
        planned = np.asarray(env.gait.forces_n)[:, 2]
        per[i].append(
            (
                env.time_s,
                int(stance.sum()),
                int((at_limit & stance).sum()),
                float(planned[stance].sum()),
                float(given[stance].sum()),
            )
        )
        return probe_call(self, i, env, goal)

    falls.Probe.__call__ = call
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # falls.main prints its own result
            result = falls.main(cmd)
    finally:
        falls.Probe.__call__ = probe_call
    fell = {f["episode"] for f in result["falls"]}
    everything, last = [], {True: [], False: []}
    for i in sorted(per):
        rows = per[i]
        t_end = rows[-1][0]
        everything += rows
        last[i in fell] += [r for r in rows if r[0] > t_end - LAST_S]
    return {
        "episodes": len(per),
        "fell": sorted(fell),
        "all": window(everything),
        "last_s_fell": window(last[True]),
        "last_s_stayed_up": window(last[False]),
        "last_s": LAST_S,
        "falls": result["falls"],
        "wall_s": result["wall_s"],
    }


if __name__ == "__main__":
    setup_jax()
    print(json.dumps(main(tyro.cli(falls.FallsCmd))))
