"""Information parity (issue 32, docs/fidelity.md): which difference from the paper's world
lets monolithic RL catch here, whether the self-aware predictor then holds, and whether a
memory does what the predictor does.

    .venv/bin/python benchmarks/parity_study.py --out /work/studies/parity [--dry-run]

One cached ``dyncatch reproduce`` per setting: the standard setting (``default``), each
information reading alone (``READINGS`` below, docs/fidelity.md says what each sets and the
text that allows it), and all of them with eq. 8 as a state indicator (``paper_literal``
without ``paper_budget``: the study's budget is the standard 4 M steps). Each trains
``rl``, ``sp_rl``, ``gt_rl`` and ``rnn_rl`` on reactive and random_reactive (each with its
own predictor) over ``--seeds`` seeds and evaluates them at 1.6 and 1.8 m/s. Re-running
resumes; settings run in the order below.

Two passes: the **primary pass** first trains only what the primary endpoints read (``rl``
and ``sp_rl`` on reactive) for every setting, under ``OUT/primary/SETTING``; the full pass
then runs each setting whole under ``OUT/SETTING``. Finished runs and predictors are
hard-linked between a setting's two folders before each pass runs it, so nothing trains
twice. ``--no-primary-first`` runs the full pass alone. The summary reads a setting's full
results where they exist and its primary results otherwise.

The analysis, written down before any of these runs existed:

- **Primary**, per reading R and method m in (rl, sp_rl): E = success at 1.8 m/s on
  reactive under R minus under ``default``, Welch's 95 % interval over seeds, its half-width
  (the smallest effect the run resolves; target <= 0.15). The family of these effects is
  also Holm-adjusted; a reading "gives rl its catch" when its effect on rl is negative and
  resolved after Holm.
- **Secondary**, per setting and behaviour at 1.8 m/s: ``sp_rl - rl`` (does the predictor
  hold), ``rnn_rl - rl`` and ``sp_rl - rnn_rl`` (does memory do what it does), Welch.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

from study_io import run_study, study_parser, write_summary

from dyncatch.evaluation.intervals import holm, welch
from dyncatch.reproduce.aggregate import seed_means
from dyncatch.reproduce.readings import PAPER_LITERAL, setting_name

READINGS = ("gamma_held", "paper_observation", "fov_half_angle", "beta_heading",
            "arm_on_sighting")  # fmt: skip
LITERAL_AT_BUDGET = tuple(r for r in PAPER_LITERAL if r != "paper_budget")
SETTINGS = ((), *((r,) for r in READINGS), LITERAL_AT_BUDGET)
METHODS = ("rl", "sp_rl", "gt_rl", "rnn_rl")
BEHAVIORS = ("reactive", "random_reactive")
SPEEDS = ("1.6", "1.8")
SPEED_MPS = 1.8
PRIMARY_METHODS = ("rl", "sp_rl")
PAIRS = (("sp_rl", "rl"), ("rnn_rl", "rl"), ("sp_rl", "rnn_rl"))
PRIMARY_DIR = "primary"
PRIMARY_BEHAVIORS = ("reactive",)


def study_argv(args, setting: tuple[str, ...], primary: bool = False) -> list[str]:
    root = args.out / PRIMARY_DIR if primary else args.out
    methods = PRIMARY_METHODS if primary else METHODS
    behaviors = PRIMARY_BEHAVIORS if primary else BEHAVIORS
    argv = ["reproduce", "--out", str(root / setting_name(setting)), "--methods", *methods]
    argv += ["--seeds", str(args.seeds), "--train-steps", str(args.train_steps)]
    argv += ["--episodes", str(args.episodes), "--speeds-mps", *SPEEDS]
    argv += ["--behaviors", *behaviors, "--table-i-behaviors", *behaviors]
    argv += ["--no-table-ii", "--transfer-behaviors"]
    argv += ["--no-videos", "--no-fig9", "--no-vmap-seeds"]
    if setting:
        argv += ["--setting", *setting]
    if args.hidden_sizes:
        argv += ["--ppo.hidden-sizes", *map(str, args.hidden_sizes)]
    return argv


def other_pass(out: Path) -> Path:
    """The folder of the same setting in the other pass."""
    if out.parent.name == PRIMARY_DIR:
        return out.parent.parent / out.name
    return out.parent / PRIMARY_DIR / out.name


def share_runs(argv: list[str]) -> None:
    """Hard-link into this command's folder the finished training runs (``done.json``) and
    predictors (``metrics.json``) that the other pass of its setting already has: the two
    passes train them under the same setting, network, budget and seeds."""
    out = Path(argv[argv.index("--out") + 1])
    other = other_pass(out)
    done = [p.parent for p in other.glob("runs/*/*/seed*/done.json")]
    done += [p.parent for p in other.glob("predictors/*/metrics.json")]
    for src in done:
        dest = out / src.relative_to(other)
        if not dest.exists():
            dest.parent.mkdir(parents=True, exist_ok=True)
            shutil.copytree(src, dest, copy_function=os.link)


def _seeds(results: dict, method: str, behavior: str) -> list[float] | None:
    return seed_means(results["table_i"]["cells"], method, SPEED_MPS, (behavior,))


def _row(label: str, a: list[float] | None, b: list[float] | None) -> dict | None:
    if a is None or b is None or min(len(a), len(b)) < 2:
        return None
    d = welch(a, b)
    return {"label": label, "difference": d.difference, "ci95": list(d.ci),
            "half_width": d.half_width, "p_value": d.p_value}  # fmt: skip


def analyse(by_setting: dict[str, dict]) -> dict:
    base = by_setting.get("default")
    primary = []
    for name, res in by_setting.items():
        if name == "default" or base is None:
            continue
        for m in PRIMARY_METHODS:
            row = _row(f"{name}: {m}", _seeds(res, m, "reactive"), _seeds(base, m, "reactive"))
            if row is not None:
                primary.append({"setting": name, "method": m, **row})
    for row, p in zip(primary, holm([r["p_value"] for r in primary]), strict=True):
        row["p_holm"] = float(p)
        lo, hi = row["ci95"]
        row["verdict"] = "unresolved" if p >= 0.05 else ("lowers" if hi < 0 else "raises")
    secondary = []
    for name, res in by_setting.items():
        for b in BEHAVIORS:
            for x, y in PAIRS:
                row = _row(f"{name}, {b}: {x} - {y}", _seeds(res, x, b), _seeds(res, y, b))
                if row is not None:
                    secondary.append({"setting": name, "behavior": b, **row})
    gives = [r["setting"] for r in primary if r["method"] == "rl" and r["verdict"] == "lowers"]
    return {"primary": primary, "secondary": secondary, "gives_rl_its_catch": gives}


def _line(r: dict) -> str:
    lo, hi = r["ci95"]
    return f"{r['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}] | {r['half_width']:.3f}"


def summarize(args) -> dict:
    by_setting, primary_only = {}, []
    for setting in SETTINGS:
        name = setting_name(setting)
        for path in (args.out / name, args.out / PRIMARY_DIR / name):
            if (path / "results.json").exists():
                by_setting[name] = json.loads((path / "results.json").read_text())
                if path.parent.name == PRIMARY_DIR:
                    primary_only.append(name)
                break
    result = analyse(by_setting)
    lines = [
        f"Primary: each reading's effect on success at {SPEED_MPS} m/s, reactive, against "
        "default (Welch 95 % CI over seeds; Holm over the family).",
        "",
        "| setting | method | effect [95 % CI] | half-width | p (Holm) | verdict |",
        "|---|---|---|---:|---:|---|",
    ]
    lines += [
        f"| {r['setting']} | {r['method']} | {_line(r)} | {r['p_holm']:.3f} | {r['verdict']} |"
        for r in result["primary"]
    ]
    lines += ["", f"Secondary: differences between methods at {SPEED_MPS} m/s.", ""]
    lines += [
        "| setting | behaviour | pair | difference [95 % CI] | half-width |",
        "|---|---|---|---|---:|",
    ]
    lines += [
        f"| {r['setting']} | {r['behavior']} | {r['label'].split(': ')[-1]} | {_line(r)} |"
        for r in result["secondary"]
    ]
    gives = ", ".join(result["gives_rl_its_catch"]) or "none resolved"
    lines += ["", f"Readings whose removal of information resolvedly lowers rl: {gives}."]
    pending = [setting_name(s) for s in SETTINGS if setting_name(s) not in by_setting]
    result["pending"] = pending
    result["primary_pass_only"] = primary_only
    lines += [
        "",
        f"Settings measured: {', '.join(by_setting) or 'none'}; "
        f"still to run: {', '.join(pending) or 'none'}.",
        f"Measured by the primary pass only (rl and sp_rl on reactive): "
        f"{', '.join(primary_only) or 'none'}.",
    ]
    write_summary(args.summary_dir, result, lines)
    return result


def parser():
    ap = study_parser(__doc__.splitlines()[0], "parity")
    ap.add_argument("--hidden-sizes", type=int, nargs="*", default=None,
                    help="the PPO network (default: the standard setting's)")  # fmt: skip
    ap.add_argument("--no-primary-first", dest="primary_first", action="store_false",
                    help="skip the primary pass (rl, sp_rl on reactive)")  # fmt: skip
    return ap


def run(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    measured = [s for s in SETTINGS if (args.out / setting_name(s) / "results.json").exists()]
    first = [s for s in SETTINGS if s not in measured] if args.primary_first else []
    argvs = [study_argv(args, s, primary=True) for s in first]
    argvs += [study_argv(args, s) for s in SETTINGS]
    return run_study(args, argvs, summarize, before=share_runs)


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
