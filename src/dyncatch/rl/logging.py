"""Training logs: one CSV row and one TensorBoard scalar set per iteration."""

from __future__ import annotations

import csv
from pathlib import Path


class MetricLog:
    """Appends metrics to ``metrics.csv`` and TensorBoard events under ``tb/`` in ``out``.

    On resume, CSV rows past the resumed iteration (written after the last checkpoint)
    are dropped so that the file matches the run.
    """

    def __init__(self, out: Path, resume_iteration: int = 0):
        from tensorboardX import SummaryWriter

        self.csv_path = out / "metrics.csv"
        self._fields: list[str] | None = None
        if resume_iteration and self.csv_path.exists():
            with self.csv_path.open() as f:
                rows = [r for r in csv.DictReader(f) if int(r["iteration"]) <= resume_iteration]
            self._rewrite(rows)
        elif self.csv_path.exists():
            self.csv_path.unlink()
        self.tb = SummaryWriter(str(out / "tb"))

    def last(self, name: str, default: float = 0.0) -> float:
        """The last logged value of a column (e.g. the wall clock to continue on resume)."""
        if not self.csv_path.exists():
            return default
        with self.csv_path.open() as f:
            rows = list(csv.DictReader(f))
        return float(rows[-1][name]) if rows and rows[-1].get(name) else default

    def _rewrite(self, rows: list[dict]) -> None:
        if not rows:
            self.csv_path.unlink(missing_ok=True)
            return
        self._fields = list(rows[0])
        with self.csv_path.open("w", newline="") as f:
            w = csv.DictWriter(f, self._fields)
            w.writeheader()
            w.writerows(rows)

    def write(self, iteration: int, env_steps: int, metrics: dict[str, float]) -> None:
        row = {"iteration": iteration, "env_steps": env_steps, **metrics}
        new = self._fields is None
        if new:
            self._fields = list(row)
        with self.csv_path.open("a", newline="") as f:
            w = csv.DictWriter(f, self._fields)
            if new:
                w.writeheader()
            w.writerow(row)
        for name, value in metrics.items():
            if value != "":  # "" marks a metric not measured at this iteration
                self.tb.add_scalar(name, value, env_steps)

    def close(self) -> None:
        self.tb.close()
