"""What a reproduction concludes from its stages' results: the cells over seeds, the
paper's claims and the headroom judged, the training summary, the figures, and
``results.json``'s content."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dyncatch.bench.machine import machine_info
from dyncatch.reproduce import aggregate, fig9, fig9_report, report, verdicts
from dyncatch.reproduce.endpoints import against_paper
from dyncatch.reproduce.paper import paper_difference
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.presentation import paper_claims
from dyncatch.reproduce.readings import setting_name
from dyncatch.reproduce.robust import improvement_probabilities, robust_summary
from dyncatch.rl.methods import METHODS


def time_to_success(curve: dict, threshold: float = 0.9) -> dict:
    """First periodic evaluation whose success rate reaches ``threshold``: samples and
    training wall seconds (None if never)."""
    hit = np.flatnonzero(curve["eval_success_rate"] >= threshold)
    if not hit.size:
        return {"samples": None, "time_s": None}
    i = int(hit[0])
    return {"samples": int(curve["eval_env_steps"][i]), "time_s": float(curve["eval_time_s"][i])}


def training_rows(data: dict, seed_ids=None) -> list[dict]:
    """A row per training run of ``report.curves``: final evaluation, wall seconds, and
    the samples and seconds to 0.9 success; ``seed_ids`` names the stacked seeds (default
    0, 1, ...)."""
    training = []
    for (behavior, method), d in data.items():
        for s in range(d["env_steps"].shape[0]):
            curve = {k: v[s] for k, v in d.items()}
            training.append(
                {
                    "behavior": behavior,
                    "method": method,
                    "seed": s if seed_ids is None else seed_ids[s],
                    "final_eval_success_rate": float(curve["eval_success_rate"][-1])
                    if curve["eval_success_rate"].size
                    else None,
                    "wall_s": float(curve["time_s"][-1]),
                    "to_0.9": time_to_success(curve),
                }
            )
    return training


def high_speeds(plan: Plan) -> list[float]:
    """The plan's speeds the ordering claims are judged at: the paper's high speeds (1.6 m/s
    and up), else the fastest."""
    return [v for v in plan.speeds_mps if v >= 1.6 - 1e-9] or [max(plan.speeds_mps)]


def judge(plan: Plan, cells: list[dict], averages: list[dict]) -> tuple[list, list]:
    """(the paper's ordering claims at high speed and on the average, the oracle's
    headroom over the best non-oracle method at each speed), judged as one family: the
    plan's primary endpoints alone, every other check under one Holm correction."""
    high = high_speeds(plan)
    claims = paper_claims(plan.method_names)
    ordering = aggregate.ordering_gaps(cells, high, claims)
    ordering += aggregate.ordering_gaps(averages, [None], claims)
    chosen = [METHODS[n] for n in plan.method_names]
    rivals = [m.name for m in chosen if not m.oracle]
    headroom = [
        c
        for m in chosen
        if m.oracle
        for c in aggregate.headroom_gaps(cells, plan.speeds_mps, m.name, rivals)
    ]
    judged = aggregate.judge_family(ordering + headroom, plan.primary_endpoints)
    return judged[: len(ordering)], judged[len(ordering) :]


def primary_rows(plan: Plan, checks: list[dict]) -> dict:
    """The plan's declared endpoints (``plan.json``'s record), those this run measured, one
    row each with the paper's difference where Table I gives both methods, and those it
    could not measure (outside its Table I rows, speeds or methods)."""
    rows = []
    for c in checks:
        if c.get("role") != "primary":
            continue
        winner, _, loser = c["claim"].partition(" > ")
        paper = None
        if c["kind"] == "ordering":
            paper = paper_difference(c["behavior"], winner, loser, c["speed_mps"], c["metric"])
        verdict = against_paper(tuple(c["ci95"]), paper, c["resolution"], c["margin"])
        rows.append({**c, "paper_difference": paper, "against_paper": verdict})
    measured = {r["endpoint"] for r in rows}
    declared = [e.name for e in plan.primary_endpoints]
    return {
        "declared": declared,
        "measured": rows,
        "not_measured": [n for n in declared if n not in measured],
    }


def results(plan: Plan, out: Path, outputs: dict, command: str, commit: str) -> dict:
    """``results.json``'s content from the stages' ``outputs`` (by stage name), its
    ``wall`` left to the caller; writes the figures under ``out/figures``."""
    t1_rows, fig6_rows = outputs["table_i"], outputs["fig6"]
    fig9_rows = outputs.get("fig9") or []
    cells = aggregate.summarize_cells(t1_rows)
    averages = aggregate.average_column(cells)
    checks, headroom = judge(plan, cells, averages)
    fig6_cells = aggregate.summarize_cells(fig6_rows)
    data = report.curves(plan, out)

    figs = out / "figures"
    figs.mkdir(exist_ok=True)
    report.plot_fig5(plan, data, figs / "fig5_learning_curves.png")
    evaluated = {c["method"] for c in fig6_cells}
    report.plot_fig6(
        fig6_cells,
        [m for m in report.policy_order() if m in evaluated],
        plan.fig6_columns,
        figs / "fig6_high_speed.png",
        plan.fig6_speed_mps,
    )
    report.plot_table_i(cells, plan.table_i_rows, figs / "table_i.png")
    fig9_cells = fig9.summarize(fig9_rows)
    if plan.fig9:
        fig9_report.plot(fig9_cells, plan.fig9_scenes, plan.fig9_columns, figs / "fig9.png")

    return {
        "scene": plan.world.scene.name,
        "setting": setting_name(plan.setting),
        "command": command,
        "commit": commit,
        "machine": machine_info(),
        "wall": None,
        "plan": plan.to_json(),
        "table_i": {"cells": cells, "average": averages, "rows": t1_rows},
        "primary_endpoints": primary_rows(plan, checks + headroom),
        "ordering_checks": checks,
        "verdicts": {
            "orderings": verdicts.ordering_rows(checks),
            "levels": verdicts.level_rows(cells, high_speeds(plan))
            + verdicts.fig9_level_rows(fig9_cells, plan.fig9_speed_mps),
            "predictors": verdicts.predictor_rows(outputs.get("table_ii") or []),
        },
        "headroom": headroom,
        "robust_summary": robust_summary(cells, plan.speeds_mps, plan.method_names),
        "improvement_probabilities": improvement_probabilities(
            cells, plan.speeds_mps, paper_claims(plan.method_names)
        ),
        "table_ii": outputs.get("table_ii") or [],
        "predictors": outputs["predictors"],
        "fig6": {"cells": fig6_cells, "rows": fig6_rows},
        "transfer": {
            "trained_on": plan.transfer_from,
            "cells": aggregate.summarize_cells(outputs["transfer"]),
            "rows": outputs["transfer"],
        }
        if outputs.get("transfer")
        else None,
        "training": training_rows(data, plan.seed_ids),
        "videos": outputs.get("videos") or [],
        "fig9": {
            "cells": fig9_cells,
            "rows": fig9_rows,
            "paper": fig9_report.paper_json(),
            "videos": outputs.get("fig9_videos") or [],
        }
        if plan.fig9
        else None,
    }
