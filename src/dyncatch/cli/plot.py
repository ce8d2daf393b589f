"""``dyncatch plot RUN [RUN ...] --out curves.png``: learning curves (``dyncatch.viz.curves``)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import tyro

from dyncatch.reproduce.presentation import method_labels
from dyncatch.viz.curves import DEFAULT_METRICS, save_curves


@dataclasses.dataclass(frozen=True)
class PlotCmd:
    """Plot learning curves of training runs from their metrics.csv against env steps."""

    runs: tyro.conf.Positional[tuple[Path, ...]]
    """Run folders written by dyncatch train (with the csv logger, the default)."""
    out: Path = Path("curves.png")
    """Image to write (.png, .pdf or .svg)."""
    metrics: tuple[str, ...] = DEFAULT_METRICS
    """Columns of metrics.csv, one panel each (e.g. success_rate, action_std, time_s)."""


def run_plot(cmd: PlotCmd) -> Path:

    out = save_curves(cmd.runs, cmd.out, cmd.metrics, method_labels())
    print(f"{out}: {', '.join(cmd.metrics)} of {len(cmd.runs)} run(s)")
    return out
