"""What the cached studies (``network_size_study.py``, ``parity_study.py``) share: their
command line and how they write their summary."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dyncatch.cli.main import main, parse
from dyncatch.reproduce.stages import estimate_s


def study_parser(description: str, name: str) -> argparse.ArgumentParser:
    """The studies' common flags; ``name`` names the default folders."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--out", type=Path, default=Path("results") / name)
    ap.add_argument("--summary-dir", type=Path, default=Path("benchmarks/results") / name)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--train-steps", type=int, default=4_000_000)
    ap.add_argument("--episodes", type=int, default=300)
    ap.add_argument("--dry-run", action="store_true")
    ap.add_argument("--summarize-only", action="store_true")
    return ap


def write_summary(summary_dir: Path, result: dict, lines: list[str]) -> None:
    """``summary.json`` (``result``) and ``summary.md`` (``lines``) in ``summary_dir``."""
    summary_dir.mkdir(parents=True, exist_ok=True)
    (summary_dir / "summary.json").write_text(json.dumps(result, indent=2) + "\n")
    (summary_dir / "summary.md").write_text("\n".join(lines) + "\n")


def run_study(args, argvs: list[list[str]], summarize, before=None) -> int:
    """Run each ``dyncatch`` command of ``argvs`` in order (cached: a re-run resumes),
    printing it and its estimate, and ``summarize(args)`` after each and at the end;
    ``before(argv)``, if given, runs first for each command that runs;
    ``--dry-run`` only prints, ``--summarize-only`` only summarises."""
    total = 0.0
    for cmd in () if args.summarize_only else argvs:
        print(" ".join(cmd))
        total += estimate_s(parse(cmd)[1])
        if not args.dry_run:
            if before is not None:
                before(cmd)
            if main(cmd) != 0:
                return 2
            summarize(args)
    print(f"estimated {total / 3600:.2f} h on 2 cores")
    if not args.dry_run:
        summarize(args)
        print((args.summary_dir / "summary.md").read_text())
    return 0
