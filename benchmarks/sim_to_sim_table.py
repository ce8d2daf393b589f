"""The sim-to-sim table of docs/fullbody.md from ``dyncatch eval --json`` outputs.

``python benchmarks/sim_to_sim_table.py FILE.json ...``: each file is what one
``dyncatch eval ... --json`` printed (its rows), with the wall time of that command in a
``"wall_s"`` key if the runner added one. Rows are paired by (method, speed) across the
``jax`` and ``mujoco`` backends; for each pair the table gives both success rates with their
Wilson 95 % intervals, both mean catch times (failures count as the episode limit), the full
body's fall rate and the share of its episodes with an arm joint over its speed or torque
limit after a physics step (``arm_over_limit``; "-" in cells run before it was measured), the
catch-time ratio (full body over reduced-order), and the gap (reduced-order minus full
body) with Newcombe's hybrid-score 95 % interval for a difference of two proportions (from
the two Wilson intervals; it ignores the pairing of episodes, so it is conservative when
outcomes correlate).
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path


def newcombe_ci95(p1: float, ci1, p2: float, ci2) -> tuple[float, float]:
    """95 % interval of ``p1 - p2`` from each proportion's Wilson interval (Newcombe 1998,
    method 10)."""
    (l1, u1), (l2, u2) = ci1, ci2
    d = p1 - p2
    return (
        d - math.sqrt((p1 - l1) ** 2 + (u2 - p2) ** 2),
        d + math.sqrt((u1 - p1) ** 2 + (p2 - l2) ** 2),
    )


def table(paths: list[str]) -> list[dict]:
    cells: dict[tuple, dict] = {}
    for path in paths:
        out = json.loads(Path(path).read_text())
        n_rows = len(out["rows"])
        for row in out["rows"]:
            key = (row["method"], row["speed_mps"])
            row = dict(row, wall_s=out.get("wall_s", float("nan")) / n_rows)
            cells.setdefault(key, {})[row["backend"]] = row
    rows = []
    for (method, speed), by in sorted(cells.items()):
        if not {"jax", "mujoco"} <= by.keys():
            continue
        j, m = by["jax"], by["mujoco"]
        lo, hi = newcombe_ci95(
            j["success_rate"], j["success_ci95"], m["success_rate"], m["success_ci95"]
        )
        rows.append(
            {
                "method": method,
                "speed_mps": speed,
                "episodes": (j["episodes"], m["episodes"]),
                "jax": (j["success_rate"], *j["success_ci95"], j["catch_time_s"]),
                "mujoco": (m["success_rate"], *m["success_ci95"], m["catch_time_s"]),
                "fell_rate": m.get("fell_rate"),
                "arm_over_limit_rate": m.get("arm_over_limit_rate"),
                "time_ratio": m["catch_time_s"] / j["catch_time_s"],
                "gap": (j["success_rate"] - m["success_rate"], lo, hi),
                "wall_s": (j["wall_s"], m["wall_s"]),
            }
        )
    return rows


def markdown(rows: list[dict]) -> str:
    lines = [
        "| method | speed (m/s) | episodes | JAX success [95 % CI] | JAX catch time (s) "
        "| full-body success [95 % CI] | full-body catch time (s) | time ratio | fell "
        "| arm over limit | gap [95 % CI] | wall s (JAX, full body) |",
        "|---|---:|---:|---|---:|---|---:|---:|---:|---:|---|---:|",
    ]
    for r in rows:
        j, m, g = r["jax"], r["mujoco"], r["gap"]
        over = r["arm_over_limit_rate"]
        over = "-" if over is None else f"{over:.3f}"
        lines.append(
            f"| {r['method']} | {r['speed_mps']:.1f} | {r['episodes'][1]} "
            f"| {j[0]:.3f} [{j[1]:.3f}, {j[2]:.3f}] | {j[3]:.2f} "
            f"| {m[0]:.3f} [{m[1]:.3f}, {m[2]:.3f}] | {m[3]:.2f} | {r['time_ratio']:.2f} "
            f"| {r['fell_rate']:.3f} | {over} "
            f"| {g[0]:+.3f} [{g[1]:+.3f}, {g[2]:+.3f}] "
            f"| {r['wall_s'][0]:.0f}, {r['wall_s'][1]:.0f} |"
        )
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown(table(sys.argv[1:])))
