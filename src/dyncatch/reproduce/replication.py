"""The primary endpoints of two independent seed sets of one plan, side by side.

A verdict holds only if a second seed set gives it again: run the plan twice into two
folders, the second with ``--first-seed`` past the first's seeds (``--seeds 10`` and
``--seeds 10 --first-seed 10``), then ``python benchmarks/replication.py A B``. Two sets
agree on an endpoint when both give the same resolution (``resolved``, ``equivalent within
the margin`` or ``unresolved``) and, where resolved, the same direction.

``pooled`` judges each ordering endpoint once more on the seeds of every set together (a seed
is a seed, whichever run trained it): the interval a target half-width is read against when
one set's seeds are too few for it. ``merged`` makes one set of several runs of one plan on
disjoint seeds (a seed set trained in parts), to be compared as one.

Plans must be equal but for their seeds and ``ROUNDING_ONLY``: fields that change results
by float rounding alone, which a replication may differ in (and says so). One set may also
be a part of the other's plan (``dyncatch reproduce --part``, ``reproduce.parts``): the same
plan kept to one trained behaviour, compared and pooled on that behaviour's endpoints.
"""

from __future__ import annotations

from dyncatch.reproduce.aggregate import gap, judge_family
from dyncatch.reproduce.endpoints import Endpoint
from dyncatch.reproduce.layout import plans_differ
from dyncatch.reproduce.parts import part_plan
from dyncatch.reproduce.plan import ROUNDING_ONLY, Plan
from dyncatch.utils.config_io import from_dict


def _key(row: dict) -> tuple:
    return (row["endpoint"], row["behavior"], row["speed_mps"])


def _outcome(row: dict) -> str:
    return row["resolution"] + (f" ({row['verdict']})" if row["resolution"] == "resolved" else "")


def _plan_and_seeds(results: dict) -> tuple[dict, set[int]]:
    """The plan without its seeds and ``ROUNDING_ONLY`` fields, and its seeds (a merged
    set lists them, ``seed_list``)."""
    plan = dict(results["plan"])
    first, n = plan.pop("first_seed", 0), plan.pop("seeds")
    listed = plan.pop("seed_list", None)
    for k in ROUNDING_ONLY:
        plan.pop(k, None)
    return plan, set(listed) if listed is not None else set(range(first, first + n))


def _seeds(results: dict) -> str:
    """The seeds as a range, ``0-29``; a merged set's as its parts', ``30-44 + 45-59``."""
    if "merged_from" in results:
        return " + ".join(results["merged_from"])
    seeds = _plan_and_seeds(results)[1]
    return f"{min(seeds)}-{max(seeds)}"


def _seeds_for(results: dict, key: tuple) -> str:
    """The seeds that measured one endpoint (``_key``): a merged set's parts that did
    (a behaviour's part measures that behaviour's alone), else ``_seeds``."""
    if "merged_from" in results:
        for row in results["primary_endpoints"]["measured"]:
            if _key(row) == key and "sets" in row:
                return " + ".join(row["sets"])
    return _seeds(results)


def rounding_only_differences(a: dict, b: dict) -> list[str]:
    """The ``ROUNDING_ONLY`` fields in which two plans differ (``field: a/b``)."""
    return [
        f"{k}: {a['plan'].get(k)}/{b['plan'].get(k)}"
        for k in ROUNDING_ONLY
        if a["plan"].get(k) != b["plan"].get(k)
    ]


def _is_part(whole: dict, part: dict) -> bool:
    """Whether the plan record ``part`` is one part of the plan record ``whole``
    (``parts.part_plan``), both as ``_plan_and_seeds`` leaves them."""
    try:
        plan = from_dict(Plan, whole)
    except (TypeError, ValueError, KeyError):
        return False
    return any(
        not plans_differ(_plan_and_seeds({"plan": part_plan(plan, b).to_json()})[0], part)
        for b in plan.behaviors
    )


def compare(a: dict, b: dict) -> list[dict]:
    """One row per primary endpoint measured by both ``results.json`` contents: each set's
    difference, interval and outcome, and whether they agree. Refuses two runs of different
    plans (unless one is a part of the other's) or of overlapping seeds, which would not be
    a replication."""
    (pa, seeds_a), (pb, seeds_b) = _plan_and_seeds(a), _plan_and_seeds(b)
    if plans_differ(pa, pb) and not (_is_part(pa, pb) or _is_part(pb, pa)):
        differ = sorted({k.split(".")[0] for k in plans_differ(pa, pb)})
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
                "sets": [_seeds_for(a, _key(ra)), _seeds_for(b, _key(ra))],
                "difference": [ra["difference"], rb["difference"]],
                "ci95": [ra["ci95"], rb["ci95"]],
                "outcome": [_outcome(ra), _outcome(rb)],
                "agree": _outcome(ra) == _outcome(rb),
                "rounding_only_differences": rounding_only_differences(a, b),
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


def _check_sets(sets: tuple[dict, ...]) -> None:
    if len(sets) < 2:
        raise ValueError("pooling needs at least two seed sets")
    for i, a in enumerate(sets):
        for b in sets[i + 1 :]:
            compare(a, b)


def _pooled_rows(sets: tuple[dict, ...], in_every_set: bool) -> list[dict]:
    """Each primary ordering endpoint judged on the seeds of ``sets`` together; with
    ``in_every_set``, only those every set measured (a part measures its behaviour's
    alone), else those any set did (the parts of one set)."""
    cells = [c for r in sets for c in r["table_i"]["cells"]]
    endpoints = [Endpoint.from_json(e) for e in sets[0]["plan"]["primary_endpoints"]]
    out = []
    for e in endpoints:
        if e.claim is None:
            continue
        if in_every_set and any(
            _merged_cell(r["table_i"]["cells"], m, e.behavior, e.speed_mps) is None
            for r in sets
            for m in e.claim
        ):
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
        key = (row["endpoint"], e.behavior, e.speed_mps)
        row["sets"] = [
            _seeds_for(r, key)
            for r in sets
            if all(
                _merged_cell(r["table_i"]["cells"], m, e.behavior, e.speed_mps) is not None
                for m in e.claim
            )
        ]
        out.append(row)
    return out


def pooled(*sets: dict) -> list[dict]:
    """Each primary ordering endpoint that every set measured, judged on the seeds of all
    of them together (``compare`` checks first that each two are one plan, or a part of it,
    on disjoint seeds). A headroom endpoint is left out: its rival, the best non-oracle
    method, is chosen per run."""
    _check_sets(sets)
    return _pooled_rows(sets, in_every_set=True)


def merged(*parts: dict) -> dict:
    """One seed set of several runs of one plan on disjoint seeds (a set trained in seed
    ranges, each ``--seeds k --first-seed s``; behaviour parts, ``--part``, are merged by
    ``dyncatch reproduce --merge-parts`` first): its plan lists the seeds, its Table I cells hold
    every part's seeds and its primary endpoints are judged on them (as ``pooled``), so
    ``compare`` and ``pooled`` read it as one set. Each part trained its own predictors
    (seeded with its first seed), where one run trains one: say so where it is reported."""
    _check_sets(parts)
    seeds = sorted(s for r in parts for s in _plan_and_seeds(r)[1])
    plan = {**parts[0]["plan"], "seeds": len(seeds), "first_seed": seeds[0], "seed_list": seeds}
    return {
        "plan": plan,
        "merged_from": [_seeds(r) for r in parts],
        "table_i": {"cells": [c for r in parts for c in r["table_i"]["cells"]]},
        "primary_endpoints": {"measured": _pooled_rows(parts, in_every_set=False)},
    }


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
