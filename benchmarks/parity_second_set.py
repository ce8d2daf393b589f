"""Information parity, a second seed set (issue 32): the two readings whose effect on rl
missed the issue's 0.15 half-width at 10 seeds, measured again on new seeds.

    .venv/bin/python benchmarks/parity_second_set.py --out /work/studies/parity2 [--dry-run]

The first set (``parity_study.py``'s primary passes, seeds 0-9, its summary in
``benchmarks/results/parity/``) left two effects on rl at 1.8 m/s on reactive wider than
0.15: ``paper_observation`` (half-width 0.240) and ``success_every_step`` (0.266), both
with bimodal seeds (some 0.00, the rest 0.35-0.95). Its raw results are gone, so they are
not pooled here: this set is measured on its own and compared with the first.

Written down before any run of this set, from the first set's seed spreads (SD 0.33-0.36
under the two readings, 0.11 under ``default``): at 30 seeds under a reading and 15 under
``default`` the projected half-width is 0.135-0.147.

- **Runs:** ``rl`` only (the endpoints below read nothing else), the study's standard
  flags (``parity_study.study_argv``: 128-128-64 networks, 4 M steps, 300 episodes per cell,
  1.6 and 1.8 m/s, ``default`` with the staleness inputs as in the first set), seeds from
  ``FIRST_SEED`` on in chunks of ``CHUNK`` (``--first-seed``; each chunk its own cached
  ``dyncatch reproduce``, so a stopped session keeps every finished chunk).
- **Order:** rounds; round r runs seeds ``FIRST_SEED + CHUNK r`` onward for ``default``
  (rounds 0 to ``DEFAULT_ROUNDS - 1`` only), then ``paper_observation``, then
  ``success_every_step``, for ``ROUNDS`` rounds. Where the session's time ends is where the
  set ends: a count fixed by the clock, not by the results.
- **Primary:** per reading, E = rl's success at 1.8 m/s on reactive under the reading minus
  under ``default``, over this set's seeds: Welch's 95 % interval, its half-width (target
  <= 0.15), Holm over the two effects; "lowers" when Holm's p < 0.05 and the interval is
  below zero.
- **Then sp_rl** (added at this set's first hour, before any sp_rl run of it; the rl rounds
  above unchanged): the first set's effect on sp_rl under ``success_every_step`` missed 0.15
  too (0.157; SDs 0.21 and 0.085), which 15 seeds a side would bring to about 0.12. After the
  rl rounds, ``SP_ROUNDS`` rounds of ``sp_rl`` chunks on the same seeds, ``default`` then
  ``success_every_step``, each chunk with its own self-aware predictor (seeded with the
  chunk's first seed, as ``--first-seed`` does); again the clock ends it. Its effect joins
  the primary family (Holm over every effect this set measures).
- **Descriptive, added after the rl rounds** (no verdict reads it): how each seed's training
  went, from its periodic evaluations (``metrics.csv``'s ``eval/success_rate``, the
  training world's speeds): of the seeds under ``LOW`` at 1.8 m/s, those whose best
  periodic evaluation stayed under ``LOW`` (never learned to catch) and those that reached it
  and ended more than ``FELL_BY`` below their best (learned, then lost it).
- **Replication:** the first set's verdict on the same effect (its Holm family of 16,
  ``benchmarks/results/parity/summary.json``) against this set's; they agree when both give
  the same verdict.
"""

from __future__ import annotations

import json
from pathlib import Path

from parity_study import SPEED_MPS, parser, setting_name, study_argv
from study_io import run_study, write_summary

from dyncatch.evaluation.intervals import holm, welch
from dyncatch.reproduce.aggregate import seed_means
from dyncatch.reproduce.layout import run_dir
from dyncatch.reproduce.report import read_curve

READINGS = ("paper_observation", "success_every_step")
SETTINGS = ((), *((r,) for r in READINGS))
FIRST_SEED = 10
CHUNK = 5
ROUNDS = 6
DEFAULT_ROUNDS = 3
SP_SETTINGS = ((), ("success_every_step",))
SP_ROUNDS = 3
METHODS = ("rl", "sp_rl")
LOW = 0.5
FELL_BY = 0.3
FIRST_SET = Path(__file__).parent / "results" / "parity" / "summary.json"


def chunk_argv(args, setting: tuple[str, ...], first: int, method: str = "rl") -> list[str]:
    """``setting``'s ``method`` runs on seeds ``first`` ... ``first + CHUNK - 1``."""
    argv = study_argv(args, setting, primary_seeds=CHUNK)
    argv[argv.index("--out") + 1] = str(chunk_folder(args.out, setting, first, method))
    i = argv.index("--methods")
    argv[i + 1 : i + 3] = [method]
    return [*argv, "--first-seed", str(first)]


def chunk_folder(out: Path, setting: tuple[str, ...], first: int, method: str = "rl") -> Path:
    """A chunk's folder; an rl chunk's is named by its setting alone (the set began so)."""
    name = setting_name(setting) + ("" if method == "rl" else f".{method}")
    return out / f"seeds{first}-{first + CHUNK - 1}" / name


def passes(args):
    for r in range(ROUNDS):
        first = FIRST_SEED + CHUNK * r
        for s in SETTINGS:
            if s or r < DEFAULT_ROUNDS:
                yield chunk_argv(args, s, first)
    for r in range(SP_ROUNDS):
        for s in SP_SETTINGS:
            yield chunk_argv(args, s, FIRST_SEED + CHUNK * r, "sp_rl")


def per_seed(out: Path, setting: tuple[str, ...], method: str = "rl") -> dict[int, float]:
    """``method``'s success at 1.8 m/s on reactive per seed, over the finished chunks."""
    seeds: dict[int, float] = {}
    for r in range(ROUNDS):
        first = FIRST_SEED + CHUNK * r
        path = chunk_folder(out, setting, first, method) / "results.json"
        if not path.exists():
            continue
        res = json.loads(path.read_text())
        values = seed_means(res["table_i"]["cells"], method, SPEED_MPS, ("reactive",))
        plan = res["plan"]
        ids = range(plan["first_seed"], plan["first_seed"] + plan["seeds"])
        seeds.update(zip(ids, values or [], strict=True))
    return dict(sorted(seeds.items()))


def training_course(out: Path, setting: tuple[str, ...], method: str, seeds: dict) -> dict:
    """Of ``seeds`` (seed: success at 1.8 m/s) those under ``LOW``: never learned to catch
    in training (best periodic evaluation under ``LOW``), or learned and lost it (ended more
    than ``FELL_BY`` below a best of ``LOW`` or more), or neither; each seed's best and last."""
    course: dict = {"low": [], "never": [], "lost": [], "other": []}
    for seed, success in seeds.items():
        if success >= LOW:
            continue
        first = FIRST_SEED + CHUNK * ((seed - FIRST_SEED) // CHUNK)
        folder = chunk_folder(out, setting, first, method)
        evals = read_curve(run_dir(folder, "reactive", method, seed))["eval_success_rate"]
        best, last = float(evals.max()), float(evals[-1])
        course["low"].append({"seed": seed, "success": success, "best": best, "last": last})
        kind = "never" if best < LOW else ("lost" if last < best - FELL_BY else "other")
        course[kind].append(seed)
    return course


def summarize(args) -> dict:
    settings = {"rl": SETTINGS, "sp_rl": SP_SETTINGS}
    seeds = {m: {setting_name(s): per_seed(args.out, s, m) for s in settings[m]} for m in METHODS}
    first = json.loads(FIRST_SET.read_text()) if FIRST_SET.exists() else {"primary": []}
    first_rows = {(r["setting"], r["method"]): r for r in first["primary"]}
    rows = []
    for m, by_setting in seeds.items():
        base = list(by_setting["default"].values())
        for name in (n for n in by_setting if n != "default"):
            vals = list(by_setting[name].values())
            if min(len(vals), len(base)) < 2:
                continue
            d = welch(vals, base)
            rows.append({"setting": name, "method": m, "seeds": len(vals),
                     "baseline_seeds": len(base), "difference": d.difference,
                     "ci95": list(d.ci), "half_width": d.half_width,
                     "p_value": d.p_value})  # fmt: skip
    for row, p in zip(rows, holm([r["p_value"] for r in rows]), strict=True):
        lo, hi = row["ci95"]
        row["p_holm"] = float(p)
        row["verdict"] = "unresolved" if p >= 0.05 else ("lowers" if hi < 0 else "raises")
        then = first_rows.get((row["setting"], row["method"]))
        row["first_set"] = then and {k: then[k] for k in ("difference", "ci95", "verdict")}
        row["agrees"] = bool(then) and then["verdict"] == row["verdict"]
    courses = {
        m: {setting_name(s): training_course(args.out, s, m, seeds[m][setting_name(s)])
            for s in settings[m]}
        for m in METHODS
    }  # fmt: skip
    result = {"per_seed": seeds, "primary": rows, "training_course": courses}
    lines = [
        f"Second seed set (seeds {FIRST_SEED} on): each reading's effect on success at "
        f"{SPEED_MPS} m/s, reactive, against default (Welch 95 % CI over seeds; Holm over "
        "every effect of this set), beside the first set's (seeds 0-9).",
        "",
        "| setting | method | seeds (default) | effect [95 % CI] | half-width | p (Holm) "
        "| verdict | first set: effect [95 % CI], verdict | agree |",
        "|---|---|---:|---|---:|---:|---|---|---|",
    ]
    for r in rows:
        lo, hi = r["ci95"]
        f = r["first_set"]
        then = f"{f['difference']:+.3f} [{f['ci95'][0]:+.3f}, {f['ci95'][1]:+.3f}], {f['verdict']}"
        lines.append(
            f"| {r['setting']} | {r['method']} | {r['seeds']} ({r['baseline_seeds']}) "
            f"| {r['difference']:+.3f} "
            f"[{lo:+.3f}, {hi:+.3f}] | {r['half_width']:.3f} | {r['p_holm']:.3f} "
            f"| {r['verdict']} | {then if f else 'not measured'} "
            f"| {'yes' if r['agrees'] else 'no'} |"
        )
    lines += ["", f"Per-seed success at {SPEED_MPS} m/s on reactive.", ""]
    lines += ["| setting | method | seeds | per seed |", "|---|---|---:|---|"]
    for m, by_setting in seeds.items():
        for name, v in by_setting.items():
            cells = ", ".join(f"{k}: {x:.2f}" for k, x in v.items())
            lines.append(f"| {name} | {m} | {len(v)} | {cells} |")
    lines += [
        "",
        f"Seeds under {LOW} at {SPEED_MPS} m/s and how their training went (descriptive): "
        f"never learned to catch (best periodic evaluation under {LOW}), or learned and "
        f"lost it (ended more than {FELL_BY} below its best).",
        "",
        "| setting | method | seeds | under 0.5 | never learned | learned, lost it | other |",
        "|---|---|---:|---:|---|---|---|",
    ]
    for m, by_setting in courses.items():
        for name, c in by_setting.items():
            never, lost, other = (
                ", ".join(map(str, c[k])) or "-" for k in ("never", "lost", "other")
            )
            lines.append(
                f"| {name} | {m} | {len(seeds[m][name])} | {len(c['low'])} | {never} | {lost} "
                f"| {other} |"
            )
    write_summary(args.summary_dir, result, lines)
    return result


def run(argv: list[str] | None = None) -> int:
    ap = parser()
    summary_dir = Path("benchmarks/results/parity/second_set")
    ap.set_defaults(summary_dir=summary_dir, hidden_sizes=[128, 128, 64])
    args = ap.parse_args(argv)
    return run_study(args, list(passes(args)), summarize)


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    raise SystemExit(run())
