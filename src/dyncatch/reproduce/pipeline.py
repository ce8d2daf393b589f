"""Run every stage of a reproduction in order (``stages.STAGES``), then write the report.

The stages are cached, so this is also the resume path: re-running the same command skips
what is finished and continues an interrupted training run. Each stage's independent jobs
run on the plan's executor (``executors.py``: here, or on Ray).
"""

from __future__ import annotations

import subprocess
import threading
import time
from collections.abc import Callable
from pathlib import Path

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


class WallClock:
    """The plan's wall time over every invocation, kept in ``wall.json``: the total of the
    earlier invocations plus this one's, rewritten every ``every_s`` seconds (and at
    ``tick``), so an invocation that is killed loses at most ``every_s`` of its time."""

    def __init__(self, path: Path, every_s: float = 30.0):
        self.path = path
        self.previous_s = read_json(path)["total_s"] if path.exists() else 0.0
        self.t_start = time.perf_counter()
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._loop, args=(every_s,), daemon=True)

    def elapsed_s(self) -> float:
        return time.perf_counter() - self.t_start

    def tick(self) -> dict:
        with self._lock:
            this_s = self.elapsed_s()
            wall = {"this_invocation_s": this_s, "total_s": self.previous_s + this_s}
            layout.write_json(self.path, wall)
        return wall

    def _loop(self, every_s: float) -> None:
        while not self._stop.wait(every_s):
            self.tick()

    def __enter__(self) -> WallClock:
        self.tick()
        self._thread.start()
        return self

    def __exit__(self, *exc) -> None:
        self._stop.set()
        self._thread.join()
        self.tick()


def run(plan: Plan, command: str, log: Callable[[str], None], progress=None) -> dict:
    """Every stage of ``plan`` into ``plan.out_dir``; ``log`` gets one line per stage and
    ``progress`` (``dyncatch.utils.progress``) the bars of long stages."""
    out = plan.out_dir
    out.mkdir(parents=True, exist_ok=True)
    layout.check_plan(out, plan)
    with WallClock(out / "wall.json") as clock:
        return _run(plan, out, command, log, progress, clock)


def _run(plan: Plan, out: Path, command, say, progress, clock: WallClock) -> dict:
    def log(msg: str) -> None:
        say(f"[{clock.elapsed_s():6.0f} s] {msg}")

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
    results["wall"] = clock.tick()
    layout.write_json(out / "results.json", results)
    (out / "report.md").write_text(render_report(results, plan))
    this_min = results["wall"]["this_invocation_s"] / 60
    log(f"wrote {out / 'report.md'} and {out / 'results.json'} ({this_min:.1f} min)")
    return results
