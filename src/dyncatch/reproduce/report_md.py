"""``report.md``: the reproduction's results (``results.json``) as one Markdown page."""

from __future__ import annotations

from dyncatch.reproduce import fig9_report, report, verdicts
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.report import label
from dyncatch.rl.methods import trained_methods


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
        f"- {plan.seeds} seed(s) (seeds {plan.first_seed}-{plan.seed_ids[-1]}) x "
        f"{len(trained_methods(plan.method_names))} learned methods x "
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
        "## Primary endpoints",
        "",
        "Declared in the plan before it ran (plan.json, `--primary-endpoints`) and judged "
        "each on its own, unadjusted: the difference with its 95 % CI (Welch over seeds with "
        "2+ seeds, else normal on pooled episodes), the smallest difference this run resolves "
        "(the CI's half-width) and the seeds per method 80 % power needs at the margin. "
        "Resolved: the CI excludes 0; equivalent: it lies inside +-margin; else unresolved. "
        "The paper's value is Table I's difference, where it gives both methods. Against "
        "the paper: reproduced (the CI excludes 0 on the paper's side and holds its value), "
        "direction reproduced but smaller or larger (it excludes 0, not the paper's value), "
        "contradicted (it excludes 0 on the other side, or lies inside +-margin while the "
        "paper's value does not), unresolved (it spans 0; 'paper's value excluded' where it "
        "spans 0 but not the paper's value).",
        "",
        report.primary_markdown(r["primary_endpoints"]),
        "",
    ]
    v = r.get("verdicts")
    if v and (v["orderings"] or v["levels"] or v.get("predictors")):
        lines += [
            "## Verdicts on the paper's numbers, claim by claim",
            "",
            "Each ordering the paper's Table I makes at the speeds judged here (its "
            "difference against ours, judged as above: a primary endpoint on its own, a "
            "secondary check only where its Holm-adjusted p-value resolves it), then each "
            "learned method's success, and Fig. 9's where the paper's text gives it, "
            "against the paper's value (level: our CI over seeds holds it, or lies above or "
            "below it), then Table II's self-aware predictor against the vanilla one (one "
            "predictor a cell: the sign only).",
            "",
            verdicts.verdicts_markdown(v["orderings"], v["levels"], v.get("predictors", [])),
            "",
        ]
    cells, averages = r["table_i"]["cells"], r["table_i"]["average"]
    for behavior in plan.table_i_rows:
        lines += [
            f"## Table I: {behavior}",
            "",
            report.table_i_markdown(cells, averages, behavior, plan.speeds_mps),
            "",
        ]
    if plan.table_i_rows:
        lines += ["![Table I](figures/table_i.png)", ""]
    lines += [
        "## Secondary checks: the paper's ordering at high speed",
        "",
        "Each claim is judged on success (first method's rate minus second's; 95 % CI "
        "Welch over seeds with 2+ seeds, else normal on pooled episodes) and, with 2+ "
        "seeds, on catch time (second method's mean catch time minus first's, the seconds "
        "the first saves; Welch CI over seeds). 'holds' means the CI is above 0. Every check "
        "of this table and the headroom's that is not a primary endpoint is secondary: one "
        "family, judged on Holm-adjusted p-values (p (Holm)); the primary rows repeat the "
        "table above.",
        "",
        report.checks_markdown(r["ordering_checks"]),
        "",
    ]
    if r.get("headroom"):
        lines += [
            "## Secondary checks: headroom, the oracle against the best non-oracle method",
            "",
            "At each speed, the policy that reads the target's true velocity against the best "
            "method that does not (highest success, then shortest catch time), judged as the "
            "claims above, in the same Holm family. 'holds': the benchmark leaves measurable "
            "room to improve.",
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
    lines += [
        "",
        f"## Fig. 6: {plan.fig6_speed_mps} m/s on {', '.join(plan.fig6_columns)}",
        "",
        "Each policy on the behaviour it was trained on, with that behaviour's predictor "
        "(the paper's protocol).",
        "",
        report.fig6_markdown(r["fig6"]["cells"]),
        "",
        "![Fig. 6](figures/fig6_high_speed.png)",
        "",
    ]
    if r.get("transfer"):
        lines += [
            f"## Transfer (beyond the paper): trained on {plan.transfer_from}, "
            f"{plan.fig6_speed_mps} m/s",
            "",
            f"The policies and predictors trained on {plan.transfer_from}, tested on "
            "behaviours they were not trained on; not the paper's protocol (Fig. 6 above is).",
            "",
            report.fig6_markdown(r["transfer"]["cells"]),
            "",
        ]
    if r["table_ii"]:
        lines += [
            "## Table II: predictor error ||v_hat - v|| (m/s), ours (paper)",
            "",
            report.table_ii_markdown(r["table_ii"]),
            "",
            "![Table II](table_ii/table_ii.png)",
            "",
        ]
    lines += [
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
                f"- {label(c['method'])} [{c['behavior']}]({c['file']}) at "
                f"{c['speed_mps']} m/s, policy trained on {c['trained_on']}: {outcome}"
            )
    if r["wall"].get("stages_estimate_s"):
        lines += [
            "",
            "## Wall time by stage",
            "",
            "Measured over every invocation of this command (`wall.json`; the time between "
            "stages, the report's included, is in the total only) against the estimate "
            "printed before the first stage (`reproduce/estimate.py`): on the reference machine "
            "it was fit on and, where the run probed its own (`dyncatch bench machine`), "
            "scaled to this one.",
            "",
            report.stage_times_markdown(r["wall"]),
        ]
        if r["wall"].get("machine_speed"):
            m = r["wall"]["machine_speed"]
            lines += [
                "",
                f"This machine's probe, last invocation: {m['compute']:.2f}x the reference's "
                f"time to compute, {m['compile']:.2f}x to compile.",
            ]
    return "\n".join(lines) + "\n"
