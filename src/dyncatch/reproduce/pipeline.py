"""Run every stage of a reproduction in order, then write the report.

The stages are cached (``stages.py``), so this is also the resume path: re-running the
same command skips what is finished and continues an interrupted training run. Each
stage's independent jobs run on the plan's executor (``executors.py``: here, or on Ray).
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable

import numpy as np

from dyncatch.reproduce import aggregate, executors, fig9, fig9_report, layout, report, stages
from dyncatch.reproduce.plan import Plan, estimate_s
from dyncatch.rl.methods import METHODS, paper_claims, trained_methods
from dyncatch.utils.files import read_json


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "") or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def time_to_success(curve: dict, threshold: float = 0.9) -> dict:
    """First periodic evaluation whose success rate reaches ``threshold``: samples and
    training wall seconds (None if never)."""
    hit = np.flatnonzero(curve["eval_success_rate"] >= threshold)
    if not hit.size:
        return {"samples": None, "time_s": None}
    i = int(hit[0])
    return {"samples": int(curve["eval_env_steps"][i]), "time_s": float(curve["eval_time_s"][i])}


def run(plan: Plan, command: str, log: Callable[[str], None], progress=None) -> dict:
    """Every stage of ``plan`` into ``plan.out_dir``; ``log`` gets one line per stage and
    ``progress`` (``dyncatch.utils.progress``) the bars of long stages."""
    out = plan.out_dir
    t_start = time.perf_counter()
    say = log

    def log(msg: str) -> None:
        say(f"[{time.perf_counter() - t_start:6.0f} s] {msg}")

    out.mkdir(parents=True, exist_ok=True)
    layout.check_plan(out, plan)
    log(
        f"estimated wall time for the whole plan on 2 cores: {estimate_s(plan) / 60:.0f} min "
        "(finished stages are skipped)"
    )

    executor = executors.make_executor(plan, log, progress)
    try:
        log("stage 1/7: frozen predictors")
        predictors = stages.train_predictors(plan, out, executor)
        log("stage 2/7: Table II")
        table_ii = stages.table_ii(plan, out, executor)
        log(f"stage 3/7: {plan.training_runs} training runs")
        stages.train_policies(plan, out, executor)
        log("stage 4/7: Table I evaluation")
        t1_rows = stages.evaluate_grid(
            plan, out, "table_i", plan.table_i_rows, plan.speeds_mps, executor
        )
        log("stage 5/7: Fig. 6 evaluation")
        behaviors = plan.fig6_columns
        fig6_rows = stages.fig6_grid(plan, out, t1_rows, executor)
        clips = []
        if plan.videos:
            log("stage 6/7: videos")
            clips = stages.record_videos(plan, out, executor)
        fig9_rows, fig9_clips = [], []
        if plan.fig9:
            log("stage 7/7: Fig. 9 (rooms and woods)")
            fig9_rows = fig9.evaluate(plan, out, executor)
            if plan.videos:
                fig9_clips = fig9.record_videos(plan, out, executor)
    finally:
        executor.close()

    cells = aggregate.summarize_cells(t1_rows)
    averages = aggregate.average_column(cells)
    high = [v for v in plan.speeds_mps if v >= 1.6 - 1e-9] or [max(plan.speeds_mps)]
    claims = paper_claims(plan.method_names)
    checks = aggregate.ordering_checks(cells, high, claims)
    checks += aggregate.ordering_checks(averages, [None], claims)
    chosen = [METHODS[n] for n in plan.method_names]
    rivals = [m.name for m in chosen if not m.oracle]
    headroom = [
        c
        for m in chosen
        if m.oracle
        for c in aggregate.headroom_checks(cells, plan.speeds_mps, m.name, rivals)
    ]
    fig6_cells = aggregate.summarize_cells(fig6_rows)
    data = report.curves(plan, out)
    training = []
    for (behavior, method), d in data.items():
        for s in range(d["env_steps"].shape[0]):
            curve = {k: v[s] for k, v in d.items()}
            training.append(
                {
                    "behavior": behavior,
                    "method": method,
                    "seed": s,
                    "final_eval_success_rate": float(curve["eval_success_rate"][-1])
                    if curve["eval_success_rate"].size
                    else None,
                    "wall_s": float(curve["time_s"][-1]),
                    "to_0.9": time_to_success(curve),
                }
            )

    figs = out / "figures"
    figs.mkdir(exist_ok=True)
    report.plot_fig5(plan, data, figs / "fig5_learning_curves.png")
    evaluated = {c["method"] for c in fig6_cells}
    report.plot_fig6(
        fig6_cells,
        [m for m in report.policy_order() if m in evaluated],
        behaviors,
        figs / "fig6_high_speed.png",
        plan.fig6_speed_mps,
    )
    report.plot_table_i(cells, plan.table_i_rows, figs / "table_i.png")
    fig9_cells = fig9.summarize(fig9_rows)
    if plan.fig9:
        fig9_report.plot(fig9_cells, plan.fig9_scenes, plan.fig9_behaviors, figs / "fig9.png")

    wall_path = out / "wall.json"
    previous = read_json(wall_path)["total_s"] if wall_path.exists() else 0.0
    this_s = time.perf_counter() - t_start
    wall = {"this_invocation_s": this_s, "total_s": previous + this_s}
    layout.write_json(wall_path, wall)

    from dyncatch.bench.machine import machine_info
    from dyncatch.reproduce.readings import setting_name

    results = {
        "scene": plan.world.scene.name,
        "setting": setting_name(plan.setting),
        "command": command,
        "commit": _commit(),
        "machine": machine_info(),
        "wall": wall,
        "plan": plan.to_json(),
        "table_i": {"cells": cells, "average": averages, "rows": t1_rows},
        "ordering_checks": checks,
        "headroom": headroom,
        "table_ii": table_ii,
        "predictors": predictors,
        "fig6": {"cells": fig6_cells, "rows": fig6_rows},
        "training": training,
        "videos": clips,
        "fig9": {
            "cells": fig9_cells,
            "rows": fig9_rows,
            "paper": fig9_report.paper_json(),
            "videos": fig9_clips,
        }
        if plan.fig9
        else None,
    }
    layout.write_json(out / "results.json", results)
    (out / "report.md").write_text(render_report(results, plan))
    log(f"wrote {out / 'report.md'} and {out / 'results.json'} ({this_s / 60:.1f} min)")
    return results


def render_report(r: dict, plan: Plan) -> str:
    m = r["machine"]
    lines = [
        f"# dyncatch reproduction ({plan.profile} profile)",
        "",
        f"- scene: `{r['scene']}` (docs/model.md); setting: `{r['setting']}` (readings of "
        "the paper, docs/fidelity.md)",
        f"- command: `{r['command']}`",
        f"- commit: `{r['commit']}`",
        f"- machine: {m['cpu']}, {m['cores']} cores, jax {m['jax']} ({m['backend']})",
        f"- wall time: {r['wall']['total_s'] / 60:.1f} min in all "
        f"({r['wall']['this_invocation_s'] / 60:.1f} min in the last invocation)",
        f"- {plan.seeds} seed(s) x {len(trained_methods(plan.method_names))} learned methods x "
        f"{len(plan.behaviors)} "
        f"behaviours, {plan.train_steps / 1e6:g} M environment steps per run, "
        f"{plan.episodes} evaluation episodes per cell (the same evaluation seeds for every "
        "policy, disjoint from training).",
        "",
        "**Our numbers come from dyncatch's JAX simulator, not the paper's Isaac Gym set-up;"
        " the paper's values are shown beside ours for reference only.** Cells are success "
        "rate [95 % CI] / mean catch time (s, a failure counts as the 20 s limit). The CI is "
        "over seeds (Student t) when there are 2+ seeds, else the Wilson interval over "
        "episodes; baselines (pursuit, intercept) have no seeds.",
        "",
    ]
    cells, averages = r["table_i"]["cells"], r["table_i"]["average"]
    for behavior in plan.table_i_rows:
        src = layout.source_behavior(plan, behavior)
        lines += [
            f"## Table I: {behavior}"
            + ("" if src == behavior else f" (policies trained on {src}: transfer)"),
            "",
            report.table_i_markdown(cells, averages, behavior, plan.speeds_mps),
            "",
        ]
    lines += [
        "![Table I](figures/table_i.png)",
        "",
        "## The paper's ordering at high speed",
        "",
        "Each claim is judged on success (first method's rate minus second's; 95 % CI "
        "Welch over seeds with 2+ seeds, else normal on pooled episodes) and, with 2+ "
        "seeds, on catch time (second method's mean catch time minus first's, the seconds "
        "the first saves; Welch CI over seeds). 'holds' means the CI is above 0.",
        "",
        report.checks_markdown(r["ordering_checks"]),
        "",
    ]
    if r.get("headroom"):
        lines += [
            "## Headroom: the oracle against the best non-oracle method",
            "",
            "At each speed, the policy that reads the target's true velocity against the best "
            "method that does not (highest success, then shortest catch time), judged as the "
            "claims above. 'holds': the benchmark leaves measurable room to improve.",
            "",
            report.checks_markdown(r["headroom"]),
            "",
        ]
    lines += [
        "## Fig. 5: learning curves",
        "",
        "![Fig. 5](figures/fig5_learning_curves.png)",
        "",
        "Top: periodic evaluations of the mean-action policy during training (same "
        "evaluation seeds each time). Wall seconds are training time, compilation "
        "included and evaluations excluded.",
        "",
        f"| behaviour | method | seed | final success at {plan.fig6_speed_mps} m/s | "
        "samples to 0.9 | "
        "wall s to 0.9 | run wall s |",
        "|---|---|---:|---:|---:|---:|---:|",
    ]
    for t in r["training"]:
        s, w, total = t["to_0.9"]["samples"], t["to_0.9"]["time_s"], t["wall_s"]
        s = "-" if s is None else f"{s / 1e6:.2f} M"
        w = "-" if w is None else f"{w:.0f}"
        total = "-" if total is None else f"{total:.0f}"
        final = t["final_eval_success_rate"]
        final = "-" if final is None else f"{final:.3f}"
        lines.append(
            f"| {t['behavior']} | {t['method']} | {t['seed']} | {final} | {s} | {w} | {total} |"
        )
    src = ", ".join(f"{b} -> {layout.source_behavior(plan, b)}" for b in plan.fig6_columns)
    lines += [
        "",
        f"## Fig. 6: {plan.fig6_speed_mps} m/s on {', '.join(plan.fig6_columns)}",
        "",
        f"Policies evaluated on a behaviour they were not trained on come from the first "
        f"trained behaviour (evaluated -> trained on: {src}).",
        "",
        report.fig6_markdown(r["fig6"]["cells"]),
        "",
        "![Fig. 6](figures/fig6_high_speed.png)",
        "",
    ]
    lines += [
        "## Table II: predictor error ||v_hat - v|| (m/s), ours (paper)",
        "",
        report.table_ii_markdown(r["table_ii"]),
        "",
        "![Table II](table_ii/table_ii.png)",
        "",
        "Frozen predictors the methods read (held-out velocity error, m/s; the tracker's is "
        "its current velocity's, with its 50 Hz position error and coverage95):",
        "",
    ]
    for p in r["predictors"]:
        track = ""
        if "position_error_m" in p:
            track = (
                f", position {p['position_error_m']:.3f} m (last sighting "
                f"{p['hold_position_error_m']:.3f} m), coverage95 {p['coverage95']:.3f}"
            )
        lines.append(
            f"- {p['behavior']} {p['kind']}: {p['error_mps']:.3f}{track} "
            f"({p['budget_steps'] / 1e6:g} M steps)"
        )
    if r["fig9"] is not None:
        lines += ["", *fig9_report.markdown(r["fig9"], plan)]
    if r["videos"]:
        lines += ["", "## Videos, with the FoV cone and the predicted-velocity arrow", ""]
        for c in r["videos"]:
            outcome = f"caught at {c['catch_time_s']:.1f} s" if c["caught"] else "not caught"
            lines.append(
                f"- {METHODS[c['method']].label} [{c['behavior']}]({c['file']}) at "
                f"{c['speed_mps']} m/s, policy trained on {c['trained_on']}: {outcome}"
            )
    return "\n".join(lines) + "\n"
