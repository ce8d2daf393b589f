"""The progress seam between library runners and the command line.

A runner reports through a ``Progress``: ``task(description, total, completed)`` opens a
task and returns ``update(completed, info="")``. The library never draws; the CLI attaches
a rich progress bar (the command line's progress module), tests and scripts pass nothing.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

Update = Callable[..., None]
"""``update(completed: int, info: str = "")``."""


class Progress(Protocol):
    def task(self, description: str, total: int, completed: int = 0) -> Update: ...


class NoProgress:
    """Reports nothing."""

    def task(self, description: str, total: int, completed: int = 0) -> Update:
        return lambda completed, info="": None
