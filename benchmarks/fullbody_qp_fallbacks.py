"""How often the convex MPC's QP gives up, episode by episode, and whether that comes before
a fall (docs/fullbody.md, "Sim-to-sim with a trained policy").

``python benchmarks/fullbody_qp_fallbacks.py [fullbody_falls.py's flags] --workers 1``
plays ``fullbody_falls.py``'s episodes (its flags, its JSON's ``falls``) and counts, per
200 Hz control period, the stance solves where ProxSuite did not converge and
``mpc.mpc_stance_forces`` fell back to the least-squares stance (``stance.stance_forces``).
Prints one JSON object: the fallback share of control periods over all episodes, over the
last 0.5 s of the episodes that fell and of those that did not, and each episode's counts.
A diagnostic: it wraps the fallback in this process, so it needs ``--workers 1``.
"""

from __future__ import annotations

import contextlib
import io
import json
from collections import defaultdict

import fullbody_falls as falls
import numpy as np
import tyro

from dyncatch.fullbody import mpc
from dyncatch.utils.jax_setup import setup_jax

LAST_S = 0.5
"""The window before an episode's end (a fall ends it) whose fallbacks are counted apart."""


def main(cmd: falls.FallsCmd) -> dict:
    if cmd.workers != 1:
        raise SystemExit("--workers 1: the count is kept in this process")
    calls = {"fallbacks": 0, "seen": 0}
    per: dict[int, list] = defaultdict(list)
    least_squares, probe_call = mpc.stance_forces, falls.Probe.__call__

    def counted(*args, **kwargs):
        calls["fallbacks"] += 1
        return least_squares(*args, **kwargs)

    def call(self, i, env, goal):
        # The probe runs after each body's control period: the fallbacks since the last
        # probe are this period's.
        per[i].append((env.time_s, calls["fallbacks"] - calls["seen"]))
        calls["seen"] = calls["fallbacks"]
        return probe_call(self, i, env, goal)

    mpc.stance_forces, falls.Probe.__call__ = counted, call
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # falls.main prints its own result
            result = falls.main(cmd)
    finally:
        mpc.stance_forces, falls.Probe.__call__ = least_squares, probe_call
    fell = {f["episode"] for f in result["falls"]}
    rows, last = [], {True: [0, 0], False: [0, 0]}
    for i in sorted(per):
        t, n = np.array(per[i], float).T
        end = t > t[-1] - LAST_S
        last[i in fell][0] += int(n[end].sum())
        last[i in fell][1] += int(end.sum())
        rows.append({"episode": i, "fell": i in fell, "periods": len(t),
                     "fallbacks": int(n.sum()), "fallbacks_last_s": int(n[end].sum())})  # fmt: skip
    total = sum(r["fallbacks"] for r in rows), sum(r["periods"] for r in rows)
    return {
        "episodes": len(rows),
        "fell": len(fell),
        "fallback_share": round(total[0] / total[1], 4),
        "fallback_share_last_s": {
            "fell": round(last[True][0] / last[True][1], 4) if last[True][1] else None,
            "stayed_up": round(last[False][0] / last[False][1], 4) if last[False][1] else None,
        },
        "last_s": LAST_S,
        "per_episode": rows,
        "falls": result["falls"],
    }


if __name__ == "__main__":
    setup_jax()
    print(json.dumps(main(tyro.cli(falls.FallsCmd))))
