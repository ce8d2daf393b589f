"""The primary endpoints of two seed sets of one plan, side by side (issue 31).

    .venv/bin/dyncatch reproduce --power --out results/power_a
    .venv/bin/dyncatch reproduce --power --first-seed 30 --out results/power_b
    .venv/bin/python benchmarks/replication.py results/power_a results/power_b

Prints the tables of ``dyncatch.reproduce.replication`` (each set's primary endpoints side
by side, then both sets' seeds pooled) and writes them as ``replication.md``/``.json``
beside the second folder's report.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dyncatch.reproduce.replication import compare, pooled, pooled_markdown, replication_markdown
from dyncatch.utils.files import read_json


def run(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("first", type=Path, help="the first seed set's reproduction folder")
    ap.add_argument("second", type=Path, help="the second seed set's reproduction folder")
    args = ap.parse_args(argv)
    try:
        a = read_json(args.first / "results.json", "run the reproduction to its end first")
        b = read_json(args.second / "results.json", "run the reproduction to its end first")
        rows = compare(a, b)
        both = pooled(a, b)
    except (ValueError, OSError) as e:
        print(f"error: {e}")
        return 2
    table = (
        "Each seed set on its own:\n\n" + replication_markdown(rows) + "\n\n"
        "Both seed sets pooled:\n\n" + pooled_markdown(both)
    )
    record = {"replication": rows, "pooled": both}
    (args.second / "replication.json").write_text(json.dumps(record, indent=2) + "\n")
    (args.second / "replication.md").write_text(table + "\n")
    print(table)
    return 0


if __name__ == "__main__":
    raise SystemExit(run())
