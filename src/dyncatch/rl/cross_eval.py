"""Cross-evaluation of a self-play study: every trained pursuer against every round's evader.

Each pursuer (a seed of a method in round k) plays, alone and with its mean action, the
learned evader of every round j (deterministic) and each scripted member of the league
alone (the reference rows), at the study's evaluation speeds: its catch rate and mean catch
time (a miss counts as the episode limit, as in the paper) per speed, on the episodes of the
exploitability evaluation (``exploitability.outcomes_at_speeds``: the same keys for every
pursuer and opponent).

Seeds are the unit: a row (method, pursuer round, opponent) gives the mean over seeds with
its t-interval (``evaluation.intervals.mean_ci``), per speed and averaged over the speeds;
the difference of two methods (``SelfPlayCfg.compare``, ``sp_rl - rl``) against each
opponent comes with Welch's interval (``evaluation.intervals.welch``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dyncatch.evaluation.intervals import CONFIDENCE, mean_ci, welch
from dyncatch.rl.exploitability import outcomes_at_speeds
from dyncatch.rl.policy import load_run
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world

OUTCOMES = ("success", "catch_time_s")
"""What each cell records per speed."""


@dataclass(frozen=True)
class Opponent:
    """A target every pursuer plays: ``round{j}`` (round j's learned evader) or a scripted
    behaviour's name, and the world it runs in."""

    name: str
    world: WorldCfg


def shared_policy(policy, world: WorldCfg):
    """``policy`` with its environment's target fields set to ``world``'s.

    A trained policy reads only the command limits (``world.base``) from its environment,
    but the target's static fields (the round's league members) are part of its structure:
    without this every round's pursuer would compile its own episode program."""
    env = policy.env
    return policy.replace(env=env.with_world(env.world.replace(target=world.target)))


def evaluate_runs(
    run_dirs: Sequence[Path],
    world: WorldCfg,
    speeds_mps: Sequence[float],
    episodes: int,
    eval_seed: int,
) -> dict:
    """Each run's outcomes in ``world`` (one compiled program for all runs of one method):
    ``success`` and ``catch_time_s``, (runs, S) lists."""
    world = validate_world(world)
    cells = [
        outcomes_at_speeds(
            shared_policy(load_run(run).policy, world), world, speeds_mps, episodes, eval_seed
        )
        for run in run_dirs
    ]
    return {"speeds_mps": list(speeds_mps)} | {name: [c[name] for c in cells] for name in OUTCOMES}


def _interval(ci) -> list[float] | None:
    return None if ci is None else [float(ci[0]), float(ci[1])]


def seed_stats(per_seed: np.ndarray, confidence: float = CONFIDENCE) -> dict:
    """(seeds, S) values as the mean over seeds with its t-interval (None with one seed):
    of the mean over speeds (``mean``, ``ci``) and per speed (``per_speed``,
    ``per_speed_ci``)."""
    x = np.asarray(per_seed, float)
    mean, ci = mean_ci(x.mean(axis=1), confidence)
    per_speed = [mean_ci(col, confidence) for col in x.T]
    return {
        "mean": mean,
        "ci": _interval(ci),
        "per_speed": [m for m, _ in per_speed],
        "per_speed_ci": [_interval(c) for _, c in per_speed],
    }


def cross_rows(cells: Sequence[dict], confidence: float = CONFIDENCE) -> list[dict]:
    """One row per cell ``{"method", "pursuer_round", "opponent", "result"}`` (a stage's
    ``evaluate_runs`` result): seeds, speeds and ``seed_stats`` of each outcome."""
    rows = []
    for c in cells:
        r = c["result"]
        row = {k: c[k] for k in ("method", "pursuer_round", "opponent")}
        row |= {"seeds": len(r["success"]), "speeds_mps": r["speeds_mps"]}
        row |= {name: seed_stats(r[name], confidence) for name in OUTCOMES}
        rows.append(row)
    return rows


def method_difference(a: Sequence[float], b: Sequence[float], confidence=CONFIDENCE) -> dict:
    """``mean(a) - mean(b)`` over seeds with Welch's interval and p-value (None with fewer
    than 2 seeds on a side)."""
    d = float(np.mean(a) - np.mean(b))
    if min(len(a), len(b)) < 2:
        return {"difference": d, "ci": None, "p_value": None}
    w = welch(a, b, confidence)
    return {"difference": w.difference, "ci": _interval(w.ci), "p_value": w.p_value}


def difference_rows(
    cells: Sequence[dict], compare: tuple[str, str], confidence: float = CONFIDENCE
) -> list[dict]:
    """``compare[0] - compare[1]`` per pursuer round and opponent where both methods were
    evaluated: each outcome averaged over the speeds per seed, then ``method_difference``."""
    a, b = compare
    by = {(c["method"], c["pursuer_round"], c["opponent"]): c["result"] for c in cells}
    rows = []
    for method, k, opponent in by:
        if method != a or (b, k, opponent) not in by:
            continue
        ra, rb = by[(a, k, opponent)], by[(b, k, opponent)]
        row = {"compare": [a, b], "pursuer_round": k, "opponent": opponent}
        for name in OUTCOMES:
            per_seed_a = np.asarray(ra[name], float).mean(axis=1)
            per_seed_b = np.asarray(rb[name], float).mean(axis=1)
            row[name] = method_difference(per_seed_a, per_seed_b, confidence)
        rows.append(row)
    return rows


def _fmt(mean: float, ci) -> str:
    return f"{mean:.3f}" + (f" [{ci[0]:.3f}, {ci[1]:.3f}]" if ci else "")


def cross_table(rows: Sequence[dict]) -> list[str]:
    """Markdown: one line per method, pursuer round and opponent; success per speed and
    over the speeds, catch time over the speeds, each mean over seeds [95 % t-interval]."""
    if not rows:
        return []
    speeds = rows[0]["speeds_mps"]
    head = " | ".join(f"success {s:g} m/s" for s in speeds)
    lines = [
        f"| method | pursuer round | opponent | seeds | {head} | success | catch time (s) |",
        "|---|---|---|---|" + "---|" * len(speeds) + "---|---|",
    ]
    for r in rows:
        s, t = r["success"], r["catch_time_s"]
        pairs = zip(s["per_speed"], s["per_speed_ci"], strict=True)
        per = " | ".join(_fmt(m, c) for m, c in pairs)
        lines.append(
            f"| {r['method']} | {r['pursuer_round']} | {r['opponent']} | {r['seeds']} | {per} "
            f"| {_fmt(s['mean'], s['ci'])} | {_fmt(t['mean'], t['ci'])} |"
        )
    return lines


def difference_table(rows: Sequence[dict]) -> list[str]:
    """Markdown: one line per pursuer round and opponent, the difference over the speeds
    [95 % Welch interval] and its p-value."""
    if not rows:
        return []
    a, b = rows[0]["compare"]
    lines = [
        f"| pursuer round | opponent | success {a} - {b} | p | catch time (s) {a} - {b} | p |",
        "|---|---|---|---|---|---|",
    ]
    for r in rows:
        s, t = r["success"], r["catch_time_s"]
        p = [("-" if x["p_value"] is None else f"{x['p_value']:.3f}") for x in (s, t)]
        lines.append(
            f"| {r['pursuer_round']} | {r['opponent']} | {_fmt(s['difference'], s['ci'])} "
            f"| {p[0]} | {_fmt(t['difference'], t['ci'])} | {p[1]} |"
        )
    return lines
