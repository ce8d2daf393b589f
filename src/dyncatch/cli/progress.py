"""A rich progress bar behind the library's ``Progress`` seam."""

from __future__ import annotations

from contextlib import contextmanager

from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn


class RichProgress:
    """``Progress`` drawn by rich: the newest task's bar, ``info`` shown beside it."""

    def __init__(self, bar: Progress):
        self._bar = bar

    def log(self, message: str) -> None:
        """A line above the live bar."""
        self._bar.console.print(message)

    def task(self, description: str, total: int, completed: int = 0):
        for old in list(self._bar.task_ids):
            self._bar.remove_task(old)
        task = self._bar.add_task(description, total=total, completed=completed, info="")

        def update(completed: int, info: str = "") -> None:
            self._bar.update(task, completed=completed, info=info)

        return update


@contextmanager
def rich_progress():
    """A live rich progress display for the duration of the block."""
    columns = [
        TextColumn("{task.description}"),
        BarColumn(),
        TextColumn("{task.fields[info]}"),
        TimeRemainingColumn(),
    ]
    with Progress(*columns) as bar:
        yield RichProgress(bar)
