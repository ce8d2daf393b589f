"""Table II's row for learned evaders (issue 34): the vanilla and the self-aware predictor's
error ||v_hat - v|| (m/s) on reactive targets and on trained evaders.

    .venv/bin/python benchmarks/evader_predictors.py --out /work/studies/evader_predictors \\
        --evaders-dir /work/studies/evader_runs

One ``dyncatch predictor table`` per target and seed (both kinds trained on the same data, at
one budget, Table II's largest: 2 M interaction steps): the reactive target (eq. 11-12) and
each evader of ``--evaders`` (a run folder of ``dyncatch evader train`` under
``--evaders-dir``, run as ``--behavior learned``). Every target runs in the same world: the
evaders' training world (``rl.evader_train.EVADER_WORLD``: the default world with the speed
cap drawn per episode in [1.4, 1.8] m/s; ``--speed-min-mps``/``--speed-max-mps``), so the
reactive row is the comparison at the evaders' speeds, not Table II's standard row (caps in
[0, 1.8]). ``--sample`` runs the evaders sampling their turns (``--world.target.evader-sample``;
only evaders whose file records the action std: of ``EVADERS``, the three ``_s0`` ones).

Cached and resumable: a cell is a folder ``OUT/{target}/seed{s}`` holding the table's files
and ``argv.json`` (the command that made it), written last; a re-run skips finished cells and
refuses a cell made by another command, naming both. Seeds run in the outer loop, so an
interrupted study has every target at its first seeds. ``summary.json`` and ``summary.md``
(in ``--summary-dir``) carry per target and kind the mean error over seeds with a 95 %
t-interval (``evaluation.intervals.mean_ci``; none with one seed) and the paired
vanilla - self-aware difference (same data per seed).
"""

from __future__ import annotations

import argparse
import csv
import json
import time
from pathlib import Path

import numpy as np
from study_io import write_summary

from dyncatch.cli.main import main
from dyncatch.evaluation.intervals import mean_ci
from dyncatch.rl.evader_train import EVADER_WORLD

EVADERS = (
    "evader_pursuit_5m_s0",
    "evader_pursuit_5m_s1",
    "evader_pursuit_5m_s2",
    "evader_intercept_5m_s0",
    "evader_pursuit_intercept_5m_s0",
)
REACTIVE = "reactive"
KINDS = ("vanilla", "self_aware")
BUDGET = 2_000_000
"""Table II's largest budget and ``dyncatch predictor train``'s default."""
DONE = "argv.json"


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", type=Path, default=Path("results/evader_predictors"))
    ap.add_argument(
        "--summary-dir", type=Path, default=Path("benchmarks/results/evader_predictors")
    )
    ap.add_argument("--evaders-dir", type=Path, default=Path("runs"))
    ap.add_argument("--evaders", nargs="+", default=list(EVADERS))
    ap.add_argument("--seeds", type=int, default=2, help="predictor seeds per target")
    ap.add_argument("--budget", type=int, default=BUDGET, help="interaction steps")
    ap.add_argument("--eval-steps", type=int, default=500_000, help="held-out steps")
    ap.add_argument("--speed-min-mps", type=float, default=EVADER_WORLD.target.speed_min_mps)
    ap.add_argument("--speed-max-mps", type=float, default=EVADER_WORLD.target.speed_max_mps)
    ap.add_argument("--sample", action="store_true", help="evaders sample their turns")
    ap.add_argument("--dry-run", action="store_true")
    ap.add_argument("--summarize-only", action="store_true")
    return ap


def targets(args) -> list[str]:
    return [REACTIVE, *args.evaders]


def cell_dir(args, target: str, seed: int) -> Path:
    return args.out / target / f"seed{seed}"


def cell_argv(args, target: str, seed: int) -> list[str]:
    behavior = REACTIVE if target == REACTIVE else "learned"
    argv = ["predictor", "table", "--json", "--behaviors", behavior, "--kinds", *KINDS]
    argv += ["--budgets", str(args.budget), "--eval-steps", str(args.eval_steps)]
    argv += ["--seed", str(seed), "--out", str(cell_dir(args, target, seed))]
    argv += ["--world.target.speed-min-mps", str(args.speed_min_mps)]
    argv += ["--world.target.speed-max-mps", str(args.speed_max_mps)]
    if target != REACTIVE:
        evader = (args.evaders_dir / target).resolve()
        argv += ["--world.target.evader-checkpoint", str(evader)]
        if args.sample:
            argv += ["--world.target.evader-sample"]
    return argv


def finished(args, target: str, seed: int, argv: list[str]) -> bool:
    """True for a cell made by ``argv``; False for none; SystemExit for another command's."""
    done = cell_dir(args, target, seed) / DONE
    if not done.is_file():
        return False
    old = json.loads(done.read_text())["argv"]
    if old != argv:
        raise SystemExit(
            f"{done.parent} was made by another command:\n  {' '.join(old)}\nnot\n  "
            f"{' '.join(argv)}\nuse another --out or remove that folder"
        )
    return True


def run_cell(args, target: str, seed: int, argv: list[str]) -> None:
    t0 = time.perf_counter()
    if main(argv) != 0:
        raise SystemExit(f"failed: dyncatch {' '.join(argv)}")
    record = {"argv": argv, "wall_s": time.perf_counter() - t0}
    (cell_dir(args, target, seed) / DONE).write_text(json.dumps(record, indent=2) + "\n")


def read_cell(args, target: str, seed: int) -> dict | None:
    """``{kind: row}`` of a finished cell, with its wall time."""
    folder = cell_dir(args, target, seed)
    if not (folder / DONE).is_file():
        return None
    with (folder / "table_ii.csv").open() as f:
        rows = {r["kind"]: r for r in csv.DictReader(f)}
    rows["wall_s"] = json.loads((folder / DONE).read_text())["wall_s"]
    return rows


def _ci(values: list[float]) -> dict:
    mean, ci = mean_ci(values)
    return {"mean": mean, "ci95": None if ci is None else list(ci), "per_seed": values}


def _fmt(c: dict) -> str:
    if c["ci95"] is None:
        return f"{c['mean']:.3f}"
    lo, hi = c["ci95"]
    return f"{c['mean']:.3f} [{lo:.3f}, {hi:.3f}]"


def summarize(args) -> dict:
    rows, walls = [], []
    for target in targets(args):
        cells = [c for s in range(args.seeds) if (c := read_cell(args, target, s)) is not None]
        if not cells:
            continue
        walls += [c["wall_s"] for c in cells]
        errors = {k: [float(c[k]["error_mps"]) for c in cells] for k in KINDS}
        gap = [v - s for v, s in zip(errors["vanilla"], errors["self_aware"], strict=True)]
        rows.append(
            {
                "target": target,
                "seeds": len(cells),
                **{k: _ci(errors[k]) for k in KINDS},
                "vanilla_minus_self_aware": _ci(gap),
                "train_samples": [int(c["self_aware"]["train_samples"]) for c in cells],
                "eval_samples": [int(c["self_aware"]["eval_samples"]) for c in cells],
                "behavior_params": json.loads(cells[0]["self_aware"]["behavior_params"]),
            }
        )
    result = {
        "budget_steps": args.budget,
        "eval_steps": args.eval_steps,
        "speed_cap_mps": [args.speed_min_mps, args.speed_max_mps],
        "evader_sample": args.sample,
        "cell_wall_s": walls,
        "rows": rows,
    }
    lines = [
        f"Error ||v_hat - v||_2 (m/s) at {args.budget / 1e6:g} M interaction steps, held-out "
        f"{args.eval_steps / 1e6:g} M steps; speed caps U({args.speed_min_mps:g}, "
        f"{args.speed_max_mps:g}) m/s; evaders {'sampled' if args.sample else 'deterministic'}."
        " Mean over predictor seeds [95 % t-interval].",
        "",
        "| target | seeds | vanilla | self_aware | vanilla - self_aware | samples: train, eval |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        cols = [_fmt(r[k]) for k in (*KINDS, "vanilla_minus_self_aware")]
        samples = f"{np.mean(r['train_samples']):.0f}, {np.mean(r['eval_samples']):.0f}"
        lines.append(f"| {r['target']} | {r['seeds']} | {' | '.join(cols)} | {samples} |")
    if walls:
        lines += ["", f"Wall time per cell: {min(walls):.0f}-{max(walls):.0f} s."]
    write_summary(args.summary_dir, result, lines)
    return result


def run(args) -> int:
    for seed in () if args.summarize_only else range(args.seeds):
        for target in targets(args):
            argv = cell_argv(args, target, seed)
            if finished(args, target, seed, argv):
                continue
            print("dyncatch " + " ".join(argv), flush=True)
            if not args.dry_run:
                run_cell(args, target, seed, argv)
                summarize(args)
    if not args.dry_run:
        summarize(args)
        print((args.summary_dir / "summary.md").read_text())
    return 0


if __name__ == "__main__":
    raise SystemExit(run(parser().parse_args()))
