"""Learning curves of training runs from their ``metrics.csv``.

``plot_runs(runs, metrics, method_labels)`` returns a matplotlib ``Figure`` (no pyplot, no
global state): one panel per metric against environment steps, one line per run, labelled
by the run's folder and its method (read from the checkpoint's header, shown by its label
in ``method_labels`` where given). Metrics measured only at some
iterations (``eval/*``) are drawn through the iterations that measured them.
"""

from __future__ import annotations

import csv
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from dyncatch.rl.policy import CHECKPOINT
from dyncatch.utils.tree_io import read_header

METRICS_FILE = "metrics.csv"
DEFAULT_METRICS = ("eval/success_rate", "reward_per_step")
"""The unbiased success rate of the mean-action policy, and the training reward per step."""
X_COLUMN = "env_steps"


def read_metrics(run: str | Path) -> dict[str, np.ndarray]:
    """Every column of a run's ``metrics.csv`` as a float array (rows,); NaN where a metric
    was not measured at that iteration."""
    path = Path(run) / METRICS_FILE
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: no metrics file; plot runs trained by dyncatch train with --logger csv"
        )
    with path.open() as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path} has no rows yet: plot it after its first iteration")
    if X_COLUMN not in rows[0]:
        raise ValueError(f"{path} has no {X_COLUMN} column: not a dyncatch train metrics file")
    return {k: np.array([float(r[k]) if r[k] else np.nan for r in rows]) for k in rows[0]}


def run_method(run: str | Path) -> str | None:
    """The method name in a run folder's checkpoint (None without a readable checkpoint)."""
    path = Path(run) / CHECKPOINT
    try:
        name = read_header(path).get("method")
    except (OSError, ValueError):
        return None
    return name


def run_labels(
    runs: Sequence[str | Path], method_labels: Mapping[str, str] | None = None
) -> list[str]:
    """Each run's folder name (with parents where two runs share one) and method, shown by
    its ``method_labels`` entry where it has one (the reproduction's labels:
    ``dyncatch.reproduce.presentation.method_labels``), else by its name."""
    method_labels = method_labels or {}
    parts = [Path(r).resolve().parts for r in runs]
    depth = 1
    while depth < max(len(p) for p in parts):
        names = ["/".join(p[-depth:]) for p in parts]
        if len(set(names)) == len(names):
            break
        depth += 1
    names = ["/".join(p[-depth:]) for p in parts]
    methods = [run_method(r) for r in runs]
    methods = [method_labels.get(m, m) if m else m for m in methods]
    return [f"{n} ({m})" if m else n for n, m in zip(names, methods, strict=True)]


def plot_runs(
    runs: Sequence[str | Path],
    metrics: Sequence[str] = DEFAULT_METRICS,
    method_labels: Mapping[str, str] | None = None,
) -> Figure:
    """One panel per metric (against env steps), one line per run; returns the figure."""
    if not runs or not metrics:
        raise ValueError("give at least one run and one metric (--metrics)")
    data = [read_metrics(r) for r in runs]
    for run, columns in zip(runs, data, strict=True):
        missing = [m for m in metrics if m not in columns]
        if missing:
            raise ValueError(
                f"{Path(run) / METRICS_FILE} has no column {', '.join(missing)}: "
                f"choose --metrics from {', '.join(c for c in columns if c != X_COLUMN)}"
            )
    fig = Figure(figsize=(4.5 * len(metrics), 3.4), layout="constrained")
    axes = fig.subplots(1, len(metrics), squeeze=False)[0]
    for ax, metric in zip(axes, metrics, strict=True):
        for label, columns in zip(run_labels(runs, method_labels), data, strict=True):
            y = columns[metric]
            measured = ~np.isnan(y)
            ax.plot(columns[X_COLUMN][measured], y[measured], marker=".", label=label)
        ax.set_title(metric)
        ax.set_xlabel("environment steps")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize="small")
    return fig


def save_curves(
    runs: Sequence[str | Path],
    out: str | Path,
    metrics: Sequence[str] = DEFAULT_METRICS,
    method_labels: Mapping[str, str] | None = None,
) -> Path:
    """``plot_runs`` written to ``out`` (the format from its suffix: .png, .pdf, .svg)."""
    fig = plot_runs(runs, metrics, method_labels)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    return out
