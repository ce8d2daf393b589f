"""The swing-stiffness table of docs/fullbody.md ("The trot's envelope") from
``benchmarks/fullbody_falls.py`` outputs.

``python benchmarks/swing_table.py DIR``: DIR holds ``fullbody_falls.py``'s JSON (its last
line) as ``{name}_kp{K}.json``, one per swing stiffness K (``GaitCfg.swing_kp_nm_per_rad``)
of the same episodes (``--eval-key``), and, optionally, ``dyncatch eval --backend jax
--json``'s output for the same run as ``jax_{name without the method}.json`` (e.g.
``sprl_s0_1.6_kp150.json`` beside ``jax_s0_1.6.json``). Per cell: success with its Wilson
95 % interval, the mean catch time with failures at the episode limit, falls, episodes with
an arm joint over its limit after a physics step; and per name, the difference of each
stiffness from the first (paired over episodes: the mean of the per-episode differences in
success and catch time with their t-intervals, ``scipy.stats.ttest_rel``).
"""

from __future__ import annotations

import json
import re
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np
from scipy import stats

from dyncatch.evaluation.stats import wilson_ci95

NAME = re.compile(r"(?P<name>.+)_kp(?P<kp>[0-9.]+)\.json$")


def cells(folder: Path) -> dict[str, dict[float, dict]]:
    found: dict[str, dict[float, dict]] = defaultdict(dict)
    for path in sorted(folder.glob("*_kp*.json")):
        m = NAME.match(path.name)
        if m:
            found[m["name"]][float(m["kp"])] = json.loads(path.read_text())
    return dict(found)


def _paired(a: np.ndarray, b: np.ndarray) -> str:
    if np.all(a == b):
        return f"{0.0:+.3f} (identical)"
    ci = stats.ttest_rel(b, a).confidence_interval(0.95)
    return f"{np.mean(b - a):+.3f} [{ci.low:+.3f}, {ci.high:+.3f}]"


def jax_row(folder: Path, name: str) -> str:
    path = folder / ("jax_" + name.split("_", 1)[1] + ".json") if "_" in name else None
    if path is None or not path.exists():
        return "-"
    row = json.loads(path.read_text())["rows"][0]
    return f"{row['success_rate']:.3f}, {row['catch_time_s']:.2f} s"


def table(folder: Path) -> str:
    lines = [
        "| episodes | swing kp (N m/rad) | success [95 % CI] | catch time (s) | fell | "
        "arm over limit | success, paired difference from the first kp [95 % CI] | "
        "catch time, paired difference (s) | JAX success, catch time |",
        "|---|---:|---|---:|---:|---:|---|---|---|",
    ]
    for name, by_kp in cells(folder).items():
        kps = sorted(by_kp)
        per = {k: by_kp[k]["per_episode"] for k in kps}
        first = kps[0]
        for k in kps:
            d = by_kp[k]
            n, s = d["episodes"], d["success"]
            lo, hi = wilson_ci95(s, n)
            t = np.asarray(per[k]["catch_time_s"])
            diff_s = diff_t = "-"
            if k != first:
                diff_s = _paired(
                    np.asarray(per[first]["success"], float), np.asarray(per[k]["success"], float)
                )
                diff_t = _paired(np.asarray(per[first]["catch_time_s"]), t)
            lines.append(
                f"| {name} ({n}) | {k:g} | {s / n:.3f} [{lo:.3f}, {hi:.3f}] | {t.mean():.2f} | "
                f"{d['fell']} | {d['physics_steps']['episodes_over_limit']} | {diff_s} | "
                f"{diff_t} | "
                f"{jax_row(folder, name)} |"
            )
    return "\n".join(lines)


if __name__ == "__main__":
    print(table(Path(sys.argv[1])))
