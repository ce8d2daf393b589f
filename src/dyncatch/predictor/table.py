"""Table II: prediction error ||v_hat - v||_2 (m/s) per behaviour, kind and data budget.

Each behaviour's training data are collected once at the largest budget; smaller budgets
train on its prefix (``data.budget_count``). Errors are measured on held-out episodes drawn
from a different seed. Writing files (Markdown, CSV, PNG) lives at the end, in ``write``.

The ``tracker`` kind (not in the default kinds; ``--kinds tracker``) has rows of its own
(``predictor.tracker.table``): its ``error_mps`` is the current velocity's error, and it adds
``position_error_m``, ``hold_position_error_m`` and ``coverage95``.
"""

from __future__ import annotations

import csv
import json
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import jax

from dyncatch.predictor.config import TRACKER, CollectCfg, PredictorCfg, TrainCfg
from dyncatch.predictor.data import budget_count, collect
from dyncatch.predictor.features import FEATURES
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.tracker.config import TrackerCfg, TrackerDataCfg, TrackerTrainCfg
from dyncatch.predictor.tracker.pipeline import write_error_vs_time
from dyncatch.predictor.tracker.table import tracker_rows
from dyncatch.predictor.train import encode_samples, evaluate, fit
from dyncatch.sim.behaviors import get_behavior, scripted_behaviors
from dyncatch.sim.config import WorldCfg


def all_behaviors() -> tuple[str, ...]:
    """Every registered scripted target behaviour, read when called (a behaviour registered
    at run time is included; ``learned``, which needs a checkpoint, is named explicitly)."""

    return scripted_behaviors()


def all_kinds() -> tuple[str, ...]:
    """Every predictor kind (``dyncatch.predictor.features.FEATURES``)."""

    return tuple(FEATURES)


@dataclass(frozen=True)
class TableCfg:
    """The grid of Table II."""

    budgets: tuple[int, ...]
    """Columns: interaction budgets in simulator steps (the paper's:
    ``dyncatch.reproduce.paper.PAPER_BUDGETS``)."""
    behaviors: tuple[str, ...] = field(default_factory=all_behaviors)
    """Rows: target behaviours (default every registered one)."""
    kinds: tuple[str, ...] = field(default_factory=all_kinds)
    """Predictor kinds per behaviour (default every frame predictor's; ``tracker`` too if
    named)."""
    eval_steps: int = 500_000
    """Interaction steps of held-out episodes per behaviour."""
    seed: int = 0
    """Seed of collection, held-out episodes (another stream) and initialisation."""


def run_table(
    table: TableCfg,
    predictor_cfg: PredictorCfg,
    train_cfg: TrainCfg,
    collect_cfg: CollectCfg,
    world: WorldCfg,
    on_cell: Callable[[dict], None] | None = None,
    tracker: tuple[TrackerCfg, TrackerTrainCfg, TrackerDataCfg] | None = None,
    paper_errors: Mapping[tuple[str, str, int], float] | None = None,
) -> list[dict]:
    """Rows ``{"behavior", "behavior_params", "kind", "budget_steps", "error_mps",
    "paper_error_mps", "train_samples", "eval_samples", "seconds"}``, one per cell
    (``behavior_params``: the behaviour's own fields, ``learned``'s evader file among them,
    so rows of two evaders differ; tracker rows: see
    ``predictor.tracker.table``; ``tracker`` is its configs, default the library's).
    ``paper_errors`` are the published errors by (behaviour, kind, budget), shown beside
    ours (``dyncatch.reproduce.paper.PAPER_TABLE_II_ERRORS``); a cell without one has None."""
    paper_errors = paper_errors or {}

    rows = []
    key = jax.random.key(table.seed)
    k_train, k_eval, k_fit = jax.random.split(key, 3)
    frame_kinds = [k for k in table.kinds if k != TRACKER]
    for behavior in table.behaviors:
        w = world.with_behavior(behavior)
        own = get_behavior(behavior).params(w.target)
        if TRACKER in table.kinds:
            setup = tracker or (TrackerCfg(), TrackerTrainCfg(), TrackerDataCfg())
            keys = (k_train, k_eval, k_fit)
            found = tracker_rows(
                behavior, w, table.budgets, table.eval_steps, keys, *setup, on_cell
            )
            rows += [{**r, "behavior_params": own} for r in found]
        if not frame_kinds:
            continue
        train, _ = collect(k_train, w, collect_cfg, max(table.budgets))
        held_out, _ = collect(k_eval, w, collect_cfg, table.eval_steps)
        for kind in frame_kinds:
            predictor = Predictor.for_world(
                PredictorCfg(kind=kind, frame=predictor_cfg.frame, hidden=predictor_cfg.hidden),
                w,
            )
            enc_train = encode_samples(predictor, train)
            enc_eval = encode_samples(predictor, held_out)
            for budget in sorted(table.budgets):
                t0 = time.perf_counter()
                n = budget_count(train, w, collect_cfg, budget)
                params, _ = fit(predictor, train_cfg, enc_train, train.label_mps, n, k_fit)
                error = evaluate(predictor, params, enc_eval, held_out.label_mps)
                row = {
                    "behavior": behavior,
                    "behavior_params": own,
                    "kind": kind,
                    "budget_steps": budget,
                    "error_mps": error,
                    "paper_error_mps": paper_errors.get((behavior, kind, budget)),
                    "train_samples": n,
                    "eval_samples": len(held_out.label_mps),
                    "seconds": time.perf_counter() - t0,
                }
                rows.append(row)
                if on_cell is not None:
                    on_cell(row)
    return rows


def _fmt(x: float | None) -> str:
    return "-" if x is None else f"{x:.3f}"


def markdown(rows: list[dict]) -> str:
    budgets = sorted({r["budget_steps"] for r in rows})
    head = " | ".join(f"{b / 1e6:g}M ours (paper)" for b in budgets)
    lines = [f"| behavior | predictor | {head} |", "|---|---|" + "---:|" * len(budgets)]
    cells = {(r["behavior"], r["kind"], r["budget_steps"]): r for r in rows}
    for behavior in dict.fromkeys(r["behavior"] for r in rows):
        for kind in dict.fromkeys(r["kind"] for r in rows):
            vals = []
            for b in budgets:
                r = cells.get((behavior, kind, b))
                vals.append(
                    "" if r is None else f"{r['error_mps']:.3f} ({_fmt(r['paper_error_mps'])})"
                )
            lines.append(f"| {behavior} | {kind} | {' | '.join(vals)} |")
    return "\n".join(lines)


TRACKER_KEYS = ("position_error_m", "hold_position_error_m", "coverage95")
"""What a tracker row adds to a Table II row."""


def tracker_markdown(rows: list[dict]) -> str:
    """The tracker's rows: 50 Hz position errors (m) and coverage of the 95 % region."""
    lines = [
        "| behavior | budget | position error (m) | last sighting (m) | coverage95 "
        "| velocity error (m/s) |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        if "position_error_m" in r:
            lines.append(
                f"| {r['behavior']} | {r['budget_steps'] / 1e6:g}M | {r['position_error_m']:.3f} "
                f"| {r['hold_position_error_m']:.3f} | {r['coverage95']:.3f} "
                f"| {r['error_mps']:.3f} |"
            )
    return "\n".join(lines)


def write(rows: list[dict], out: Path, header: str = "") -> list[Path]:
    """table_ii.md, table_ii.csv and table_ii.png (error vs budget) under ``out``; with
    tracker rows, also tracker_{behavior}_error_vs_time.{csv,png} (error against the time
    since the last sighting, the largest budget)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out.mkdir(parents=True, exist_ok=True)
    by_time = {
        r["behavior"]: r["by_time_since_sighting"] for r in rows if "by_time_since_sighting" in r
    }
    rows = [{k: v for k, v in r.items() if k != "by_time_since_sighting"} for r in rows]
    md, csv_path, png = out / "table_ii.md", out / "table_ii.csv", out / "table_ii.png"
    text = (header + "\n\n" if header else "") + markdown(rows) + "\n"
    if by_time:
        text += "\nTracker (50 Hz, held-out episodes):\n\n" + tracker_markdown(rows) + "\n"
    md.write_text(text)
    with csv_path.open("w", newline="") as f:
        fields = list(dict.fromkeys(k for r in rows for k in r))
        writer = csv.DictWriter(f, fieldnames=fields, restval="")
        writer.writeheader()
        writer.writerows(
            {k: json.dumps(v) if isinstance(v, dict) else v for k, v in r.items()} for r in rows
        )
    paths = []
    for behavior, bins in by_time.items():
        for p in write_error_vs_time(bins, out, behavior):
            paths.append(p.rename(out / f"tracker_{behavior}_{p.name}"))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    styles = ("--", "-", ":", "-.")
    kinds = list(dict.fromkeys(r["kind"] for r in rows))
    for behavior in dict.fromkeys(r["behavior"] for r in rows):
        for kind, style in zip(kinds, styles * len(kinds), strict=False):
            sel = [r for r in rows if r["behavior"] == behavior and r["kind"] == kind]
            if sel:
                xs = [r["budget_steps"] / 1e6 for r in sel]
                (line,) = ax.plot(
                    xs, [r["error_mps"] for r in sel], style, marker="o", label=f"{behavior} {kind}"
                )
                # The paper's values as crosses of the same colour (zeros cannot go on a log axis).
                paper = [(x, r["paper_error_mps"]) for x, r in zip(xs, sel, strict=True)]
                paper = [(x, e) for x, e in paper if e]
                if paper:
                    ax.plot(*zip(*paper, strict=True), "x", color=line.get_color(), ms=8)
    ax.set_title("Table II: ours (lines), paper (crosses)", fontsize=9)
    ax.set_xlabel("interaction steps (M)")
    ax.set_ylabel("error ||v_hat - v||_2 (m/s)")
    ax.set_yscale("log")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)
    return [md, csv_path, png, *paths]
