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

from dyncatch.bench.speed_probe import REFERENCE, MachineSpeed, probe_speed
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
    earlier invocations plus this one's, and each stage's (``enter``), rewritten every
    ``every_s`` seconds (and at ``tick``), so an invocation that is killed loses at most
    ``every_s`` of its time."""

    def __init__(self, path: Path, every_s: float = 30.0):
        self.path = path
        before = read_json(path) if path.exists() else {}
        self.previous_s = before.get("total_s", 0.0)
        self.previous_stages_s = dict(before.get("stages_s", {}))
        self.t_start = time.perf_counter()
        self._stages_s: dict[str, float] = {}
        self._stage: str | None = None
        self._stage_t0 = 0.0
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._thread = threading.Thread(target=self._loop, args=(every_s,), daemon=True)

    def elapsed_s(self) -> float:
        return time.perf_counter() - self.t_start

    def enter(self, stage: str | None) -> None:
        """Count the time from now on to ``stage`` (None: to no stage)."""
        with self._lock:
            now = time.perf_counter()
            if self._stage is not None:
                spent = now - self._stage_t0
                self._stages_s[self._stage] = self._stages_s.get(self._stage, 0.0) + spent
            self._stage, self._stage_t0 = stage, now

    def _all_stages_s(self, now: float) -> dict[str, float]:
        out = dict(self.previous_stages_s)
        for name, s in self._stages_s.items():
            out[name] = out.get(name, 0.0) + s
        if self._stage is not None:
            out[self._stage] = out.get(self._stage, 0.0) + now - self._stage_t0
        return out

    def tick(self) -> dict:
        with self._lock:
            now = time.perf_counter()
            this_s = now - self.t_start
            wall = {
                "this_invocation_s": this_s,
                "total_s": self.previous_s + this_s,
                "stages_s": self._all_stages_s(now),
            }
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
        self.enter(None)
        self.tick()


def estimate_line(plan: Plan, speed: MachineSpeed | None, probe: dict | None) -> str:
    """The first line of the log: the whole plan's estimate on the reference machine, and
    with a probe's ``speed`` on this one."""
    line = f"estimated wall time for the whole plan: {estimate_s(plan) / 60:.0f} min on the "
    line += "reference machine (the idle 2-core Xeon the estimate was fit on)"
    if speed is not None:
        line += (
            f"; this machine takes {speed.compute:.2f}x its time to compute and "
            f"{speed.compile:.2f}x to compile (a {probe['probe_wall_s']:.0f} s probe), so here "
            f"about {estimate_s(plan, speed) / 60:.0f} min"
        )
    return line + " (finished stages are skipped)"


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

    speed, probe = None, None
    if plan.probe_machine and not plan.merge_parts:
        speed, probe = probe_speed()
    log(estimate_line(plan, speed, probe))

    stages = stages_of(plan)
    outputs = {}
    executor = executors.make_executor(plan, log, progress)
    try:
        for i, stage in enumerate(stages, 1):
            jobs = stage.jobs(plan, out)
            todo = "done"
            if jobs:
                todo = f"{len(jobs)} job{'s' * (len(jobs) != 1)}; the whole stage estimated at "
                todo += f"{stage.estimate(plan, speed or REFERENCE) / 60:.0f} min"
            log(f"stage {i}/{len(stages)}: {stage.title} ({todo})")
            clock.enter(stage.name)
            executor.run(jobs)
            outputs[stage.name] = stage.collect(plan, out)
    finally:
        clock.enter(None)
        executor.close()

    results = summary.results(plan, out, outputs, command, _commit())
    results["wall"] = clock.tick()
    results["wall"]["stages_estimate_s"] = {s.name: s.estimate(plan) for s in stages}
    if speed is not None:
        wall = results["wall"]
        wall["machine_speed"] = {"compute": speed.compute, "compile": speed.compile}
        wall["machine_probe"] = probe
        wall["stages_estimate_here_s"] = {s.name: s.estimate(plan, speed) for s in stages}
    layout.write_json(out / "results.json", results)
    (out / "report.md").write_text(render_report(results, plan))
    this_min = results["wall"]["this_invocation_s"] / 60
    log(f"wrote {out / 'report.md'} and {out / 'results.json'} ({this_min:.1f} min)")
    return results
