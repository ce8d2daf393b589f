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

Passes: the **primary passes** first train only what the primary endpoints read (``rl``
and ``sp_rl`` on reactive) for every setting, at 5 and then 10 seeds
(``--primary-seeds``), under ``OUT/primary_sN/SETTING``; the full pass then runs each
setting whole under ``OUT/SETTING``. Finished runs and predictors are hard-linked between a
setting's folders before each pass runs it, so nothing trains twice; ``--primary-seeds``
with no value runs the full pass alone. The primary analysis reads each setting's results
with the most seeds; the secondary reads the full pass's, or the primary's until it exists.
The 10-seed pass was added after the first 5-seed results, whose half-width on rl (0.161
for gamma_held) missed the issue's 0.15; the analysis below is unchanged.

The analysis, written down before any of these runs existed:

- **Primary**, per reading R and method m in (rl, sp_rl): E = success at 1.8 m/s on
  reactive under R minus under ``default``, Welch's 95 % interval over seeds, its half-width
  (the smallest effect the run resolves; target <= 0.15). The family of these effects is
  also Holm-adjusted; a reading "gives rl its catch" when its effect on rl is negative and
  resolved after Holm.
- **Secondary**, per setting and behaviour at 1.8 m/s: ``sp_rl - rl`` (does the predictor
  hold), ``rnn_rl - rl`` and ``sp_rl - rnn_rl`` (does memory do what it does), Welch.

Added after the 5-seed primary pass, before any run of what they add (the analysis above is
unchanged; the added settings join its Holm family):

- ``success_every_step`` alone: the issue lists it among the readings, and it made rl score
  0.00 in the earlier fidelity study (2 seeds, 2 M steps).
- ``LITERAL_WITHOUT_ARM``, the literal combination without ``arm_on_sighting``, labelled
  exploratory: under ``arm_on_sighting`` no method and no planner catches at 1.6-1.8 m/s
  (rl, sp_rl, pursuit and intercept all 0.00-0.01), so the literal combination cannot tell
  methods apart.
- The 10-seed pass runs a setting only where its 5-seed effect on rl or sp_rl missed the
  half-width target (0.15), and always for ``default``, the baseline; ``default`` first,
  then settings not yet measured, then the widest half-width first.
- The full pass skips a setting under which no primary run catches (every rl and sp_rl
  seed at most ``NO_CATCH`` at 1.8 m/s on reactive): its secondary differences would compare
  zeros. Decided before the full pass of any such setting ran (``arm_on_sighting`` and the
  literal combination: all 0.00).
- The full pass runs ``default`` first, then the settings whose primary effect on rl is
  resolved and lowers it, then the rest: an order, not a change to the analysis. Decided
  after the 5-seed primary pass, where ``success_every_step`` alone lowered rl to 0.00 on
  every seed while sp_rl kept catching, so its rnn_rl and gt_rl answer the secondary
  questions first.

Added before the full pass of ``success_every_step`` ran (the analysis above unchanged):
``--full-settings`` runs the full pass of the named settings alone, for a machine where the
primary folders are gone (``full_pass_order`` cannot then be decided). Its rl and sp_rl
seeds 0-4 on reactive retrain the primary pass's, so they also check that the code still
gives its recorded per-seed values (summary.md).

The study's ``default`` is the standard setting it began under, whose observation feeds the
held sighting's age and the visible flag; issue 32 then made the paper's observation (the
reading ``paper_observation`` here) the library's default. So every command of a setting
without ``paper_observation`` passes ``STALENESS_FLAG``: each setting, its folder name and
its plan.json stay what they were, and the study resumes unchanged. ``default`` here is
thus the reading ``staleness_observation`` of today's library, and ``paper_observation``'s
effect against it is the effect of the standard's change.
"""

from __future__ import annotations

import json
import math
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
LITERAL_WITHOUT_ARM = tuple(r for r in LITERAL_AT_BUDGET if r != "arm_on_sighting")
SETTINGS = ((), *((r,) for r in READINGS), LITERAL_AT_BUDGET, ("success_every_step",),
            LITERAL_WITHOUT_ARM)  # fmt: skip
SETTINGS_BY_NAME = {setting_name(s): s for s in SETTINGS}
EXPLORATORY = (setting_name(LITERAL_WITHOUT_ARM),)
HALF_WIDTH_TARGET = 0.15
NO_CATCH = 0.02
METHODS = ("rl", "sp_rl", "gt_rl", "rnn_rl")
BEHAVIORS = ("reactive", "random_reactive")
SPEEDS = ("1.6", "1.8")
SPEED_MPS = 1.8
PRIMARY_METHODS = ("rl", "sp_rl")
PAIRS = (("sp_rl", "rl"), ("rnn_rl", "rl"), ("sp_rl", "rnn_rl"))
PRIMARY_PREFIX = "primary_s"
PRIMARY_BEHAVIORS = ("reactive",)
STALENESS_FLAG = "--world.observation.staleness-inputs"
"""The study's baseline observation, pinned: it began when the standard observation fed the
sighting's age and the visible flag (issue 32 then made the paper's s, without them, the
standard). Every setting without ``paper_observation`` keeps them, so ``default`` and each
reading are what their recorded plan.json and finished runs say. A flag, not the reading
``staleness_observation``: plan.json records the ``--setting`` list, and the folder names
come from it, so both stay as recorded."""


def study_argv(args, setting: tuple[str, ...], primary_seeds: int | None = None) -> list[str]:
    """The ``dyncatch reproduce`` command of ``setting``'s full pass, or of its primary pass
    at ``primary_seeds`` seeds."""
    primary = primary_seeds is not None
    root = args.out / f"{PRIMARY_PREFIX}{primary_seeds}" if primary else args.out
    methods = PRIMARY_METHODS if primary else METHODS
    behaviors = PRIMARY_BEHAVIORS if primary else BEHAVIORS
    seeds = primary_seeds if primary else args.seeds
    argv = ["reproduce", "--out", str(root / setting_name(setting)), "--methods", *methods]
    argv += ["--seeds", str(seeds), "--train-steps", str(args.train_steps)]
    argv += ["--episodes", str(args.episodes), "--speeds-mps", *SPEEDS]
    argv += ["--behaviors", *behaviors, "--table-i-behaviors", *behaviors]
    argv += ["--no-table-ii", "--transfer-behaviors"]
    argv += ["--no-videos", "--no-fig9", "--no-vmap-seeds"]
    if setting:
        argv += ["--setting", *setting]
    if "paper_observation" not in setting:
        argv.append(STALENESS_FLAG)
    if args.hidden_sizes:
        argv += ["--ppo.hidden-sizes", *map(str, args.hidden_sizes)]
    return argv


def setting_folders(root: Path, name: str) -> list[Path]:
    """``name``'s folders: the full pass's, then each primary pass's by seed count."""
    primaries = root.glob(f"{PRIMARY_PREFIX}*/{name}")
    return [
        root / name,
        *sorted(primaries, key=lambda p: int(p.parent.name[len(PRIMARY_PREFIX) :])),
    ]


def share_runs(argv: list[str]) -> None:
    """Hard-link into this command's folder the finished training runs (``done.json``, of
    the seeds it trains) and predictors (``metrics.json``) that the other passes of its
    setting already have: the passes train them under the same setting, network, budget
    and seeds."""
    out = Path(argv[argv.index("--out") + 1])
    seeds = int(argv[argv.index("--seeds") + 1])
    root = out.parent.parent if out.parent.name.startswith(PRIMARY_PREFIX) else out.parent
    for other in setting_folders(root, out.name):
        if other == out:
            continue
        done = [p.parent for p in other.glob("runs/*/*/seed*/done.json")]
        done = [d for d in done if int(d.name.removeprefix("seed")) < seeds]
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


def analyse(by_setting: dict[str, dict], primary_by_setting: dict[str, dict] | None = None) -> dict:
    """The primary effects (read from ``primary_by_setting``, default ``by_setting``) and the
    secondary differences (from ``by_setting``)."""
    primary_by_setting = by_setting if primary_by_setting is None else primary_by_setting
    base = primary_by_setting.get("default")
    primary = []
    for name, res in primary_by_setting.items():
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


def _label(name: str) -> str:
    return f"{name} (exploratory)" if name in EXPLORATORY else name


def _line(r: dict) -> str:
    lo, hi = r["ci95"]
    return f"{r['difference']:+.3f} [{lo:+.3f}, {hi:+.3f}] | {r['half_width']:.3f}"


def collect(args) -> tuple[dict, dict, list[str], dict]:
    """Per setting: the results the secondary analysis reads (the full pass's, else a primary
    pass's), those the primary reads (the most seeds), the settings measured by a primary
    pass only, and the folder each primary effect is read from."""
    by_setting, by_seeds, primary_only, sources = {}, {}, [], {}
    for setting in SETTINGS:
        name = setting_name(setting)
        found = [p for p in setting_folders(args.out, name) if (p / "results.json").exists()]
        if not found:
            continue
        read = {p: json.loads((p / "results.json").read_text()) for p in found}
        full = args.out / name
        by_setting[name] = read[full] if full in read else read[found[-1]]
        if full not in read:
            primary_only.append(name)
        most = max(found, key=lambda p: read[p]["plan"]["seeds"] if "plan" in read[p] else 0)
        by_seeds[name] = read[most]
        sources[name] = str(most.relative_to(args.out))
    return by_setting, by_seeds, primary_only, sources


def primary_widths(args) -> dict[str, float]:
    """Per measured setting, the larger half-width of its effects on rl and sp_rl."""
    by_setting, by_seeds, _, _ = collect(args)
    widths: dict[str, float] = {}
    for r in analyse(by_setting, by_seeds)["primary"]:
        widths[r["setting"]] = max(widths.get(r["setting"], 0.0), r["half_width"])
    return widths


def needs_more_seeds(setting: tuple[str, ...], widths: dict[str, float]) -> bool:
    """Whether a later primary pass runs ``setting``: always for ``default`` and for a setting
    not yet measured; else where its effect on rl or sp_rl missed ``HALF_WIDTH_TARGET``."""
    width = widths.get(setting_name(setting))
    return not setting or width is None or width > HALF_WIDTH_TARGET


def later_pass_order(widths: dict[str, float]) -> list[tuple[str, ...]]:
    """A later primary pass's order: ``default`` (the baseline), the settings not yet
    measured, then the widest effect first."""
    return sorted(SETTINGS, key=lambda s: (bool(s), -widths.get(setting_name(s), math.inf)))


def catches_nothing(args, setting: tuple[str, ...]) -> bool:
    """Whether every primary run of ``setting`` catches at most ``NO_CATCH`` (False while
    none is measured)."""
    res = collect(args)[1].get(setting_name(setting))
    if res is None:
        return False
    per = [_seeds(res, m, "reactive") or [] for m in PRIMARY_METHODS]
    return all(per) and max(max(v) for v in per) <= NO_CATCH


def summarize(args) -> dict:
    by_setting, by_seeds, primary_only, sources = collect(args)
    result = analyse(by_setting, by_seeds)
    result["primary_sources"] = sources
    lines = [
        f"Primary: each reading's effect on success at {SPEED_MPS} m/s, reactive, against "
        "default (Welch 95 % CI over seeds; Holm over the family).",
        "",
        "| setting | method | effect [95 % CI] | half-width | p (Holm) | verdict |",
        "|---|---|---|---:|---:|---|",
    ]
    lines += [
        f"| {_label(r['setting'])} | {r['method']} | {_line(r)} | {r['p_holm']:.3f} "
        f"| {r['verdict']} |"
        for r in result["primary"]
    ]
    lines += ["", f"Per-seed success at {SPEED_MPS} m/s on reactive (what the primary reads).", ""]
    lines += ["| setting | seeds | " + " | ".join(PRIMARY_METHODS) + " |", "|---|---:|---|---|"]
    for name, res in by_seeds.items():
        per = [_seeds(res, m, "reactive") or [] for m in PRIMARY_METHODS]
        cells = " | ".join(", ".join(f"{x:.2f}" for x in v) for v in per)
        lines.append(f"| {_label(name)} | {max(map(len, per))} | {cells} |")
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
    pending += [name for name in primary_only if not catches_nothing(args, SETTINGS_BY_NAME[name])]
    result["pending"] = pending
    result["primary_pass_only"] = primary_only
    lines += [
        "",
        f"Settings measured: {', '.join(by_setting) or 'none'}; "
        f"full pass still to run: {', '.join(pending) or 'none'}.",
        f"Measured by a primary pass only (rl and sp_rl on reactive): "
        f"{', '.join(primary_only) or 'none'}.",
        "Primary effects read: "
        + ", ".join(f"{k} from {v}" for k, v in sources.items())
        + " (the folder with the most seeds).",
    ]
    write_summary(args.summary_dir, result, lines)
    return result


def parser():
    ap = study_parser(__doc__.splitlines()[0], "parity")
    ap.add_argument("--hidden-sizes", type=int, nargs="*", default=None,
                    help="the PPO network (default: the standard setting's)")  # fmt: skip
    ap.add_argument("--primary-seeds", type=int, nargs="*", default=[5, 10],
                    help="the primary passes' seed counts (none: skip them)")  # fmt: skip
    ap.add_argument("--full-settings", nargs="+", default=None, metavar="SETTING",
                    help="the full pass runs only these settings, in the order given "
                         "(names as in summary.md, e.g. success_every_step; default: "
                         "every setting, in full_pass_order)")  # fmt: skip
    return ap


def chosen_settings(names: list[str]) -> list[tuple[str, ...]]:
    """The settings ``--full-settings`` names, in its order; an unknown name is an error
    that lists the known ones."""
    unknown = [n for n in names if n not in SETTINGS_BY_NAME]
    if unknown:
        raise SystemExit(
            f"--full-settings: unknown setting(s) {', '.join(unknown)}; "
            f"choose from {', '.join(SETTINGS_BY_NAME)}"
        )
    return [SETTINGS_BY_NAME[n] for n in names]


def run(argv: list[str] | None = None) -> int:
    args = parser().parse_args(argv)
    if args.full_settings:
        chosen_settings(args.full_settings)  # a wrong name fails before anything runs
    return run_study(args, passes(args), summarize, before=share_runs)


def passes(args):
    """The commands in order, each decided when its turn comes (``needs_more_seeds`` reads
    the passes before it): the primary passes, then the full pass."""
    measured = [s for s in SETTINGS if (args.out / setting_name(s) / "results.json").exists()]
    for i, n in enumerate(args.primary_seeds):
        widths = primary_widths(args) if i > 0 else {}
        for s in later_pass_order(widths) if i > 0 else SETTINGS:
            if n <= args.seeds and s in measured:
                continue  # the full pass already holds these seeds
            if i > 0 and not needs_more_seeds(s, widths):
                continue
            yield study_argv(args, s, primary_seeds=n)
    for s in full_pass_order(args):
        yield study_argv(args, s)


def full_pass_order(args) -> list[tuple[str, ...]]:
    """The full pass's settings, decided when it begins: ``default`` first, then those
    whose primary effect on rl is resolved and lowers it (where the secondary questions, does
    sp_rl hold and does memory do what the predictor does, have an answer to give), then the
    rest in ``SETTINGS`` order; without the settings under which no primary run catches.
    ``--full-settings`` replaces this order with its own list (a study whose primary folders
    are gone cannot decide it)."""
    if getattr(args, "full_settings", None):
        return chosen_settings(args.full_settings)
    by_setting, by_seeds, _, _ = collect(args)
    lowers = set(analyse(by_setting, by_seeds)["gives_rl_its_catch"])
    keep = [s for s in SETTINGS if not catches_nothing(args, s)]
    return sorted(keep, key=lambda s: (bool(s), setting_name(s) not in lowers))


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
