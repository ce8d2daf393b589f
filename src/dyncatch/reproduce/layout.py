"""Where a reproduction keeps what it made, and the rules of that cache.

Layout under ``out``::

    plan.json                              the plan (a different plan is refused)
    predictors/{behavior}_{kind}/          frozen predictors of p_rl / sp_rl
    table_ii/                              Table II (md, csv, png, json)
    runs/{behavior}/{method}/seed{s}/      training runs (checkpoint, metrics.csv, tb/, done.json)
    eval/table_i/{behavior}/{policy}.json  one evaluation cell list per policy
    eval/fig6/{behavior}/{policy}.json
    eval/transfer/{behavior}/{policy}.json transfer: ``transfer_from``'s policies elsewhere
    eval/fig9/{scene}/{behavior}/{row}.json  Fig. 9 cells (a row: a policy, blended or not)
    videos/{method}_{behavior}.gif         the filmed method (sp_rl)
    videos/fig9_{scene}.gif                Fig. 9: blended sp_rl in each scene

Every file is written atomically (or, for a training run, finished by ``done.json``), so
whoever wrote it (this process or a Ray worker) and whenever it was interrupted, a file
that exists is whole.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from dyncatch.predictor.checkpoint import PREDICTOR_FILE
from dyncatch.reproduce.plan import PROFILES, Plan
from dyncatch.rl.methods import get_method
from dyncatch.sim.config import LEGACY_WORLD
from dyncatch.utils.config_io import config_diff, flatten
from dyncatch.utils.files import read_json, write_json


def cached(path: Path, compute: Callable[[], object]):
    if path.exists():
        return read_json(path)
    value = compute()
    write_json(path, value)
    return value


def check_plan(out: Path, plan: Plan) -> None:
    """Record the plan; refuse to mix the results of two different plans in one folder."""
    path = out / "plan.json"
    want = plan.to_json()
    if path.exists():
        have = read_json(path, "delete it, or choose another --out")
        if have != want:
            diff = plan_diff(have, want)
            if not diff:  # only fields added since, at their defaults: same results
                write_json(path, want)
                return
            shown = ", ".join(f"{k} ({diff[k][0]} -> {diff[k][1]})" for k in list(diff)[:4])
            more = f" and {len(diff) - 4} more" if len(diff) > 4 else ""
            raise ValueError(
                f"{out} holds a reproduction with other {shown}{more}; "
                "re-run with the same flags to resume, or choose another --out"
            )
    else:
        write_json(path, want)


LEGACY_VALUES: dict[str, tuple] = {
    "vmap_seeds": (False,),
    "fig9": (False, True),
    "ground_truth": (),
    "ppo.obs_min_std": (0.0,),
    "fig9_speed_mps": (None,),
    "transfer_behaviors": ([],),
    "table_ii": (True,),
    "power": (False,),
    **{f"world.{k}": (v,) for k, v in LEGACY_WORLD.items()},
}
"""Plan fields added after plans were recorded whose default is not (only) what the code did
before them, mapped to the values a recorded plan without them is compatible with: plans
recorded before ``fig9_speed_mps`` drew Fig. 9's speed per episode (None); before
``transfer_behaviors`` there was no transfer table (adding it only adds its files); plans
recorded before ``vmap_seeds`` trained their seeds one by one; plans recorded before
``fig9`` ran no Fig. 9 (off), and turning the stage on only adds its files; plans recorded
before ``ppo.obs_min_std`` normalised without a floor; the world's ``LEGACY_WORLD`` fields
(plans recorded before ``world.observation.staleness_inputs`` fed the staleness inputs, so
they resume only with ``--world.observation.staleness-inputs``; a ``--setting`` is recorded
too, so adding ``staleness_observation`` to it would not match). Before ``ground_truth``
was recorded gt_rl trained with ``always`` and then, for a while, ``when_predicted``: none
is compatible, so such a folder's gt_rl runs are never reused."""


def plan_diff(have: dict, want: dict) -> dict:
    """The differing fields, leaving out those the recorded plan lacks whose new value is
    compatible with what the code did before the field existed: one of its ``LEGACY_VALUES``,
    else its default in the recorded plan's profile (a field added later defaults to the old
    behaviour unless listed there). So a cached study made before it still holds. A field
    removed since, or one set to another value, counts."""

    profile = PROFILES["quick" if have.get("quick") else "power" if have.get("power") else "full"]
    accepted = {k: (v,) for k, v in flatten(profile.to_json()).items()} | LEGACY_VALUES
    known = flatten(have)
    return {
        k: v
        for k, v in config_diff(have, want).items()
        if k in known or k not in accepted or v[1] not in accepted[k]
    }


def plans_differ(a: dict, b: dict) -> dict:
    """The fields in which two recorded plans (``plan.json`` contents) differ, leaving out a
    field one of them lacks where the other holds what the code did before it existed
    (``plan_diff`` both ways): two runs of one plan, one recorded before a field was added,
    do not differ."""
    back = plan_diff(b, a)
    return {k: v for k, v in plan_diff(a, b).items() if k in back}


def predictor_dir(out: Path, behavior: str, kind: str) -> Path:
    return out / "predictors" / f"{behavior}_{kind}"


def predictor_path(out: Path, behavior: str, method: str) -> Path | None:
    """The frozen predictor ``method`` reads for ``behavior``'s runs (None if it reads none)."""
    kind = get_method(method).predictor_kind
    return None if kind is None else predictor_dir(out, behavior, kind) / PREDICTOR_FILE


def run_dir(out: Path, behavior: str, method: str, seed: int) -> Path:
    return out / "runs" / behavior / method / f"seed{seed}"


def source_behavior(plan: Plan, behavior: str, table: str | None = None) -> str:
    """Behaviour whose policies (and predictors) are evaluated on ``behavior`` in ``table``:
    the transfer table's are ``plan.transfer_from``'s; everywhere else its own (the paper's
    protocol), and a behaviour not trained on is refused (``validate_plan`` names the flag)."""
    if table == "transfer":
        return plan.transfer_from
    if behavior not in plan.behaviors:
        raise ValueError(
            f"{behavior} is evaluated but not trained on: add it to --behaviors "
            "(policies tested on another behaviour belong in --transfer-behaviors)"
        )
    return behavior


def cell_name(method: str, seed: int | None) -> str:
    return method if seed is None else f"{method}_seed{seed}"


def cell_path(out: Path, table: str, behavior: str, method: str, seed: int | None) -> Path:
    return out / "eval" / table / behavior / f"{cell_name(method, seed)}.json"


def fig6_evaluated_columns(plan: Plan) -> tuple[str, ...]:
    """The Fig. 6 columns evaluated on their own: all of them when Fig. 6's speed is not a
    Table I speed, else those that are not Table I rows (the others reuse Table I's cells:
    the same policies, behaviour, speed and episode count)."""
    if not any(abs(plan.fig6_speed_mps - v) < 1e-9 for v in plan.speeds_mps):
        return plan.fig6_columns
    return tuple(b for b in plan.fig6_columns if b not in plan.table_i_rows)
