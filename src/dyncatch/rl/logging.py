"""Training logs: a registry of loggers behind one interface, and ``MetricLog`` fanning out.

A logger receives one row per iteration: ``write(iteration, env_steps, metrics)`` where a
metric is a float, or ``""`` for one not measured at that iteration (the evaluation
columns), then ``close()``. ``LOGGERS`` maps the names of ``dyncatch train --logger`` to
``LoggerKind``s that build them from the run folder, the run's header and the iteration
a resumed run starts from.
"""

from __future__ import annotations

import csv
import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Protocol

from dyncatch.utils.cli_types import live_name

Metrics = dict[str, float | str]


class Logger(Protocol):
    def write(self, iteration: int, env_steps: int, metrics: Metrics) -> None: ...

    def close(self) -> None: ...


def _measured(metrics: Metrics) -> dict[str, float]:
    return {k: v for k, v in metrics.items() if v != ""}


def read_metrics(path: Path, fix: str = "delete it, or restore it from a copy") -> list[dict]:
    """The rows of a ``metrics.csv``, each cell a string as written; ValueError naming the
    file and ``fix`` if it is not one (not text, no ``iteration``/``env_steps`` columns, a
    cell that is neither a number nor empty)."""
    try:
        with path.open(newline="") as f:
            rows = list(csv.DictReader(f))
    except (UnicodeDecodeError, csv.Error) as err:
        raise ValueError(f"{path}: not a metrics.csv ({err}); {fix}") from None
    for i, row in enumerate(rows, start=2):
        if None in row or None in row.values() or not {"iteration", "env_steps"} <= set(row):
            raise ValueError(f"{path}: line {i} does not match the columns; {fix}")
        for name, value in row.items():
            try:
                float(value) if value else None
            except ValueError:
                raise ValueError(
                    f"{path}: line {i}, column {name}: {value!r} is not a number; {fix}"
                ) from None
    return rows


class CsvLogger:
    """``metrics.csv``: one row per iteration (``iteration``, ``env_steps``, metrics).

    On resume, rows past the resumed iteration (written after the last checkpoint) are
    dropped so that the file matches the run; a fresh run replaces the file.
    """

    def __init__(self, out: Path, resume_iteration: int = 0):
        self.path = out / "metrics.csv"
        self._fields: list[str] | None = None
        if resume_iteration and self.path.exists():
            rows = read_metrics(self.path, "delete it to resume (its rows start again)")
            self._rewrite([r for r in rows if float(r["iteration"]) <= resume_iteration])
        elif self.path.exists():
            self.path.unlink()

    def last(self, name: str) -> float | None:
        """The last logged value of a column, if any."""
        return self.last_row().get(name)

    def last_row(self) -> dict[str, float]:
        """The last logged row, its empty cells left out ({} before the first row)."""
        if not self.path.exists():
            return {}
        rows = read_metrics(self.path, "delete it to resume (its rows start again)")
        return {k: float(v) for k, v in rows[-1].items() if v} if rows else {}

    def _rewrite(self, rows: list[dict]) -> None:
        if not rows:
            self.path.unlink(missing_ok=True)
            return
        self._fields = list(rows[0])
        with self.path.open("w", newline="") as f:
            w = csv.DictWriter(f, self._fields)
            w.writeheader()
            w.writerows(rows)

    def write(self, iteration: int, env_steps: int, metrics: Metrics) -> None:
        row = {"iteration": iteration, "env_steps": env_steps, **metrics}
        new = self._fields is None
        if new:
            self._fields = list(row)
        with self.path.open("a", newline="") as f:
            w = csv.DictWriter(f, self._fields)
            if new:
                w.writeheader()
            w.writerow(row)

    def close(self) -> None:
        pass


class TensorBoardLogger:
    """TensorBoard scalars under ``tb/``, against environment steps."""

    def __init__(self, out: Path):
        from tensorboardX import SummaryWriter

        self.tb = SummaryWriter(str(out / "tb"))

    def write(self, iteration: int, env_steps: int, metrics: Metrics) -> None:
        for name, value in _measured(metrics).items():
            self.tb.add_scalar(name, value, env_steps)

    def close(self) -> None:
        self.tb.close()


class WandbLogger:
    """Weights & Biases under ``wandb/``, the run's header as ``wandb.config``.

    Offline (``wandb/offline-run-*``, upload later with ``wandb sync``) unless the user
    configured ``WANDB_MODE``: dyncatch never contacts a server on its own. A resumed
    training starts a new W&B run whose steps continue from the checkpoint's.
    """

    def __init__(self, out: Path, header: dict):
        import wandb

        # Passed explicitly: wandb reads the environment once per process.
        mode = os.environ.get("WANDB_MODE") or "offline"
        self.run = wandb.init(
            project="dyncatch",
            name=out.name,
            dir=str(out),
            mode=mode,
            config=header,
            settings=wandb.Settings(console="off", silent=True, x_disable_stats=True),
            reinit="create_new",
        )

    def write(self, iteration: int, env_steps: int, metrics: Metrics) -> None:
        self.run.log({"iteration": iteration, **_measured(metrics)}, step=env_steps)

    def close(self) -> None:
        self.run.finish()


@dataclass(frozen=True)
class LoggerKind:
    doc: str
    make: Callable[[Path, dict, int], Logger]
    """(run folder, run header, resumed iteration) -> logger."""


LOGGERS: dict[str, LoggerKind] = {
    "csv": LoggerKind(
        "metrics.csv (read by dyncatch plot, dyncatch reproduce and resume's wall clock)",
        lambda out, header, resumed: CsvLogger(out, resumed),
    ),
    "tensorboard": LoggerKind(
        "TensorBoard events in tb/", lambda out, header, resumed: TensorBoardLogger(out)
    ),
    "wandb": LoggerKind(
        "Weights & Biases in wandb/, offline unless WANDB_MODE is set",
        lambda out, header, resumed: WandbLogger(out, header),
    ),
}
"""The loggers of ``dyncatch train --logger``, by name."""

LoggerName = live_name(lambda: tuple(LOGGERS), "LOGGER")
"""A key of ``LOGGERS``, read when the command line is parsed."""


def validate_loggers(names: Sequence[str]) -> tuple[str, ...]:
    """The names, checked: known, at least one, none twice."""
    unknown = [n for n in names if n not in LOGGERS]
    if unknown or not names or len(set(names)) != len(names):
        raise ValueError(
            f"--logger {' '.join(names) or '(none)'}: give one or more of "
            f"{', '.join(LOGGERS)}, each once"
        )
    return tuple(names)


class MetricLog:
    """Writes each iteration's metrics to every chosen logger.

    ``last`` reads a column back from ``metrics.csv`` (the wall clock a resumed run
    continues), when ``csv`` is among the loggers.
    """

    def __init__(
        self,
        out: Path,
        resume_iteration: int = 0,
        loggers: Sequence[str] = ("csv", "tensorboard"),
        header: dict | None = None,
    ):
        self.loggers = {
            name: LOGGERS[name].make(out, header or {}, resume_iteration)
            for name in validate_loggers(loggers)
        }
        if "csv" not in self.loggers and (out / "metrics.csv").exists():
            # An earlier invocation's file: cut to the checkpoint (or removed on a fresh
            # run) as the csv logger would, so it never shows iterations the run lost.
            CsvLogger(out, resume_iteration)

    def last(self, name: str, default: float = 0.0) -> float:
        """The last logged value of a column (``default`` without one, or without csv)."""
        csv_log = self.loggers.get("csv")
        value = csv_log.last(name) if isinstance(csv_log, CsvLogger) else None
        return default if value is None else value

    def last_row(self) -> dict[str, float]:
        """The last logged row of ``metrics.csv`` ({} without one, or without csv)."""
        csv_log = self.loggers.get("csv")
        return csv_log.last_row() if isinstance(csv_log, CsvLogger) else {}

    def write(self, iteration: int, env_steps: int, metrics: Metrics) -> None:
        for logger in self.loggers.values():
            logger.write(iteration, env_steps, metrics)

    def close(self) -> None:
        for logger in self.loggers.values():
            logger.close()
