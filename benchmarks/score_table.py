"""The rows of ``dyncatch predictor score`` (one JSON object a line) as a Markdown matrix:
one row per predictor (the target it was trained on, its kind), one column per target
scored, the error ||v_hat - v|| in m/s; a learned evader is named by its run folder, a
league by its members (``league(reactive+ev_a+ev_b)``).

    .venv/bin/python benchmarks/score_table.py ROWS.jsonl [...] [--out TABLE.md]
"""

from __future__ import annotations

import argparse
import json
import os
from pathlib import Path


def _folder(path: str) -> str:
    return os.path.basename(os.path.normpath(path))


def target_name(behavior: str, params: dict) -> str:
    """A target's name: its behaviour, a learned evader's run folder, or a league's
    members (scripted first, then evaders by folder)."""
    params = params or {}
    if "league_evaders" in params:
        members = [*params.get("league_behaviors", []), *map(_folder, params["league_evaders"])]
        return f"league({'+'.join(members)})"
    evader = params.get("evader_checkpoint")
    return _folder(evader) if evader else behavior


def matrix(rows: list[dict]) -> str:
    """The Markdown table of ``rows``; a cell scored twice is refused."""
    cols: list[str] = []
    preds: list[tuple[str, str]] = []
    cells: dict[tuple[str, str, str], float] = {}
    samples: dict[str, int] = {}
    for r in rows:
        col = target_name(r["behavior"], r["behavior_params"])
        pred = (target_name(r["trained_on"], r["trained_on_params"]), r["kind"])
        if (*pred, col) in cells:
            raise ValueError(f"{pred} is scored on {col} twice: give each cell once")
        cols += [col] if col not in cols else []
        preds += [pred] if pred not in preds else []
        cells[(*pred, col)] = r["error_mps"]
        samples[col] = r["eval_samples"]
    lines = [
        "| trained on | kind | " + " | ".join(cols) + " |",
        "|---|---|" + "---:|" * len(cols),
    ]
    for t, k in preds:
        row = []
        for c in cols:
            e = cells.get((t, k, c))
            cell = "-" if e is None else f"{e:.3f}"
            row.append(f"**{cell}**" if c == t else cell)
        lines.append(f"| {t} | {k} | " + " | ".join(row) + " |")
    lines.append("")
    lines.append("Held-out samples: " + ", ".join(f"{c} {samples[c]}" for c in cols) + ".")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", nargs="+", type=Path, help="files of predictor score's rows")
    ap.add_argument("--out", type=Path, help="also write the table here")
    args = ap.parse_args(argv)
    rows = [json.loads(line) for p in args.rows for line in p.read_text().splitlines() if line]
    text = matrix(rows)
    print(text, end="")
    if args.out:
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
