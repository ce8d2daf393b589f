"""The primary endpoints of two independent seed sets of one plan, side by side.

A verdict holds only if a second seed set gives it again: run the plan twice into two
folders, the second with ``--first-seed`` past the first's seeds (``--seeds 10`` and
``--seeds 10 --first-seed 10``), then ``python benchmarks/replication.py A B``. Two sets
agree on an endpoint when both give the same resolution (``resolved``, ``equivalent within
the margin`` or ``unresolved``) and, where resolved, the same direction.
"""

from __future__ import annotations


def _key(row: dict) -> tuple:
    return (row["endpoint"], row["behavior"], row["speed_mps"])


def _outcome(row: dict) -> str:
    return row["resolution"] + (f" ({row['verdict']})" if row["resolution"] == "resolved" else "")


def _plan_and_seeds(results: dict) -> tuple[dict, set[int]]:
    """The plan without its seeds, and its seeds."""
    plan = dict(results["plan"])
    first, n = plan.pop("first_seed", 0), plan.pop("seeds")
    return plan, set(range(first, first + n))


def _seeds(results: dict) -> str:
    seeds = _plan_and_seeds(results)[1]
    return f"{min(seeds)}-{max(seeds)}"


def compare(a: dict, b: dict) -> list[dict]:
    """One row per primary endpoint measured by both ``results.json`` contents: each set's
    difference, interval and outcome, and whether they agree. Refuses two runs of different
    plans or of overlapping seeds, which would not be a replication."""
    (pa, seeds_a), (pb, seeds_b) = _plan_and_seeds(a), _plan_and_seeds(b)
    if pa != pb:
        differ = sorted(k for k in pa.keys() | pb.keys() if pa.get(k) != pb.get(k))
        raise ValueError(f"the two runs have different plans ({', '.join(differ[:4])}): "
                         "a replication repeats one plan with other seeds")  # fmt: skip
    if seeds_a & seeds_b:
        raise ValueError(
            f"the two runs share seeds {sorted(seeds_a & seeds_b)}: give the second "
            "--first-seed past the first's seeds"
        )
    rows_b = {_key(r): r for r in b["primary_endpoints"]["measured"]}
    out = []
    for ra in a["primary_endpoints"]["measured"]:
        rb = rows_b.get(_key(ra))
        if rb is None:
            continue
        out.append(
            {
                "endpoint": ra["endpoint"],
                "claim": ra["claim"],
                "behavior": ra["behavior"],
                "speed_mps": ra["speed_mps"],
                "sets": [_seeds(a), _seeds(b)],
                "difference": [ra["difference"], rb["difference"]],
                "ci95": [ra["ci95"], rb["ci95"]],
                "outcome": [_outcome(ra), _outcome(rb)],
                "agree": _outcome(ra) == _outcome(rb),
            }
        )
    return out


def replication_markdown(rows: list[dict]) -> str:
    lines = [
        "| endpoint | seeds | difference [95 % CI] | outcome | seeds | difference [95 % CI] "
        "| outcome | agree |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        cells = []
        for i in range(2):
            lo, hi = r["ci95"][i]
            cells += [r["sets"][i], f"{r['difference'][i]:+.3f} [{lo:+.3f}, {hi:+.3f}]",
                      r["outcome"][i]]  # fmt: skip
        name = f"{r['endpoint']} ({r['claim']}, {r['behavior']}, {r['speed_mps']:g} m/s)"
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {'yes' if r['agree'] else 'no'} |")
    return "\n".join(lines)
