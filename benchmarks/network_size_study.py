"""Network size as a named, measured reading (issue 30, part 1; docs/performance.md).

    .venv/bin/python benchmarks/network_size_study.py --out /work/studies/network_size

The paper gives no network size. One cached ``dyncatch reproduce`` per size (256-256-128,
the standard until now; 128-128-64; 64-64) trains ``rl``, ``p_rl``, ``sp_rl`` and
``gt_rl`` on reactive and random_reactive (each with its own predictor) over 5 seeds at
4 M steps, and evaluates every policy at 1.6 and 1.8 m/s. Re-running resumes; sizes run
in the order below, so an interrupted study has the cheapest comparison first.

The criterion, written down before any of these runs existed (commit of this file):

- For each method m, D_m(S) = success at 1.8 m/s of size S minus that of 256-256-128,
  each the mean over seeds of the seed's mean over the two behaviours (a seed's two runs
  are independent, so the behaviour-averaged seed is the unit; 5 per size and method).
- A size S **holds** if D_m(S) >= -0.05 for all four methods (point estimates, as the issue
  states the criterion) **and** the oracle's plateau holds: ``gt_rl``'s final periodic
  evaluation success, mean over seeds and behaviours, at least that of 256-256-128 minus
  0.05.
- The standard is the smallest size that holds; if none does, 256-256-128 stays. One size
  for every method: never chosen per method.
- Every D_m(S) is reported with its 95 % Welch interval and the smallest difference the run
  resolves; a D whose interval spans 0 is unresolved, and the summary says that a point
  criterion at 5 seeds carries that risk.

``summary.md`` and ``summary.json`` (in ``--summary-dir``, committed) carry the table.

Its runs fed the policy the held sighting's age and the visible flag, the standard
observation until issue 32 made the paper's (without them) the default; every command
passes ``--world.observation.staleness-inputs`` so that the recorded folders resume and
their plan.json files still match (the parity study's ``default`` shares their runs).
"""

from __future__ import annotations

import json

import numpy as np
from study_io import run_study, study_parser, write_summary

from dyncatch.evaluation.intervals import welch
from dyncatch.reproduce.aggregate import seed_means

SIZES = ((128, 128, 64), (256, 256, 128), (64, 64))
REFERENCE = (256, 256, 128)
METHODS = ("rl", "p_rl", "sp_rl", "gt_rl")
BEHAVIORS = ("reactive", "random_reactive")
SPEEDS = ("1.6", "1.8")
MARGIN = 0.05
SPEED_MPS = 1.8


def size_name(size: tuple[int, ...]) -> str:
    return "-".join(map(str, size))


def study_argv(args, size: tuple[int, ...]) -> list[str]:
    argv = ["reproduce", "--out", str(args.out / size_name(size)), "--methods", *METHODS]
    argv += ["--seeds", str(args.seeds), "--train-steps", str(args.train_steps)]
    argv += ["--episodes", str(args.episodes), "--speeds-mps", *SPEEDS]
    argv += ["--behaviors", *BEHAVIORS, "--ppo.hidden-sizes", *map(str, size)]
    argv += ["--no-table-ii", "--transfer-behaviors", "--world.observation.staleness-inputs"]
    return argv + ["--no-videos", "--no-fig9", "--no-vmap-seeds"]


def seed_success(results: dict, method: str) -> list[float] | None:
    """Per seed, the mean over the behaviours of the seed's success at SPEED_MPS."""
    return seed_means(results["table_i"]["cells"], method, SPEED_MPS, BEHAVIORS)


def plateau(results: dict, method: str = "gt_rl") -> float | None:
    finals = [
        r["final_eval_success_rate"]
        for r in results["training"]
        if r["method"] == method and r["final_eval_success_rate"] is not None
    ]
    return float(np.mean(finals)) if finals else None


def train_seconds(results: dict) -> float:
    """The fastest run's training seconds: the others ran beside other jobs (or paused), so
    the least contended run is the closest to an idle machine's figure."""
    return float(np.min([r["wall_s"] for r in results["training"]]))


def parameters(name: str) -> int:
    """The size's order for "smallest": the product of its widths."""
    return int(np.prod([int(w) for w in name.split("-")]))


def judge(by_size: dict[str, dict]) -> dict:
    """The criterion above, over the sizes whose reproduction finished."""
    ref = by_size.get(size_name(REFERENCE))
    rows, holds = [], {}
    if ref is None:
        return {"rows": rows, "holds": holds, "standard": None}
    ref_plateau = plateau(ref)
    for name, res in by_size.items():
        if name == size_name(REFERENCE):
            continue
        ok = True
        for m in METHODS:
            a, b = seed_success(res, m), seed_success(ref, m)
            if a is None or b is None:  # a method not evaluated on every behaviour
                ok = False
                continue
            d = welch(a, b)
            ok &= d.difference >= -MARGIN
            lo, hi = d.ci
            rows.append(
                {
                    "size": name,
                    "method": m,
                    "success": float(np.mean(a)),
                    "reference": float(np.mean(b)),
                    "difference": d.difference,
                    "ci95": [lo, hi],
                    "resolvable": d.half_width,
                    "resolved": not (lo <= 0 <= hi),
                }
            )
        p = plateau(res)
        plateau_ok = p is not None and ref_plateau is not None and p >= ref_plateau - MARGIN
        holds[name] = {"methods_hold": bool(ok), "plateau": p, "plateau_holds": plateau_ok,
                       "holds": bool(ok and plateau_ok)}  # fmt: skip
    passing = [n for n, h in holds.items() if h["holds"]]
    finished_all = len(by_size) == len(SIZES)
    smallest = min(passing, key=parameters, default=None)
    # A smaller size still to run may hold too: the standard waits for it.
    pending_smaller = smallest is not None and any(
        size_name(s) not in by_size and parameters(size_name(s)) < parameters(smallest)
        for s in SIZES
    )
    standard = None if pending_smaller else smallest
    standard = standard or (size_name(REFERENCE) if finished_all else None)
    return {"rows": rows, "holds": holds, "reference_plateau": ref_plateau,
            "standard": standard, "complete": finished_all}  # fmt: skip


def summarize(args) -> dict:
    by_size = {}
    for size in SIZES:
        path = args.out / size_name(size) / "results.json"
        if path.exists():
            by_size[size_name(size)] = json.loads(path.read_text())
    verdict = judge(by_size)
    verdict["per_size"] = {
        name: {
            "seed_success": {m: seed_success(res, m) for m in METHODS},
            "gt_rl_plateau": plateau(res),
            "fastest_training_s": train_seconds(res),
        }
        for name, res in by_size.items()
    }
    lines = [
        f"Success at {SPEED_MPS} m/s, per method: seed means over {', '.join(BEHAVIORS)}; "
        f"difference to {size_name(REFERENCE)} with its 95 % Welch interval.",
        "",
        "| size | method | success | reference | difference [95 % CI] | resolvable |",
        "|---|---|---:|---:|---|---:|",
    ]
    for r in verdict["rows"]:
        lo, hi = r["ci95"]
        lines.append(
            f"| {r['size']} | {r['method']} | {r['success']:.3f} | {r['reference']:.3f} | "
            f"{r['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}]"
            f"{'' if r['resolved'] else ' unresolved'} | {r['resolvable']:.3f} |"
        )
    lines += [
        "",
        f"Success at {SPEED_MPS} m/s, mean over seeds of the behaviour-averaged seed:",
        "",
    ]
    lines += ["| size | " + " | ".join(METHODS) + " |", "|---|" + "---:|" * len(METHODS)]
    for name, d in verdict["per_size"].items():
        means = [np.mean(v) if v else float("nan") for v in d["seed_success"].values()]
        lines.append(f"| {name} | " + " | ".join(f"{x:.3f}" for x in means) + " |")
    lines += ["", "| size | fastest training s/seed (shared machine) | gt_rl plateau | holds |"]
    lines += ["|---|---:|---:|---|"]
    for name, res in by_size.items():
        h = verdict["holds"].get(name, {})
        p = plateau(res)
        lines.append(
            f"| {name} | {train_seconds(res):.0f} | {p:.3f} | "
            f"{'reference' if name == size_name(REFERENCE) else h.get('holds')} |"
        )
    lines += ["", f"Standard by the criterion: {verdict['standard'] or 'not decided yet'}."]
    write_summary(args.summary_dir, verdict, lines)
    return verdict


def run(argv: list[str] | None = None) -> int:
    ap = study_parser(__doc__.splitlines()[0], "network_size")
    args = ap.parse_args(argv)
    return run_study(args, [study_argv(args, size) for size in SIZES], summarize)


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
