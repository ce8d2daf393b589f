"""Memory against prediction under the standard setting (issue 32, items 2-3): does a
recurrent policy (``rnn_rl``, a GRU actor-critic trained by recurrent PPO) do what the
self-aware predictor does for monolithic RL?

    .venv/bin/python benchmarks/memory_study.py --out /work/studies/memory \\
        --full /work/studies/full10 [--dry-run | --summarize-only]

One cached ``dyncatch reproduce`` per behaviour (reactive, random_reactive, each with its
own predictors): ``rl``, ``sp_rl`` and ``rnn_rl``, seeds 0-9, the full profile's training
(4 M steps, 128-128-64; ``rnn_rl``'s GRU as wide as the first hidden layer) and world (the
standard setting: the paper's observation, no age of the sighting, where a memory has the
most to add), 300 episodes a cell at 1.6 and 1.8 m/s. The ``rl`` and ``sp_rl`` runs and the
predictors are the full reproduction's (``--full``: its part folders, hard-linked, never
trained twice) where that part's plan trains them alike (same world, PPO, budget, seeds and
predictor training: ``linkable``); else they are trained here. Every policy is evaluated
here, on the same evaluation episodes. Two jobs at a time on a local Ray by default
(``--workers``; the same results, docs/scaling.md).

The analysis, written down before any ``rnn_rl`` run of this study:

- **Primary**, per behaviour B in (reactive, random_reactive), success at 1.8 m/s, Welch's
  95 % interval over seeds, Holm over the four:
  P1(B) = ``rnn_rl - rl``: does memory help monolithic RL;
  P2(B) = ``sp_rl - rnn_rl``: does the explicit predictor still beat memory.
  A primary is resolved when its Holm-adjusted p is below 0.05. **Memory recovers what the
  predictor does** on B when P2's interval lies within +-``MARGIN`` (equivalence at the
  margin of issue 31's target); it **does not** when P2 is resolved and positive; else it is
  unresolved. Each primary's half-width is the smallest difference the run resolves.
- **Secondary** (descriptive): the same pairs at 1.6 m/s and on catch time, ``sp_rl - rl``,
  and the learning curves (each folder's report.md, Fig. 5).
- **Stopping rule:** 10 seeds. If a primary's half-width exceeds 0.15 a second seed set
  (``--first-seed 10``, into another ``--out``) may be run; both are then reported apart
  and pooled, whatever their direction (``--pool-with`` the first set's summary folder:
  the second set's summary adds the same analysis over both sets' seeds, each behaviour
  with every seed either set measured).
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from study_io import run_study, study_parser, write_summary

from dyncatch.cli.main import parse
from dyncatch.evaluation.intervals import holm, welch
from dyncatch.reproduce.aggregate import seed_means
from dyncatch.rl.methods import predictor_kinds

METHODS = ("rl", "sp_rl", "rnn_rl")
BEHAVIORS = ("reactive", "random_reactive")
SPEEDS = ("1.6", "1.8")
PRIMARY_SPEED_MPS = 1.8
PRIMARY_PAIRS = (("rnn_rl", "rl"), ("sp_rl", "rnn_rl"))
"""P1 and P2 of the docstring, (winner, loser): success of the first minus the second's."""
SECONDARY_PAIRS = (("rnn_rl", "rl"), ("sp_rl", "rnn_rl"), ("sp_rl", "rl"))
MARGIN = 0.10
"""The equivalence margin of P2 (issue 31's half-width target)."""
LINKED_METHODS = ("rl", "sp_rl")
"""The methods whose finished runs are taken from the full reproduction's parts."""
SHAPES_THE_RUNS = (
    "world", "ppo", "train_steps", "first_seed", "predictor_steps", "predictor_updates",
    "ground_truth", "setting", "vmap_seeds",
)  # fmt: skip
"""Plan fields that a training run or predictor depends on: equal, a part's runs are this
study's (a run also depends on its seed and method, which its folder names)."""


def study_argv(args, behavior: str) -> list[str]:
    """The ``dyncatch reproduce`` command of ``behavior``."""
    argv = ["reproduce", "--out", str(args.out / behavior), "--methods", *METHODS]
    argv += ["--seeds", str(args.seeds), "--first-seed", str(args.first_seed)]
    argv += ["--train-steps", str(args.train_steps), "--episodes", str(args.episodes)]
    argv += ["--speeds-mps", *SPEEDS, "--behaviors", behavior, "--table-i-behaviors", behavior]
    argv += ["--no-table-ii", "--transfer-behaviors", "--no-videos", "--no-fig9"]
    if args.workers > 1:
        argv += ["--executor", "ray", "--ray-workers", str(args.workers)]
    return argv


def linkable(part_plan: dict, plan: dict) -> list[str]:
    """The fields in ``SHAPES_THE_RUNS`` on which a part's recorded plan and this study's
    differ (empty: the part's runs and predictors are this study's)."""
    return [k for k in SHAPES_THE_RUNS if part_plan.get(k) != plan.get(k)]


def link_from_full(args, argv: list[str]) -> list[str]:
    """Hard-link into ``argv``'s folder the full reproduction's finished ``rl`` and ``sp_rl``
    runs of its seeds and its behaviour's predictors, if that part's plan trains them
    alike; returns the differing fields (empty when linked, or when there is no part)."""
    if args.full is None:
        return []
    out = Path(argv[argv.index("--out") + 1])
    behavior = out.name
    part = args.full / behavior
    if not (part / "plan.json").exists():
        return []
    plan = parse(argv)[1].to_json()
    differ = linkable(json.loads((part / "plan.json").read_text()), plan)
    if differ:
        print(f"not linking {part}: its plan differs in {', '.join(differ)}")
        return differ
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    sources = [part / "runs" / behavior / m / f"seed{s}" for m in LINKED_METHODS for s in seeds]
    sources = [s for s in sources if (s / "done.json").exists()]
    for kind in predictor_kinds(METHODS):
        if (part / "predictors" / f"{behavior}_{kind}" / "metrics.json").exists():
            sources.append(part / "predictors" / f"{behavior}_{kind}")
    for src in sources:
        dest = out / src.relative_to(part)
        if not dest.exists():
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copytree(src, dest, copy_function=os.link)
    return []


def _row(label: str, a, b) -> dict | None:
    if a is None or b is None or min(len(a), len(b)) < 2:
        return None
    d = welch(a, b)
    return {
        "label": label, "difference": d.difference, "ci95": list(d.ci),
        "half_width": d.half_width, "p_value": d.p_value, "seeds": [len(a), len(b)],
    }  # fmt: skip


def analyse(by_behavior: dict[str, dict]) -> dict:
    """The primary endpoints (Holm over those measured), the memory verdict per behaviour,
    and the secondary differences, from each behaviour's results.json."""

    def seeds(res: dict, method: str, speed: float, key: str = "per_seed_success"):
        return seed_means(res["table_i"]["cells"], method, speed, (res["_behavior"],), key)

    primary = []
    for b, res in by_behavior.items():
        res = {**res, "_behavior": b}
        for x, y in PRIMARY_PAIRS:
            row = _row(f"{b}: {x} - {y}", seeds(res, x, PRIMARY_SPEED_MPS),
                       seeds(res, y, PRIMARY_SPEED_MPS))  # fmt: skip
            if row is not None:
                primary.append({"behavior": b, "pair": [x, y], **row})
    # Holm over the declared family of four: an endpoint not measured yet enters at p = 1, so
    # an interim verdict is never less conservative than the final one.
    missing = len(BEHAVIORS) * len(PRIMARY_PAIRS) - len(primary)
    adjusted = holm([r["p_value"] for r in primary] + [1.0] * missing)
    for row, p in zip(primary, adjusted[: len(primary)], strict=True):
        row["p_holm"] = float(p)
        sign = "holds" if row["difference"] > 0 else "reversed"
        row["verdict"] = "unresolved" if p >= 0.05 else sign
    memory = {}
    for row in primary:
        if row["pair"] != ["sp_rl", "rnn_rl"]:
            continue
        lo, hi = row["ci95"]
        if -MARGIN < lo and hi < MARGIN:
            memory[row["behavior"]] = "recovers what the predictor does (equivalent within +-0.10)"
        elif row["verdict"] == "holds":
            memory[row["behavior"]] = "does not recover it (sp_rl - rnn_rl resolved, positive)"
        else:
            memory[row["behavior"]] = "unresolved"
    secondary = []
    measures = (("per_seed_success", "success"), ("per_seed_catch_time_s", "catch time (s)"))
    for b, res in by_behavior.items():
        res = {**res, "_behavior": b}
        for speed in (1.6, 1.8):
            for key, measure in measures:
                for x, y in SECONDARY_PAIRS:
                    a, c = seeds(res, x, speed, key), seeds(res, y, speed, key)
                    row = _row(f"{b}, {speed} m/s, {measure}: {x} - {y}", a, c)
                    if row is not None:
                        secondary.append({"behavior": b, "speed_mps": speed, "measure": measure})
                        secondary[-1].update(row)
    means = {
        b: {m: _mean(seeds({**res, "_behavior": b}, m, PRIMARY_SPEED_MPS)) for m in METHODS}
        for b, res in by_behavior.items()
    }
    return {"primary": primary, "memory": memory, "secondary": secondary, "means_1_8": means}


PER_SEED_KEYS = ("per_seed_success", "per_seed_catch_time_s")
"""The per-seed lists of a Table I cell that the analysis reads."""


def pool(first: dict, second: dict) -> dict:
    """One behaviour's results over both seed sets: each Table I cell of ``first`` with the
    per-seed lists of ``second``'s same (behaviour, method, speed) appended; a cell only one
    set has, and a baseline's (no seeds: the same episodes give the same cell), is kept as
    it is. Refuses a learned method's cell whose per-seed successes are the same in both
    (the same set given twice)."""

    def key(c: dict):
        return c["behavior"], c["method"], round(c["speed_mps"], 9)

    later = {key(c): c for c in second["table_i"]["cells"]}
    cells = []
    for c in first["table_i"]["cells"]:
        other = later.pop(key(c), None)
        if other is None or c["method"] not in METHODS:  # a baseline has no seeds to pool
            cells.append(c)
            continue
        if other["per_seed_success"] == c["per_seed_success"]:
            raise ValueError(
                f"--pool-with: the cell {key(c)} is the same in both sets; "
                "pass the first seed set's summary folder, not this one's"
            )
        cells.append({**c, **{k: list(c[k]) + list(other[k]) for k in PER_SEED_KEYS}})
    cells += list(later.values())
    return {"table_i": {"cells": cells}}


def _mean(values) -> float | None:
    return None if not values else sum(values) / len(values)


def _ci(r: dict) -> str:
    lo, hi = r["ci95"]
    return f"{r['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}]"


def _results_of(folder: Path) -> dict[str, dict]:
    """Each behaviour's results.json under ``folder`` (``folder/<behaviour>/``)."""
    by_behavior = {}
    for b in BEHAVIORS:
        path = folder / b / "results.json"
        if path.exists():
            by_behavior[b] = json.loads(path.read_text())
    return by_behavior


def _primary_lines(result: dict) -> list[str]:
    lines = [
        "| behaviour | pair | difference [95 % CI] | half-width | seeds | p (Holm) | verdict |",
        "|---|---|---|---:|---|---:|---|",
    ]
    for r in result["primary"]:
        lines.append(
            f"| {r['behavior']} | {r['pair'][0]} - {r['pair'][1]} | {_ci(r)} | "
            f"{r['half_width']:.3f} | {r['seeds'][0]} + {r['seeds'][1]} | {r['p_holm']:.3g} | "
            f"{r['verdict']} |"
        )
    lines += ["", "Memory (rnn_rl) against the self-aware predictor (sp_rl):", ""]
    lines += [f"- {b}: {v}" for b, v in result["memory"].items()]
    return lines


def pooled_analysis(first: dict[str, dict], second: dict[str, dict]) -> dict:
    """``analyse`` over both seed sets: every behaviour either set measured, with the seeds
    of both where both measured it."""
    both = {}
    for b in BEHAVIORS:
        if b in first and b in second:
            both[b] = pool(first[b], second[b])
        elif b in first or b in second:
            both[b] = first.get(b, second.get(b))
    return analyse(both)


def summarize(args) -> dict:
    by_behavior = _results_of(args.out)
    result = analyse(by_behavior)
    lines = [
        "Memory against prediction (benchmarks/memory_study.py; analysis in its docstring).",
        "",
        "Primary: success at 1.8 m/s, Welch 95 % over seeds, Holm over the four (one not yet",
        "measured enters at p = 1).",
        "",
        *_primary_lines(result),
    ]
    if args.pool_with is not None:
        first = _results_of(args.pool_with)
        if not first:
            raise SystemExit(f"--pool-with {args.pool_with}: no <behaviour>/results.json there; "
                             "pass the first seed set's summary folder")  # fmt: skip
        result["pooled"] = pooled_analysis(first, by_behavior)
        result["pooled"]["with"] = str(args.pool_with)
        lines += [
            "",
            f"Pooled with the seed set in {args.pool_with} (every seed of both sets; a",
            "behaviour this set did not run enters with the other set's seeds):",
            "",
        ]
        lines += _primary_lines(result["pooled"])
    lines += ["", "Mean success at 1.8 m/s over seeds:", ""]
    lines += ["| behaviour | " + " | ".join(METHODS) + " |", "|---|" + "---:|" * len(METHODS)]
    for b, means in result["means_1_8"].items():
        cells = ["-" if means[m] is None else f"{means[m]:.3f}" for m in METHODS]
        lines.append(f"| {b} | " + " | ".join(cells) + " |")
    lines += ["", "Secondary (descriptive):", "", "| difference | [95 % CI] | half-width |",
              "|---|---|---:|"]  # fmt: skip
    lines += [f"| {r['label']} | {_ci(r)} | {r['half_width']:.3f} |" for r in result["secondary"]]
    missing = [b for b in BEHAVIORS if b not in by_behavior]
    if missing:
        lines += ["", f"Still to run: {', '.join(missing)}."]
    write_summary(args.summary_dir, result, lines)
    return result


def parser():
    ap = study_parser(__doc__.splitlines()[0], "memory")
    ap.set_defaults(seeds=10)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--full", type=Path, default=None,
                    help="the full reproduction's part folders (FULL/reactive, ...)")  # fmt: skip
    ap.add_argument("--behaviors", nargs="+", choices=BEHAVIORS, default=list(BEHAVIORS),
                    help="these halves only (run each after its full part)")  # fmt: skip
    ap.add_argument("--workers", type=int, default=2,
                    help="jobs at a time on a local Ray (1: this process)")  # fmt: skip
    ap.add_argument("--pool-with", type=Path, default=None,
                    help="the first seed set's summary folder (<behaviour>/results.json): "
                         "report this set pooled with it too")  # fmt: skip
    return ap


def run(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    argvs = [study_argv(args, b) for b in args.behaviors]
    return run_study(args, argvs, summarize, before=lambda cmd: link_from_full(args, cmd))


if __name__ == "__main__":
    raise SystemExit(run())
