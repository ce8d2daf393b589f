"""Fig. 9's grouped bar chart and markdown tables, ours beside the paper's values."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dyncatch.reproduce.fig9 import Fig9Row, row_named, rows_of
from dyncatch.reproduce.paper import (
    PAPER_FIG9_METHOD,
    PAPER_FIG9_SCENE_AVERAGE,
    PAPER_FIG9_SUCCESS,
)
from dyncatch.reproduce.report import color, label

PANELS = (
    ("success_rate", "success rate"),
    ("catch_time_s", "mean catch time (s, failure = limit)"),
    ("contacts_per_episode", "contacts per episode"),
)


def _color(row: str) -> str:
    return color(row_named(row).policy)


def row_label(row: Fig9Row) -> str:
    """A row's name in tables and legends: its policy's label, "+ blend" when blended."""
    return label(row.policy) + (" + blend" if row.blend else "")


def paper_json() -> dict:
    """The paper's Fig. 9 values the text gives, for results.json."""
    return {
        "method": PAPER_FIG9_METHOD,
        "success": [
            {"scene": sc, "behavior": b, "success_rate": v}
            for (sc, b), v in PAPER_FIG9_SUCCESS.items()
        ],
        "scene_average_success": PAPER_FIG9_SCENE_AVERAGE,
    }


def plot(cells: list[dict], scenes, behaviors, path: Path) -> None:
    """A column of panels per behaviour (success with its 95 % CI, catch time, contacts),
    scenes along x, a bar per row (hatched: without the blend); the paper's success values
    as black crosses on its row's bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    by = {(c["scene"], c["behavior"], c["method"]): c for c in cells}
    rows = list(dict.fromkeys(c["method"] for c in cells))  # in the plan's row order
    fig, axes = plt.subplots(
        len(PANELS), len(behaviors), figsize=(1.2 + 3.2 * len(behaviors), 8), squeeze=False
    )
    width = 0.8 / max(len(rows), 1)
    xs = np.arange(len(scenes))
    for j, behavior in enumerate(behaviors):
        for k, row in enumerate(rows):
            x = xs + (k - len(rows) / 2 + 0.5) * width
            got = [by.get((sc, behavior, row)) for sc in scenes]
            for i, (key, _) in enumerate(PANELS):
                vals = [np.nan if c is None else c[key] for c in got]
                err = None
                if key == "success_rate":
                    err = np.array(
                        [
                            [0.0, 0.0]
                            if c is None
                            else [v - c["success_ci95"][0], c["success_ci95"][1] - v]
                            for c, v in zip(got, vals, strict=True)
                        ]
                    ).T.clip(0)
                axes[i, j].bar(
                    x,
                    vals,
                    width,
                    yerr=err,
                    capsize=2,
                    color=_color(row),
                    hatch="" if row_named(row).blend else "//",
                    edgecolor="white" if row_named(row).blend else "black",
                    label=row_label(row_named(row)),
                )
            if row == PAPER_FIG9_METHOD:
                paper = [PAPER_FIG9_SUCCESS.get((sc, behavior), np.nan) for sc in scenes]
                axes[0, j].plot(x, paper, "kx", ms=8, mew=2, label="paper (text)")
        axes[0, j].set_title(behavior)
        for i, (_, ylabel) in enumerate(PANELS):
            ax = axes[i, j]
            ax.set_xticks(xs, scenes, rotation=30, fontsize=7)
            ax.grid(axis="y", alpha=0.3)
            if j == 0:
                ax.set_ylabel(ylabel)
        axes[0, j].set_ylim(0, 1.05)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="lower center", ncol=len(handles), fontsize=8)
    fig.suptitle("Fig. 9 (ours): plane-trained policies in rooms and woods, 95 % CIs")
    fig.tight_layout(rect=(0, 0.05, 1, 1))
    fig.savefig(path, dpi=100)
    plt.close(fig)


def _cell(c: dict | None) -> str:
    if c is None:
        return "-"
    lo, hi = c["success_ci95"]
    return (
        f"{c['success_rate']:.3f} [{lo:.2f}, {hi:.2f}] / {c['catch_time_s']:.1f} / "
        f"{c['contacts_per_episode']:.2f}"
    )


def markdown(fig9: dict, plan) -> list[str]:
    """The report's Fig. 9 section: a table per behaviour, rows by scenes."""
    by = {(c["scene"], c["behavior"], c["method"]): c for c in fig9["cells"]}
    scenes = plan.fig9_scenes
    limit = plan.fig9_duration_s or "the scene's (40 s)"
    speed = plan.fig9_speed_mps
    speed = f"at {speed} m/s" if speed is not None else "its speed drawn per episode (variant)"
    lines = [
        "## Fig. 9: rooms and woods (policies trained on the plane)",
        "",
        f"The target {speed}; each policy on the behaviour it was trained on.",
        "",
        "Cells are success rate [95 % CI] / mean catch time (s; a failure counts as the "
        f"episode limit, {limit}) / contacts per episode (a contact: the footprint comes "
        "within 1 mm of a wall or obstacle). '+ blend' is eq. 10's collision avoidance "
        "(docs/scenes.md). The paper's values are only those its text gives (its method, "
        "with its blend).",
        "",
        "![Fig. 9](figures/fig9.png)",
        "",
    ]
    for behavior in plan.fig9_columns:
        lines += [
            f"### {behavior}",
            "",
            "| row | " + " | ".join(scenes) + " |",
            "|---|" + "---|" * len(scenes),
        ]
        for r in rows_of(plan):
            got = [by.get((sc, behavior, r.name)) for sc in scenes]
            if all(c is None for c in got):
                continue
            lines.append(f"| {row_label(r)} | " + " | ".join(_cell(c) for c in got) + " |")
            if r.name == PAPER_FIG9_METHOD:
                paper = [PAPER_FIG9_SUCCESS.get((sc, behavior)) for sc in scenes]
                if any(p is not None for p in paper):
                    cells = ["-" if p is None else f"{p:.3f}" for p in paper]
                    lines.append("| paper | " + " | ".join(cells) + " |")
        lines.append("")
    for c in fig9.get("videos") or []:
        outcome = f"caught at {c['catch_time_s']:.1f} s" if c["caught"] else "not caught"
        lines.append(
            f"- {row_label(row_named(c['method']))} in [{c['scene']}]({c['file']}), "
            f"{c['behavior']}: {outcome}"
        )
    return lines
