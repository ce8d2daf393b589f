"""Cached, resumable stages of a long pipeline (the self-play rounds).

A stage is a folder, the JSON spec of everything that makes it, and a function that fills
the folder. ``run_stage`` skips a stage whose ``done.json`` exists (written atomically after
the stage's files, so a stage that has one is whole) and refuses one whose ``done.json``
records another spec, naming the differing fields; a folder without ``done.json`` was
interrupted, and is cleared and made again, unless the stage continues it itself
(``Stage.keeps_partial``: an evader run from its saved training state).
"""

from __future__ import annotations

import shutil
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dyncatch.utils.config_io import config_diff
from dyncatch.utils.files import read_json, write_json
from dyncatch.utils.progress import Progress

DONE = "done.json"
"""The file that marks a finished stage: ``{"spec", "result", "time_s"}``."""


def flag_of(field: str) -> str:
    """A dotted config field as its command-line flag (``pursuer_ppo.lr`` ->
    ``--pursuer-ppo.lr``)."""
    return "--" + field.replace("_", "-")


def diff_message(have: dict, want: dict, where: str, fix: str) -> str | None:
    """None if equal, else which fields differ (as flags, old -> new) and ``fix``."""
    diff = config_diff(have, want)
    if not diff:
        return None
    shown = ", ".join(f"{flag_of(k)} ({a!r} -> {b!r})" for k, (a, b) in list(diff.items())[:4])
    more = f" and {len(diff) - 4} more" if len(diff) > 4 else ""
    return f"{where} was made with other {shown}{more}; {fix}"


@dataclass(frozen=True)
class Stage:
    """One unit of cached work."""

    name: str
    """Shown in progress and errors, e.g. ``round1/pursuer/rl``."""
    out: Path
    """Its folder (``out/done.json`` marks it finished)."""
    spec: dict
    """The JSON of everything that makes it; a recorded one that differs is refused."""
    make: Callable[[Progress | None], Any]
    """Fills ``out`` (reporting to the progress it is given); returns a JSON-able result
    kept in ``done.json``."""
    keeps_partial: bool = False
    """``make`` continues an interrupted folder itself (and clears what it cannot use), so
    ``run_stage`` leaves it in place; False: the folder is cleared first."""


def stage_done(stage: Stage) -> dict | None:
    """The finished stage's ``done.json``, None if it has none; ValueError if its spec
    differs from ``stage.spec``."""
    path = stage.out / DONE
    if not path.exists():
        return None
    have = read_json(path, "delete the stage's folder to make it again")
    msg = diff_message(
        have.get("spec", {}),
        stage.spec,
        f"stage {stage.name} ({stage.out})",
        "re-run with the same flags to resume, or choose another --out",
    )
    if msg:
        raise ValueError(msg)
    return have


def run_stage(stage: Stage, progress: Progress | None = None) -> dict:
    """``done.json`` of the stage: read when finished, else made (a partial folder is
    cleared first, unless the stage keeps it) and written after the stage's own files."""
    done = stage_done(stage)
    if done is not None:
        return {**done, "skipped": True}
    if stage.out.exists() and not stage.keeps_partial:
        shutil.rmtree(stage.out)
    clock0 = time.perf_counter()
    result = stage.make(progress)
    done = {"spec": stage.spec, "result": result, "time_s": time.perf_counter() - clock0}
    write_json(stage.out / DONE, done)
    return {**done, "skipped": False}
