"""The fidelity study (docs/fidelity.md): one reproduction per reading of the paper.

    .venv/bin/python benchmarks/fidelity_study.py --out results/fidelity \\
        --world-flags --world.scene.name open_plane

Each setting (``default`` = no reading: the standard setting, or readings from
``dyncatch.reproduce.readings`` on the study's baseline, ``narrow_speeds``) is a
``dyncatch reproduce`` of the study's size into ``OUT/<setting>/``: rl, p_rl, sp_rl, gt_rl
trained on reactive over seeds, sp_fp, pursuit and intercept evaluated at 1.4, 1.6 and
1.8 m/s on reactive and (transfer) random_reactive. Every stage is cached, so re-running
the same command resumes where it stopped (even in another session); ``summary.md`` and
``summary.json`` are written from whatever settings have finished. ``--dry-run`` prints
the plan and its estimate.

Every setting here fed the policy the held sighting's age and the visible flag, the
standard observation of its day (its plan.json files predate the field that names it);
issue 32 then made the paper's observation, without them, the default. Each command passes
``--world.observation.staleness-inputs`` so that the recorded settings resume and the ones
not yet run compare with them; ``default`` is thus the standard setting of the study's
day, today's reading ``staleness_observation``.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from dyncatch.cli.main import main, parse
from dyncatch.reproduce.aggregate import best_rival, gap, time_gap
from dyncatch.reproduce.readings import READINGS, setting_name
from dyncatch.reproduce.stages import estimate_s

BASELINE = ("narrow_speeds",)
"""The study began before the standard setting was chosen, on the first slice's world; so
each reading is measured against that world (training speeds U(0.8, 1.8) m/s, the
``narrow_speeds`` reading since), and ``default`` is the standard setting it led to."""
CANDIDATES = (("success_every_step",), ("fullbody_base",))
"""Readings measured on the standard setting itself, as candidates to join it: eq. 8 as a
state indicator changed the ordering of the methods on the baseline; the base calibrated on
the full-body gait (issue 15) replaces guessed agility constants by measured ones."""
SETTINGS = (
    (),
    *CANDIDATES,
    BASELINE,
    (*BASELINE, "legged_yaw"),
    (*BASELINE, "eq9_per_step", "success_every_step"),
    (*BASELINE, "legged_turning"),
    (*BASELINE, "legged_yaw", "legged_turning"),
    (*BASELINE, "success_every_step"),
    (*BASELINE, "eq9_per_step"),
    (*BASELINE, "slow_tracking"),
)
"""The standard setting; candidates on it; the baseline; one reading at a time on it; the two
agility readings together; and eq. 8 and 9 both read literally (every term paid each control
step, eq. 8 as a state indicator)."""
SPEEDS = ("1.4", "1.6", "1.8")
ORACLE = "gt_rl"
NON_ORACLE = ("rl", "p_rl", "sp_rl", "sp_fp")


def study_argv(out: Path, setting: tuple[str, ...], args) -> list[str]:
    argv = ["reproduce", "--out", str(out / setting_name(setting))]
    argv += ["--seeds", str(args.seeds), "--train-steps", str(args.train_steps)]
    argv += ["--episodes", str(args.episodes), "--speeds-mps", *SPEEDS]
    # Trained on reactive only (half the compute: the study fits its 4 h); random_reactive
    # rows evaluate those policies and predictors (transfer, ``trained_on`` in results.json).
    argv += ["--behaviors", "reactive", "--table-i-behaviors", "reactive", "random_reactive"]
    argv += ["--fig6-behaviors", "reactive", "--table-ii-behaviors", "reactive"]
    argv += ["--table-ii-budgets", "2000000", "--no-videos", "--no-fig9"]
    # Seeds one by one, as the study's first settings were trained (before seed groups).
    argv += ["--no-vmap-seeds"]
    if setting:
        argv += ["--setting", *setting]
    argv += ["--world.observation.staleness-inputs"]  # the recorded settings' observation
    return argv + list(args.world_flags)


def verdicts(results: dict) -> list[dict]:
    """Per behaviour and speed: the oracle's gap to the best non-oracle method (on success,
    then on catch time), and sp_rl against rl, with their 95 % CIs."""
    cells = results["table_i"]["cells"]
    by = {(c["behavior"], c["method"], c["speed_mps"]): c for c in cells}
    rows = []
    for behavior in dict.fromkeys(c["behavior"] for c in cells):
        for speed in sorted({c["speed_mps"] for c in cells}):
            oracle = by.get((behavior, ORACLE, speed))
            rivals = [by[k] for k in ((behavior, m, speed) for m in NON_ORACLE) if k in by]
            if oracle is None or not rivals:
                continue
            best = best_rival(rivals)
            row = {"behavior": behavior, "speed_mps": speed, "best_non_oracle": best["method"]}
            row["oracle_gap_success"] = gap(oracle, best)
            row["oracle_gap_time"] = time_gap(oracle, best)
            sp, rl = by.get((behavior, "sp_rl", speed)), by.get((behavior, "rl", speed))
            if sp and rl:
                row["sp_rl_vs_rl_success"] = gap(sp, rl)
                row["sp_rl_vs_rl_time"] = time_gap(sp, rl)
                row["sp_rl_share_of_oracle"] = oracle_share(rl, sp, oracle)
            row["success"] = {
                c["method"]: c["success_rate"]
                for c in cells
                if c["behavior"] == behavior and c["speed_mps"] == speed
            }
            rows.append(row)
    return rows


def oracle_share(rl: dict, sp: dict, oracle: dict) -> dict:
    """How much of the oracle's advantage over ``rl`` the self-aware predictor recovers:
    (sp_rl - rl) / (gt_rl - rl), on success and on catch time (seed means; None where the
    oracle has no advantage to recover)."""

    def share(a: float, b: float, o: float) -> float | None:
        return (b - a) / (o - a) if abs(o - a) > 1e-9 else None

    return {
        "success": share(rl["success_rate"], sp["success_rate"], oracle["success_rate"]),
        "catch_time": share(rl["catch_time_s"], sp["catch_time_s"], oracle["catch_time_s"]),
    }


def _share(x: float | None) -> str:
    return "-" if x is None else f"{x:.2f}"


def _fmt(check: dict | None) -> str:
    if check is None:
        return "-"
    lo, hi = check["ci95"]
    return f"{check['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}]"


def _cell(c: dict | None) -> str:
    if c is None:
        return "-"
    lo, hi = c["success_ci95"]
    return f"{c['success_rate']:.2f} [{lo:.2f}, {hi:.2f}] / {c['catch_time_s']:.1f} s"


def method_table(all_results: dict[str, dict], speed: float) -> list[str]:
    """Success [95 % CI] / catch time of every method and baseline, per setting and behaviour,
    at one speed."""
    names = list(dict.fromkeys(c["method"] for r in all_results.values()
                               for c in r["table_i"]["cells"]))  # fmt: skip
    lines = [f"| setting | behaviour | {' | '.join(names)} |", "|---|---|" + "---|" * len(names)]
    for name, r in all_results.items():
        cells = r["table_i"]["cells"]
        for behavior in dict.fromkeys(c["behavior"] for c in cells):
            by = {c["method"]: c for c in cells
                  if c["behavior"] == behavior and c["speed_mps"] == speed}  # fmt: skip
            lines.append(f"| {name} | {behavior} | " + " | ".join(_cell(by.get(m)) for m in names)
                         + " |")  # fmt: skip
    return lines


def plot_curves(out: Path, settings: list[str], path: Path) -> None:
    """One panel per setting: the periodic evaluation's success at ``eval_speed_mps`` (1.8 m/s)
    against environment steps, each trained method's seed mean with its seed range shaded."""
    from matplotlib.figure import Figure

    from dyncatch.reproduce.presentation import reproduced_methods
    from dyncatch.reproduce.report import color, label, read_curve
    from dyncatch.rl.methods import trained_methods

    cols = min(4, len(settings))
    rows = -(-len(settings) // cols)
    fig = Figure(figsize=(4.0 * cols, 3.2 * rows), layout="constrained")
    axes = fig.subplots(rows, cols, squeeze=False)
    for ax, name in zip(axes.flat, settings, strict=False):
        for method in trained_methods(reproduced_methods()):
            runs = sorted((out / name / "runs" / "reactive" / method).glob("seed*"))
            curves = [read_curve(r) for r in runs if (r / "metrics.csv").exists()]
            if not curves:
                continue
            n = min(len(c["eval_success_rate"]) for c in curves)
            x = curves[0]["eval_env_steps"][:n] / 1e6
            y = np.stack([c["eval_success_rate"][:n] for c in curves])
            ax.plot(x, y.mean(0), color=color(method), label=label(method))
            ax.fill_between(x, y.min(0), y.max(0), color=color(method), alpha=0.2, lw=0)
        ax.set_title(name, fontsize=9)
        ax.set_ylim(-0.02, 1.02)
        ax.set_xlabel("env steps (M)")
        ax.set_ylabel("success at 1.8 m/s (reactive)")
        ax.grid(alpha=0.3)
    for ax in list(axes.flat)[len(settings) :]:
        ax.set_axis_off()
    axes.flat[0].legend(fontsize=7)
    fig.savefig(path, dpi=110)


def summarize(out: Path) -> dict:
    summary, all_results = {}, {}
    for setting in SETTINGS:
        path = out / setting_name(setting) / "results.json"
        if path.exists():
            all_results[setting_name(setting)] = json.loads(path.read_text())
            summary[setting_name(setting)] = verdicts(all_results[setting_name(setting)])
    lines = [
        "| setting | behaviour | speed | best non-oracle | gt_rl gap: success | gt_rl gap: "
        "s saved | sp_rl - rl: success | sp_rl vs rl: s saved |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, rows in summary.items():
        for r in rows:
            lines.append(
                f"| {name} | {r['behavior']} | {r['speed_mps']} | {r['best_non_oracle']} | "
                f"{_fmt(r['oracle_gap_success'])} | {_fmt(r['oracle_gap_time'])} | "
                f"{_fmt(r.get('sp_rl_vs_rl_success'))} | {_fmt(r.get('sp_rl_vs_rl_time'))} |"
            )
    lines += [
        "",
        "Share of the oracle's advantage over rl that sp_rl recovers, "
        "(sp_rl - rl) / (gt_rl - rl), seed means:",
        "",
        "| setting | behaviour | speed | on success | on catch time |",
        "|---|---|---|---|---|",
    ]
    for name, rows in summary.items():
        for r in rows:
            if "sp_rl_share_of_oracle" in r:
                sh = r["sp_rl_share_of_oracle"]
                lines.append(f"| {name} | {r['behavior']} | {r['speed_mps']} | "
                             f"{_share(sh['success'])} | {_share(sh['catch_time'])} |")  # fmt: skip
    for speed in (1.8, 1.6, 1.4):
        lines += ["", f"Every method at {speed} m/s (success [95 % CI] / catch time):", ""]
        lines += method_table(all_results, speed)
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    (out / "summary.md").write_text("\n".join(lines) + "\n")
    if all_results:
        plot_curves(out, list(all_results), out / "curves.png")
    return summary


def run(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("results/fidelity"))
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--train-steps", type=int, default=2_000_000)
    ap.add_argument("--episodes", type=int, default=500)
    ap.add_argument("--only", nargs="*", default=None, help="settings to run, by name")
    ap.add_argument("--dry-run", action="store_true")
    ap.add_argument(
        "--world-flags",
        nargs=argparse.REMAINDER,
        default=[],
        help="flags passed to every reproduction (e.g. --world.scene.name ...)",
    )
    args = ap.parse_args(argv)
    todo = [s for s in SETTINGS if args.only is None or setting_name(s) in args.only]
    for setting in todo:
        unknown = [r for r in setting if r not in READINGS]
        if unknown:
            raise SystemExit(f"unknown readings {unknown}")
    total = 0.0
    for setting in todo:
        cmd = study_argv(args.out, setting, args)
        plan = parse(cmd)[1]
        total += estimate_s(plan)
        print(f"{setting_name(setting)}: {' '.join(cmd)}")
    print(f"estimated {total / 3600:.1f} h on 2 cores for {len(todo)} settings")
    if args.dry_run:
        return 0
    for setting in todo:
        if main(study_argv(args.out, setting, args)) != 0:
            return 2
        summarize(args.out)
    summarize(args.out)
    print((args.out / "summary.md").read_text())
    return 0


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
