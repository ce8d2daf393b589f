"""Figures, ``report.md`` and ``results.json`` from the cached stage outputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dyncatch.policies.registry import BASELINES
from dyncatch.predictor.table import markdown as table_ii_rows_markdown
from dyncatch.reproduce.layout import run_dir
from dyncatch.reproduce.paper import paper_cell
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.presentation import PRESENTATION
from dyncatch.rl.logging import read_metrics
from dyncatch.rl.methods import trained_methods


def _registry() -> dict:
    """Every evaluated policy (methods, then baselines) by name, in table order, with its
    ``label`` and ``color``."""
    return {**PRESENTATION, **BASELINES}


def policy_order() -> tuple[str, ...]:
    return tuple(_registry())


def label(name: str) -> str:
    return _registry()[name].label


def color(name: str) -> str:
    return _registry()[name].color


def read_curve(run: Path) -> dict[str, np.ndarray]:
    """Per-iteration training columns, and the periodic evaluations (``eval_*``, on the
    iterations where the run evaluated its mean-action policy)."""
    rows = read_metrics(run / "metrics.csv", "delete the run's folder to retrain it")
    keys = ("env_steps", "success_rate", "reward_per_step", "time_s")
    curve = {k: np.array([float(r[k]) for r in rows]) for k in keys}
    evaluated = [r for r in rows if r.get("eval/success_rate")]
    curve["eval_env_steps"] = np.array([float(r["env_steps"]) for r in evaluated])
    curve["eval_time_s"] = np.array([float(r["time_s"]) for r in evaluated])
    curve["eval_success_rate"] = np.array([float(r["eval/success_rate"]) for r in evaluated])
    return curve


def smooth(x: np.ndarray, window: int = 5) -> np.ndarray:
    if len(x) < window:
        return x
    kernel = np.ones(window) / window
    padded = np.concatenate([np.full(window - 1, x[0]), x])
    return np.convolve(padded, kernel, mode="valid")


def curves(plan: Plan, out: Path) -> dict:
    result = {}
    for behavior in plan.behaviors:
        for method in trained_methods(plan.method_names):
            runs = [read_curve(run_dir(out, behavior, method, s)) for s in plan.seed_ids]
            result[(behavior, method)] = {
                k: np.stack([r[k][: min(len(q[k]) for q in runs)] for r in runs]) for k in runs[0]
            }
    return result


def plot_fig5(plan: Plan, data: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(
        2, len(plan.behaviors), figsize=(5.5 * len(plan.behaviors), 7), squeeze=False
    )
    for j, behavior in enumerate(plan.behaviors):
        panels = (
            (
                "eval_env_steps",
                "eval_success_rate",
                f"success at {plan.fig6_speed_mps} m/s (evaluation)",
                False,
            ),
            ("env_steps", "reward_per_step", "reward per step (training)", True),
        )
        for i, (xkey, key, ylabel, smoothed) in enumerate(panels):
            ax = axes[i, j]
            for b, method in data:
                if b != behavior:
                    continue
                d = data[(behavior, method)]
                if d[key].shape[1] == 0:
                    continue
                x = d[xkey][0] / 1e6
                ys = np.stack([smooth(y) if smoothed else y for y in d[key]])
                ax.plot(x, ys.mean(0), color=color(method), label=label(method))
                if ys.shape[0] > 1:
                    ax.fill_between(x, ys.min(0), ys.max(0), color=color(method), alpha=0.2)
            ax.set_xlabel("environment steps (M)")
            ax.set_ylabel(ylabel)
            ax.set_title(f"{behavior}")
            ax.grid(alpha=0.3)
    axes[0, 0].legend(loc="lower right")
    fig.suptitle(f"Fig. 5 (ours): mean over {plan.seeds} seed(s), band = min-max over seeds")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_fig6(cells: list[dict], methods, behaviors, path: Path, speed: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by = {(c["behavior"], c["method"]): c for c in cells}
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.8 / len(methods)
    xs = np.arange(len(behaviors))
    for k, method in enumerate(methods):
        for ax, key in zip(axes, ("success_rate", "catch_time_s"), strict=True):
            vals = [by[(b, method)][key] if (b, method) in by else np.nan for b in behaviors]
            err = None
            if key == "success_rate":
                lo = [
                    v - by[(b, method)]["success_ci95"][0] if (b, method) in by else 0
                    for b, v in zip(behaviors, vals, strict=True)
                ]
                hi = [
                    by[(b, method)]["success_ci95"][1] - v if (b, method) in by else 0
                    for b, v in zip(behaviors, vals, strict=True)
                ]
                err = np.maximum([lo, hi], 0)
            ax.bar(
                xs + (k - len(methods) / 2 + 0.5) * width,
                vals,
                width,
                yerr=err,
                color=color(method),
                label=label(method),
                capsize=2,
            )
    axes[0].set_ylabel("success rate")
    axes[1].set_ylabel("mean catch time (s, failure = limit)")
    for ax in axes:
        ax.set_xticks(xs, behaviors)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(methods), fontsize=8)
    fig.suptitle(f"Fig. 6 (ours): target speed {speed} m/s, 95 % CIs")
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_table_i(cells: list[dict], behaviors, path: Path) -> None:
    """Table I's success against target speed, one panel per behaviour of ``behaviors``; no
    figure where there is none (a part of a reproduction whose behaviour Table I omits)."""
    if not behaviors:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(behaviors), figsize=(6 * len(behaviors), 4.2), squeeze=False)
    for ax, behavior in zip(axes[0], behaviors, strict=True):
        for method in policy_order():
            cs = sorted(
                (c for c in cells if c["behavior"] == behavior and c["method"] == method),
                key=lambda c: c["speed_mps"],
            )
            if not cs:
                continue
            x = [c["speed_mps"] for c in cs]
            y = [c["success_rate"] for c in cs]
            ax.plot(x, y, "o-", color=color(method), label=label(method))
            ax.fill_between(
                x,
                [c["success_ci95"][0] for c in cs],
                [c["success_ci95"][1] for c in cs],
                color=color(method),
                alpha=0.15,
            )
        ax.set_title(f"Table I (ours): {behavior}")
        ax.set_xlabel("target speed (m/s)")
        ax.set_ylabel("success rate")
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _cell(c: dict | None) -> str:
    if c is None:
        return "-"
    lo, hi = c["success_ci95"]
    return f"{c['success_rate']:.3f} [{lo:.2f}, {hi:.2f}] / {c['catch_time_s']:.2f}"


def _paper(behavior: str, method: str, speed) -> str:
    p = paper_cell(behavior, method, speed)
    return "-" if p is None else f"{p[0]:.3f} / {p[1]:.2f}"


def table_i_markdown(cells, averages, behavior: str, speeds) -> str:
    by = {(c["method"], c["speed_mps"]): c for c in cells if c["behavior"] == behavior}
    avg = {a["method"]: a for a in averages if a["behavior"] == behavior}
    head = " | ".join(f"{v:.1f} m/s" for v in speeds)
    lines = [f"| method | source | {head} | average |", "|---|---|" + "---|" * (len(speeds) + 1)]
    for method in policy_order():
        if method not in avg:
            continue
        ours = [_cell(by.get((method, v))) for v in speeds]
        lines.append(f"| {label(method)} | ours | {' | '.join(ours)} | {_cell(avg[method])} |")
        if paper_cell(behavior, method, None) is not None:
            paper = [_paper(behavior, method, v) for v in speeds]
            lines.append(f"| | paper | {' | '.join(paper)} | {_paper(behavior, method, None)} |")
    return "\n".join(lines)


def fig6_markdown(cells: list[dict]) -> str:
    by = {(c["behavior"], c["method"]): c for c in cells}
    behaviors = list(dict.fromkeys(c["behavior"] for c in cells))
    lines = [
        "| method | " + " | ".join(behaviors) + " |",
        "|---|" + "---|" * len(behaviors),
    ]
    for method in policy_order():
        if not any((b, method) in by for b in behaviors):
            continue
        lines.append(
            f"| {label(method)} | "
            + " | ".join(_cell(by.get((b, method))) for b in behaviors)
            + " |"
        )
    return "\n".join(lines)


MEASURE_LABEL = {"success_rate": "success rate", "catch_time_s": "catch time (s saved)"}


def checks_markdown(checks: list[dict]) -> str:
    """The checks as a table: primary endpoints with the smallest difference the run
    resolves (the CI's half-width), secondary ones with their Holm-adjusted p-value."""
    lines = [
        "| behaviour | speed | claim | measure | difference [95% CI] | p (Holm) | role | verdict |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for c in checks:
        speed = "average" if c["speed_mps"] is None else f"{c['speed_mps']:.1f} m/s"
        lo, hi = c["ci95"]
        measure = MEASURE_LABEL[c.get("metric", "success_rate")]
        p = f"{c['p_value']:.3g}" if "p_value" in c else ""
        if "p_holm" in c:
            p += f" ({c['p_holm']:.3g})"
        role = c.get("role", "")
        if role == "primary":
            role += f", resolves +-{c['smallest_resolvable_difference']:.3f}"
        lines.append(
            f"| {c['behavior']} | {speed} | {c['claim']} | {measure} | {c['difference']:+.3f} "
            f"[{lo:+.3f}, {hi:+.3f}] | {p} | {role} | {c['verdict']} |"
        )
    return "\n".join(lines)


def primary_markdown(primary: dict) -> str:
    """The plan's primary endpoints (``summary.primary_rows``) as a table: the paper's
    difference where Table I gives one, ours with its 95 % CI, the smallest difference the
    run resolves (the CI's half-width), the seeds per method for 80 % power at the margin,
    the resolution and its verdict on the paper's claim (``endpoints.against_paper``);
    then the declared endpoints the plan does not measure."""
    lines = []
    if primary["measured"]:
        lines += [
            "| endpoint | measure | paper | ours [95% CI] | smallest resolvable | "
            "seeds for 80 % power at the margin | verdict | against the paper |",
            "|---|---|---:|---|---:|---:|---|---|",
        ]
    for c in primary["measured"]:
        lo, hi = c["ci95"]
        paper = "-" if c["paper_difference"] is None else f"{c['paper_difference']:+.3f}"
        seeds = c.get("seeds_for_80pct_power_at_margin")
        verdict = c["resolution"]
        if verdict == "resolved":
            verdict += f" ({c['verdict']})"
        elif verdict.startswith("equivalent"):
            verdict += f" (+-{c['margin']:g})"
        lines.append(
            f"| {c['endpoint']} ({c['claim']}, {c['behavior']}, {c['speed_mps']:g} m/s) | "
            f"{MEASURE_LABEL[c['metric']]} | {paper} | {c['difference']:+.3f} "
            f"[{lo:+.3f}, {hi:+.3f}] | +-{c['smallest_resolvable_difference']:.3f} | "
            f"{'-' if seeds is None else seeds} | {verdict} | "
            f"{c.get('against_paper') or '-'} |"
        )
    if not primary["measured"]:
        lines.append(
            "No primary endpoint in this plan's speeds, Table I behaviours and methods: "
            "every check below is secondary."
        )
    if primary["not_measured"]:
        lines += [
            "",
            "Declared but not measured by this plan: "
            + ", ".join(f"`{n}`" for n in primary["not_measured"])
            + ".",
        ]
    return "\n".join(lines)


def table_ii_markdown(rows: list[dict]) -> str:
    return table_ii_rows_markdown(rows)


def stage_times_markdown(wall: dict) -> str:
    """Each stage's measured wall time (``wall["stages_s"]``) against its estimate
    (``wall["stages_estimate_s"]``, the reference machine's), and where the run probed its
    machine, against the estimate scaled to it (``wall["stages_estimate_here_s"]``); then
    the whole run's. A stage with no measurement (its jobs done by an invocation before
    wall.json counted stages) shows '-'."""
    here = wall.get("stages_estimate_here_s")
    head = "| stage | estimate | measured | measured / estimate |"
    rule = "|---|---:|---:|---:|"
    if here:
        head += " estimate here | measured / estimate here |"
        rule += "---:|---:|"
    lines = [head, rule]

    def ratio(measured: float | None, estimate: float) -> str:
        if measured is None:
            return "-"
        return f"{measured / estimate:.2f}" if estimate > 0 else "-"

    def row(name: str, estimate: float, measured: float | None, scaled: float | None) -> str:
        took = "-" if measured is None else f"{measured / 60:.1f} min"
        line = f"| {name} | {estimate / 60:.1f} min | {took} | {ratio(measured, estimate)} |"
        if here:
            line += f" {scaled / 60:.1f} min | {ratio(measured, scaled)} |"
        return line

    estimates, measured = wall["stages_estimate_s"], wall.get("stages_s", {})
    for name, estimate in estimates.items():
        lines.append(row(name, estimate, measured.get(name), (here or {}).get(name)))
    total_here = sum(here.values()) if here else None
    lines.append(row("**whole run**", sum(estimates.values()), wall["total_s"], total_here))
    return "\n".join(lines)
