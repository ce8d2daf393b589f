"""The primary endpoints of two independent seed sets of one plan, side by side.

A verdict holds only if a second seed set gives it again: run the plan twice into two
folders, the second with ``--first-seed`` past the first's seeds (``--seeds 10`` and
``--seeds 10 --first-seed 10``), then ``python benchmarks/replication.py A B``. Two sets
agree on an endpoint when both give the same resolution (``resolved``, ``equivalent within
the margin`` or ``unresolved``) and, where resolved, the same direction.

``pooled`` judges each ordering endpoint once more on both sets' seeds together (a seed is
a seed, whichever run trained it): the interval a target half-width is read against when
one set's seeds are too few for it.
"""

from __future__ import annotations

from dyncatch.reproduce.aggregate import gap, judge_family
from dyncatch.reproduce.endpoints import Endpoint


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


def _merged_cell(cells: list[dict], method: str, behavior: str, speed_mps: float) -> dict | None:
    """One Table I cell with the seeds of every matching cell of ``cells``; None if none."""
    found = [
        c
        for c in cells
        if c["method"] == method and c["behavior"] == behavior
        and abs(c["speed_mps"] - speed_mps) < 1e-9
    ]  # fmt: skip
    if not found or any(len(c.get("per_seed_success") or []) < 2 for c in found):
        return None
    per_seed = [x for c in found for x in c["per_seed_success"]]
    return {
        "method": method,
        "per_seed_success": per_seed,
        "success_rate": sum(per_seed) / len(per_seed),
        "episodes": sum(c["episodes"] for c in found),
    }


def pooled(a: dict, b: dict) -> list[dict]:
    """Each primary ordering endpoint of the plan judged on the seeds of both runs
    together (``compare`` checks first that they are one plan on disjoint seeds). A
    headroom endpoint is left out: its rival, the best non-oracle method, is chosen per run."""
    compare(a, b)
    cells = a["table_i"]["cells"] + b["table_i"]["cells"]
    endpoints = [Endpoint.from_json(e) for e in a["plan"]["primary_endpoints"]]
    out = []
    for e in endpoints:
        if e.claim is None:
            continue
        winner, loser = (_merged_cell(cells, m, e.behavior, e.speed_mps) for m in e.claim)
        if winner is None or loser is None:
            continue
        check = {
            "kind": e.kind,
            "behavior": e.behavior,
            "speed_mps": e.speed_mps,
            "claim": f"{e.claim[0]} > {e.claim[1]}",
            **gap(winner, loser),
        }
        row = judge_family([check], [e])[0]
        row["sets"] = [_seeds(a), _seeds(b)]
        out.append(row)
    return out


def pooled_markdown(rows: list[dict]) -> str:
    lines = [
        "| endpoint | seeds per method | difference [95 % CI] | smallest resolvable | outcome |",
        "|---|---:|---|---:|---|",
    ]
    for r in rows:
        lo, hi = r["ci95"]
        name = f"{r['endpoint']} ({r['claim']}, {r['behavior']}, {r['speed_mps']:g} m/s)"
        lines.append(
            f"| {name} | {min(r['seeds'])} ({' + '.join(r['sets'])}) | "
            f"{r['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}] | "
            f"+-{r['smallest_resolvable_difference']:.3f} | {_outcome(r)} |"
        )
    return "\n".join(lines)


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
