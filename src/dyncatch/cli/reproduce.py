"""``dyncatch reproduce [--quick]``: the flags are ``dyncatch.reproduce.plan.Plan`` itself."""

from __future__ import annotations

import sys

from dyncatch.cli.progress import rich_progress
from dyncatch.reproduce.parts import merge, part_plan, unfinished_jobs
from dyncatch.reproduce.pipeline import run
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.validate import validate_plan
from dyncatch.utils.files import check_out_dir


def run_reproduce(plan: Plan) -> dict:
    plan = validate_plan(plan)
    check_out_dir(plan.out_dir)
    if plan.part is not None and plan.merge_parts:
        raise ValueError("--part runs one part and --merge-parts merges them: choose one")
    if plan.part is not None:
        plan = part_plan(plan, plan.part)  # derived from the validated whole plan
    elif plan.merge_parts:
        merge(plan, plan.merge_parts, plan.out_dir)
        left = unfinished_jobs(plan, plan.out_dir)
        if left:
            raise ValueError(
                f"--merge-parts: the parts leave {len(left)} job(s) of the plan undone "
                f"(e.g. {'; '.join(left[:3])}): were they run with this plan's flags?"
            )
    command = "dyncatch " + " ".join(sys.argv[1:]) if sys.argv[1:] else "dyncatch reproduce"
    with rich_progress() as progress:
        return run(plan, command, lambda msg: progress.log(f"[bold]{msg}"), progress)
