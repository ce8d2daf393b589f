"""Run every stage of a reproduction in order (``stages.STAGES``), then write the report.

The stages are cached, so this is also the resume path: re-running the same command skips
what is finished and continues an interrupted training run. Each stage's independent jobs
run on the plan's executor (``executors.py``: here, or on Ray).
"""

from __future__ import annotations

import subprocess
import time
from collections.abc import Callable

from dyncatch.reproduce import executors, layout, summary
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.report_md import render_report
from dyncatch.reproduce.stages import estimate_s, stages_of
from dyncatch.utils.files import read_json


def _commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, timeout=10
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            timeout=10,
        )
        return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "") or "unknown"
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def run(plan: Plan, command: str, log: Callable[[str], None], progress=None) -> dict:
    """Every stage of ``plan`` into ``plan.out_dir``; ``log`` gets one line per stage and
    ``progress`` (``dyncatch.utils.progress``) the bars of long stages."""
    out = plan.out_dir
    t_start = time.perf_counter()
    say = log

    def log(msg: str) -> None:
        say(f"[{time.perf_counter() - t_start:6.0f} s] {msg}")

    out.mkdir(parents=True, exist_ok=True)
    layout.check_plan(out, plan)
    log(
        f"estimated wall time for the whole plan on 2 cores: {estimate_s(plan) / 60:.0f} min "
        "(finished stages are skipped)"
    )

    stages = stages_of(plan)
    outputs = {}
    executor = executors.make_executor(plan, log, progress)
    try:
        for i, stage in enumerate(stages, 1):
            jobs = stage.jobs(plan, out)
            todo = f"{len(jobs)} job{'s' * (len(jobs) != 1)}" if jobs else "done"
            log(f"stage {i}/{len(stages)}: {stage.title} ({todo})")
            executor.run(jobs)
            outputs[stage.name] = stage.collect(plan, out)
    finally:
        executor.close()

    results = summary.results(plan, out, outputs, command, _commit())
    wall_path = out / "wall.json"
    previous = read_json(wall_path)["total_s"] if wall_path.exists() else 0.0
    this_s = time.perf_counter() - t_start
    results["wall"] = {"this_invocation_s": this_s, "total_s": previous + this_s}
    layout.write_json(wall_path, results["wall"])
    layout.write_json(out / "results.json", results)
    (out / "report.md").write_text(render_report(results, plan))
    log(f"wrote {out / 'report.md'} and {out / 'results.json'} ({this_s / 60:.1f} min)")
    return results
