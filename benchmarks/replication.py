"""The primary endpoints of two seed sets of one plan, side by side (issue 31).

    .venv/bin/dyncatch reproduce --power --out results/power_a
    .venv/bin/dyncatch reproduce --power --first-seed 30 --out results/power_b
    .venv/bin/python benchmarks/replication.py results/power_a results/power_b

A second set trained in seed ranges (``--seeds 15 --first-seed 30``, then ``--first-seed
45``; each range's behaviour parts merged by ``dyncatch reproduce --merge-parts`` first) is
named range by range: ``replication.py A B1 B2`` compares A with B1 and B2 merged
(``replication.merged``). Prints the tables of ``dyncatch.reproduce.replication`` (each
set's primary endpoints side by side, then both sets' seeds pooled) and writes them as
``replication.md``/``.json`` beside the last folder's report.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dyncatch.reproduce.replication import (
    compare,
    merged,
    pooled,
    pooled_markdown,
    replication_markdown,
)
from dyncatch.utils.files import read_json


def run(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("first", type=Path, help="the first seed set's reproduction folder")
    ap.add_argument(
        "second", type=Path, nargs="+", help="the second seed set's folder (or its parts')"
    )
    args = ap.parse_args(argv)
    try:
        a = read_json(args.first / "results.json", "run the reproduction to its end first")
        parts = [
            read_json(f / "results.json", "run the reproduction to its end first")
            for f in args.second
        ]
        b = parts[0] if len(parts) == 1 else merged(*parts)
        rows = compare(a, b)
        both = pooled(a, b)
    except (ValueError, OSError) as e:
        print(f"error: {e}")
        return 2
    notes = sorted({d for r in rows for d in r["rounding_only_differences"]})
    table = (
        "Each seed set on its own:\n\n" + replication_markdown(rows) + "\n\n"
        "Both seed sets pooled:\n\n" + pooled_markdown(both)
    )
    if notes:
        table += (
            "\n\nThe sets' plans differ only in fields that move results by float rounding: "
            + "; ".join(notes)
            + " (dyncatch.reproduce.plan.ROUNDING_ONLY)."
        )
    for name, r, other in (("first", a, b), ("second", b, a)):
        if len(r["plan"]["behaviors"]) < len(other["plan"]["behaviors"]):
            table += (
                f"\n\nThe {name} set ran part of the plan, behaviours "
                f"{', '.join(r['plan']['behaviors'])} (dyncatch reproduce --part): only "
                "their endpoints are compared and pooled."
            )
    if len(parts) > 1:
        table += (
            f"\n\nThe second set was trained in {len(parts)} parts, each with its own "
            "predictors (seeded with the part's first seed)."
        )
    record = {"replication": rows, "pooled": both}
    out = args.second[-1]
    (out / "replication.json").write_text(json.dumps(record, indent=2) + "\n")
    (out / "replication.md").write_text(table + "\n")
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(run())
