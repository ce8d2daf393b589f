"""Where a reproduction's time goes, stage by stage: wall and CPU seconds, the XLA
compilations (count and seconds) and the estimate printed before it (``reproduce.estimate``).

    python benchmarks/reproduce_stages.py --out /tmp/q1            # the quick profile
    python benchmarks/reproduce_stages.py --out /tmp/q1 --json /tmp/q1_stages.json

It runs ``dyncatch reproduce --quick`` in this process with an empty persistent
compilation cache of its own (a fresh clone's first ``make demo``), so every compilation
counted is a real one. A compilation's seconds are JAX's tracing, lowering and XLA
compilation of one jitted program; those under 0.2 s (eager operations, small helpers) are
counted apart. On a machine shared with other work the wall seconds stretch; the CPU seconds
and the compilations' share of them are what to compare with an idle run.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import tempfile
import time
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

EVENTS = (
    "/jax/core/compile/jaxpr_trace_duration",
    "/jax/core/compile/jaxpr_to_mlir_module_duration",
    "/jax/core/compile/backend_compile_duration",
)
"""JAX's events around one program's tracing, lowering and XLA compilation."""
BIG_S = 0.2
"""A compilation at least this long is a program of the stage's own (a training iteration,
an evaluation rollout); shorter ones are eager operations and small helpers."""


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True, help="results folder (must not exist)")
    p.add_argument("--json", type=Path, default=None, help="also write the table here")
    a = p.parse_args()
    if a.out.exists():
        raise SystemExit(f"{a.out} exists: give a new folder (finished stages would be skipped)")
    os.environ["JAX_COMPILATION_CACHE_DIR"] = tempfile.mkdtemp(prefix="dyncatch_jax_")

    from jax import monitoring

    from dyncatch.reproduce.pipeline import run
    from dyncatch.reproduce.plan import PROFILES
    from dyncatch.reproduce.stages import stages_of
    from dyncatch.reproduce.validate import validate_plan
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    plan = validate_plan(replace(PROFILES["quick"], out=a.out))
    stages = stages_of(plan)
    marks: list[tuple[str, float, float]] = []  # (stage name, wall, cpu) at its start
    current = {"stage": "setup"}

    def log(msg: str) -> None:
        print(msg, flush=True)
        m = re.search(r"stage (\d+)/\d+:", msg)
        if m:
            current["stage"] = stages[int(m.group(1)) - 1].name
            marks.append((current["stage"], time.perf_counter(), time.process_time()))

    # A program's events arrive in order (trace, lower, compile), stage by stage.
    events: list[tuple[str, str, float]] = []

    def listen_ordered(event: str, duration: float, **kwargs) -> None:
        if event in EVENTS:
            events.append((current["stage"], event, duration))

    monitoring.register_event_duration_secs_listener(listen_ordered)
    t0, c0 = time.perf_counter(), time.process_time()
    run(plan, "python benchmarks/reproduce_stages.py", log)
    t1, c1 = time.perf_counter(), time.process_time()
    monitoring.unregister_event_duration_listener(listen_ordered)

    # One program = one backend compilation, plus the trace and lowering just before it.
    compiles: dict[str, list[float]] = defaultdict(list)
    pending = 0.0
    for stage, event, duration in events:
        pending += duration
        if event == EVENTS[2]:
            compiles[stage].append(pending)
            pending = 0.0

    ends = [*(m[1:] for m in marks[1:]), (t1, c1)]
    rows = []
    for (name, w, c), (w_end, c_end) in zip(marks, ends, strict=True):
        stage = next(s for s in stages if s.name == name)
        big = [s for s in compiles[name] if s >= BIG_S]
        small = [s for s in compiles[name] if s < BIG_S]
        rows.append(
            {
                "stage": name,
                "wall_s": round(w_end - w, 1),
                "cpu_s": round(c_end - c, 1),
                "programs": len(big),
                "program_compile_s": [round(s, 1) for s in big],
                "small_compiles": len(small),
                "small_compile_s": round(sum(small), 1),
                "estimate_s": round(stage.estimate(plan), 1),
            }
        )
    result = {
        "plan": "quick",
        "wall_s": round(t1 - t0, 1),
        "cpu_s": round(c1 - c0, 1),
        "setup_compile_s": round(sum(compiles["setup"]), 1),
        "estimate_s": round(sum(s.estimate(plan) for s in stages), 1),
        "stages": rows,
    }
    text = json.dumps(result, indent=1)
    print(text)
    if a.json is not None:
        a.json.write_text(text + "\n")


if __name__ == "__main__":
    main()
