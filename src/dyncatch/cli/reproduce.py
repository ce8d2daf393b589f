"""``dyncatch reproduce [--quick]``: the flags are ``dyncatch.reproduce.plan.Plan`` itself."""

from __future__ import annotations

import sys

from dyncatch.cli.progress import rich_progress
from dyncatch.reproduce.pipeline import run
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.validate import validate_plan
from dyncatch.utils.files import check_out_dir


def run_reproduce(plan: Plan) -> dict:
    plan = validate_plan(plan)
    check_out_dir(plan.out_dir)
    command = "dyncatch " + " ".join(sys.argv[1:]) if sys.argv[1:] else "dyncatch reproduce"
    with rich_progress() as progress:
        return run(plan, command, lambda msg: progress.log(f"[bold]{msg}"), progress)
