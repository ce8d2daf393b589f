"""A reproduction in parts, one per trained behaviour, for machines whose sessions or jobs
end before the whole plan would (a full reproduction takes about 4.4 h on 2 cores).

Every output of a reproduction lives under its behaviour (``layout``), but for Table II
and the report, so a plan splits into one plan per trained behaviour (``part_plan``): that
behaviour's predictors, training runs, Table I row, Fig. 6 column, Fig. 9 cells and videos,
the transfer table in the part of ``transfer_from``, Table II in the first part and Fig. 9's
scene videos in the part of the behaviour the whole plan films. Each part is a complete
reproduction of its own (``dyncatch reproduce ... --part BEHAVIOR --out DIR``), resumable as
any other. ``merge`` copies the finished parts' files into one folder, where the whole
plan's run (``dyncatch reproduce ... --merge-parts DIR ... --out OUT``) finds every stage
done and writes the whole report. A part's folder without its checkpoints and TensorBoard
logs (``KEPT_OUT``) is all a merge reads: small enough to keep between sessions.
"""

from __future__ import annotations

import dataclasses
import shutil
from collections.abc import Sequence
from pathlib import Path

from dyncatch.reproduce.layout import plans_differ
from dyncatch.reproduce.plan import ROUNDING_ONLY, Plan
from dyncatch.reproduce.stages import stages_of
from dyncatch.utils.config_io import config_diff
from dyncatch.utils.files import read_json, write_json

KEPT_OUT = ("checkpoint.safetensors", "tb")
"""File and folder names a merge does not copy (and a part's archive may leave out): the
training checkpoints and TensorBoard logs, which only a part's own stages read."""

OWN_FILES = ("plan.json", "wall.json", "results.json", "report.md", "parts.json")
"""A part's top-level files that describe the part alone (the merge writes its own)."""


def _filmed_fig9_behavior(plan: Plan) -> str | None:
    """The behaviour whose Fig. 9 scene videos the whole plan films (its first column)."""
    return plan.fig9_columns[0] if plan.fig9 and plan.videos and plan.fig9_columns else None


def _narrowed(given: tuple | None, shown: tuple, behavior: str) -> tuple | None:
    """A shown-behaviours field of a part: ``shown`` kept to ``behavior``, or None (the
    part's default, its one behaviour) where the whole plan left the field unset too, so
    that a plan of one behaviour is its own part."""
    kept = tuple(b for b in shown if b == behavior)
    return None if given is None and kept == (behavior,) else kept


def part_plan(plan: Plan, behavior: str) -> Plan:
    """The part of ``plan`` that trains ``behavior`` alone, with every output of ``plan``
    that lives under it (the module's docstring)."""
    if behavior not in plan.behaviors:
        raise ValueError(
            f"--part {behavior} is not trained on (--behaviors {' '.join(plan.behaviors)}): "
            "choose one of those"
        )
    first = behavior == plan.behaviors[0]
    fig9 = plan.fig9 and behavior in plan.fig9_columns
    return dataclasses.replace(
        plan,
        behaviors=(behavior,),
        table_i_behaviors=_narrowed(plan.table_i_behaviors, plan.table_i_rows, behavior),
        fig6_behaviors=_narrowed(plan.fig6_behaviors, plan.fig6_columns, behavior),
        fig9=fig9,
        fig9_behaviors=(
            _narrowed(plan.fig9_behaviors, plan.fig9_columns, behavior)
            if fig9
            else plan.fig9_behaviors
        ),
        transfer_behaviors=plan.transfer_behaviors if behavior == plan.transfer_from else (),
        table_ii=plan.table_ii and first,
        part=None,
        merge_parts=(),
    )


def part_plans(plan: Plan) -> dict[str, Plan]:
    """Every part of ``plan``, by behaviour, in the order of ``plan.behaviors``."""
    return {b: part_plan(plan, b) for b in plan.behaviors}


def _identity(plan_json: dict) -> dict:
    """A plan's record without the fields parts may differ in (``ROUNDING_ONLY``: a part
    trained grouped on a GPU, another one by one on a CPU)."""
    return {k: v for k, v in plan_json.items() if k not in ROUNDING_ONLY}


def _which_part(folder: Path, parts: dict[str, Plan]) -> str:
    recorded = _identity(
        read_json(folder / "plan.json", "name a part's results folder (run it with --part first)")
    )
    for behavior, p in parts.items():
        if not plans_differ(recorded, _identity(p.to_json())):
            return behavior
    near = min(parts, key=lambda b: len(config_diff(recorded, _identity(parts[b].to_json()))))
    diff = config_diff(recorded, _identity(parts[near].to_json()))
    fields = ", ".join(sorted(diff)[:4])
    raise ValueError(
        f"--merge-parts {folder} is no part of this plan: its plan.json differs from part "
        f"{near}'s in {fields}; merge the parts of the plan given on the command line"
    )


def _copy_part(src: Path, out: Path, skip_fig9_videos: bool) -> int:
    copied = 0
    for path in sorted(src.rglob("*")):
        rel = path.relative_to(src)
        if path.is_dir() or any(part in KEPT_OUT for part in rel.parts):
            continue
        if len(rel.parts) == 1 and rel.name in OWN_FILES:
            continue
        if skip_fig9_videos and rel.parts[0] == "videos" and rel.name.startswith("fig9_"):
            continue
        dest = out / rel
        dest.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, dest)
        copied += 1
    return copied


def merge(plan: Plan, folders: Sequence[Path], out: Path) -> dict:
    """Copy the parts in ``folders`` (one per trained behaviour of ``plan``) into ``out``,
    with their wall times summed in ``out/wall.json`` and a record of each part in
    ``out/parts.json``; the whole plan's run then finds their stages done. Refuses a folder
    that is no part of ``plan``, a part named twice or missing, and (``unfinished``) a part
    that has not written its report."""
    parts = part_plans(plan)
    found: dict[str, Path] = {}
    for folder in map(Path, folders):
        behavior = _which_part(folder, parts)
        if behavior in found:
            raise ValueError(
                f"--merge-parts names part {behavior} twice ({found[behavior]}, {folder})"
            )
        if not (folder / "results.json").exists():
            raise ValueError(
                f"--merge-parts {folder}: part {behavior} is unfinished (no results.json); "
                "run its command to the end first"
            )
        found[behavior] = folder
    missing = [b for b in parts if b not in found]
    if missing:
        raise ValueError(
            f"--merge-parts lacks the parts of {', '.join(missing)}: run each with "
            f"--part BEHAVIOR and name its folder"
        )
    filmed = _filmed_fig9_behavior(plan)
    out.mkdir(parents=True, exist_ok=True)
    total_s, stages_s, record = 0.0, {}, []
    for behavior, folder in found.items():
        files = _copy_part(folder, out, skip_fig9_videos=behavior != filmed)
        wall = read_json(folder / "wall.json") if (folder / "wall.json").exists() else {}
        total_s += wall.get("total_s", 0.0)
        for name, s in wall.get("stages_s", {}).items():
            stages_s[name] = stages_s.get(name, 0.0) + s
        results = read_json(folder / "results.json")
        recorded = read_json(folder / "plan.json")
        record.append(
            {
                "behavior": behavior,
                "folder": str(folder),
                "files": files,
                "wall_s": wall.get("total_s"),
                "commit": results.get("commit"),
                **{k: recorded.get(k) for k in ROUNDING_ONLY},
            }
        )
    write_json(out / "wall.json", {"this_invocation_s": 0.0, "total_s": total_s,
                                   "stages_s": stages_s})  # fmt: skip
    write_json(out / "parts.json", record)
    return {"parts": record, "total_s": total_s}


def unfinished_jobs(plan: Plan, out: Path) -> list[str]:
    """The names of the jobs the whole plan would still run in ``out`` (after a merge:
    none, or the parts were not this plan's)."""
    return [job.name for stage in stages_of(plan) for job in stage.jobs(plan, out)]
