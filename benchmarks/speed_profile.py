"""The parity study's runs below its 1.6-1.8 m/s cells (issue 32, docs/fidelity.md): each
trained seed's success against the reactive target at Table I's lower speeds, so that a
setting's effect reads as a curve over speed, as the paper's Table I does.

    .venv/bin/python benchmarks/speed_profile.py --study /work/studies/parity \\
        --out /work/studies/speed_profile [--settings default paper_observation ...]

Reads each setting's runs from the parity study's folder with the most seeds (the full pass
or a primary pass, as ``parity_study.py`` does) and evaluates every seed of rl and sp_rl
(sp_rl with its setting's self-aware predictor) by ``dyncatch eval`` at each speed, the
same evaluation seed for every run. Each run's rows are cached in ``OUT`` (a re-run
evaluates only what is missing). The summary gives, per setting, method and speed, the mean
over seeds with its 95 % t-interval, and the per-seed values.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from parity_study import setting_folders
from study_io import write_summary

from dyncatch.evaluation.intervals import mean_ci
from dyncatch.utils.files import read_json, write_json

METHODS = ("rl", "sp_rl")
BEHAVIOR = "reactive"


def parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--study", type=Path, required=True, help="the parity study's --out")
    ap.add_argument("--out", type=Path, required=True, help="where each run's rows are cached")
    ap.add_argument("--summary-dir", type=Path, default=Path("benchmarks/results/speed_profile"))
    ap.add_argument(
        "--settings", nargs="+", default=["default", "paper_observation", "success_every_step"]
    )
    ap.add_argument("--speeds", type=float, nargs="+", default=[0.4, 0.8, 1.0, 1.2, 1.4])
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--eval-seed", type=int, default=0)
    ap.add_argument("--summarize-only", action="store_true")
    return ap


def setting_folder(study: Path, setting: str) -> Path:
    """The folder of ``setting`` holding the most seeds (its ``plan.json``'s ``seeds``)."""
    found = [p for p in setting_folders(study, setting) if (p / "plan.json").exists()]
    if not found:
        raise FileNotFoundError(f"no run of setting {setting!r} under {study}: run the study")
    return max(found, key=lambda p: read_json(p / "plan.json")["seeds"])


def runs(folder: Path, method: str) -> list[Path]:
    """The finished seeds of ``method`` on reactive, in seed order."""
    done = [p.parent for p in (folder / "runs" / BEHAVIOR / method).glob("seed*/done.json")]
    return sorted(done, key=lambda p: int(p.name.removeprefix("seed")))


def eval_argv(args, folder: Path, run: Path, method: str) -> list[str]:
    argv = ["eval", str(run), "--speeds", *map(str, args.speeds)]
    argv += ["--episodes", str(args.episodes), "--seed", str(args.eval_seed), "--json"]
    if method == "sp_rl":
        pred = folder / "predictors" / f"{BEHAVIOR}_self_aware" / "predictor.safetensors"
        argv += ["--predictor", str(pred)]
    return argv


def evaluate(args) -> None:
    from dyncatch.cli.main import parse

    for setting in args.settings:
        folder = setting_folder(args.study, setting)
        for method in METHODS:
            for run in runs(folder, method):
                out = args.out / setting / method / f"{run.name}.json"
                if out.exists():
                    continue
                argv = eval_argv(args, folder, run, method)
                command, cmd = parse(argv)
                write_json(out, {"argv": argv, **command.run(cmd)})


def summarize(args) -> dict:
    rows, lines = [], []
    speeds = [float(s) for s in args.speeds]
    header = " | ".join(f"{s:g} m/s" for s in speeds)
    lines += [f"Success on {BEHAVIOR}, mean over seeds [95 % t-interval], "
              f"{args.episodes} episodes per seed and speed (intervals clipped to [0, 1]).", "",
              f"| setting | method | seeds | {header} |",
              "|---|---|---:|" + "---|" * len(speeds)]  # fmt: skip
    for setting in args.settings:
        for method in METHODS:
            files = sorted((args.out / setting / method).glob("seed*.json"),
                           key=lambda p: int(p.stem.removeprefix("seed")))  # fmt: skip
            if not files:
                continue
            per_seed = [json.loads(f.read_text())["rows"] for f in files]
            cells = []
            for s in speeds:
                values = [next(r["success_rate"] for r in rr if r["speed_mps"] == s)
                          for rr in per_seed]  # fmt: skip
                mean, ci = mean_ci(values)
                rows.append({"setting": setting, "method": method, "speed_mps": s,
                             "mean": mean, "ci95": ci, "per_seed": values})  # fmt: skip
                cells.append(
                    f"{mean:.2f}"
                    + ("" if ci is None else f" [{max(ci[0], 0):.2f}, {min(ci[1], 1):.2f}]")
                )
            lines.append(f"| {setting} | {method} | {len(files)} | " + " | ".join(cells) + " |")
    lines += ["", "Per seed:", ""]
    lines += [f"- {r['setting']}, {r['method']}, {r['speed_mps']:g} m/s: "
              + ", ".join(f"{v:.2f}" for v in r["per_seed"]) for r in rows]  # fmt: skip
    result = {"speeds_mps": speeds, "episodes": args.episodes, "eval_seed": args.eval_seed,
              "rows": rows}  # fmt: skip
    write_summary(args.summary_dir, result, lines)
    return result


def run(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if not args.summarize_only:
        evaluate(args)
    summarize(args)
    print((args.summary_dir / "summary.md").read_text())
    return 0


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
