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


def study_argv(args, setting: tuple[str, ...]) -> list[str]:
    argv = ["reproduce", "--out", str(args.out / setting_name(setting)), "--methods", *METHODS]
    argv += ["--seeds", str(args.seeds), "--train-steps", str(args.train_steps)]
    argv += ["--episodes", str(args.episodes), "--speeds-mps", *SPEEDS]
    argv += ["--behaviors", *BEHAVIORS, "--no-table-ii", "--transfer-behaviors"]
    argv += ["--no-videos", "--no-fig9", "--no-vmap-seeds"]
    if setting:
        argv += ["--setting", *setting]
    if args.hidden_sizes:
        argv += ["--ppo.hidden-sizes", *map(str, args.hidden_sizes)]
    return argv


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
    by_setting = {}
    for setting in SETTINGS:
        path = args.out / setting_name(setting) / "results.json"
        if path.exists():
            by_setting[setting_name(setting)] = json.loads(path.read_text())
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
    lines += [
        "",
        f"Settings measured: {', '.join(by_setting) or 'none'}; "
        f"still to run: {', '.join(pending) or 'none'}.",
    ]
    write_summary(args.summary_dir, result, lines)
    return result


def run(argv: list[str] | None = None) -> int:
    ap = study_parser(__doc__.splitlines()[0], "parity")
    ap.add_argument("--hidden-sizes", type=int, nargs="*", default=None,
                    help="the PPO network (default: the standard setting's)")  # fmt: skip
    args = ap.parse_args(argv)
    return run_study(args, [study_argv(args, s) for s in SETTINGS], summarize)


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
