"""``dyncatch eval RUN_OR_METHOD``: success rate and catch time per target speed (Table I).

A run is evaluated in the world it was trained in; ``--world.*`` flags apply on top of it
(a first generalisation test), and the output says which fields differ.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Literal

import tyro

from dyncatch.evaluation.backends import EvalBackendName, get_backend
from dyncatch.evaluation.grid import evaluate_speeds
from dyncatch.fullbody.config import FullBodyCfg, validate_fullbody
from dyncatch.policies.blend import Blended, PlaneScan, deploy
from dyncatch.reproduce.paper import PAPER_SPEEDS_MPS
from dyncatch.rl.methods import MethodName
from dyncatch.rl.policy import checkpoint_path, header_world
from dyncatch.rl.resolve import resolve_policy
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_speeds, validate_world
from dyncatch.utils.config_io import config_diff
from dyncatch.utils.tree_io import read_header


@dataclasses.dataclass(frozen=True)
class EvalCmd:
    """Evaluate a trained run or a baseline on evaluation seeds disjoint from training ones."""

    method: tyro.conf.Positional[str]
    """A run folder written by dyncatch train, or a non-learned baseline: pursuit, intercept."""
    speeds: tuple[float, ...] = PAPER_SPEEDS_MPS
    """Target speeds (m/s), one row each (default: the paper's Table I)."""
    episodes: int = 1000
    """Episodes per speed (each environment plays exactly one)."""
    seed: int = 0
    """Evaluation seed."""
    as_method: MethodName | None = None
    """Evaluate a run as a method that reuses its policy (sp_fp for a gt_rl run)."""
    predictor: Path | None = None
    """Predictor checkpoint, overriding the one the run was trained with (needed for sp_fp)."""
    backend: EvalBackendName = "jax"
    """Where the episodes are played (dyncatch.evaluation.backends): jax, the reduced-order
    world; mujoco, the full-body Aliengo + Z1 (pip install -e '.[fullbody]'; open plane
    only; docs/fullbody.md). The same seed plays the same episodes on both."""
    fullbody: FullBodyCfg = FullBodyCfg()
    """The full body (``--backend mujoco`` only; docs/fullbody.md, "Constants"). Fields set
    away from their defaults are recorded in the JSON's ``fullbody_changes``."""
    blend: bool = False
    """Deploy with eq. 10's collision avoidance (policies.blend, docs/scenes.md), as Fig. 9
    does in rooms and woods."""
    scan: Literal["auto", "own", "plane"] = "auto"
    """The range scan a trained run reads: auto shows a run trained on the open plane the
    plane's scan (every ray at its cap) in any scene, as Fig. 9 does (its normaliser never
    saw a wall); own feeds it the scene's scan; plane forces the plane's."""
    json: bool = False
    """Print one JSON object {"rows": [...], "world_changes": {...}, "deployment": {...}}
    instead of a table."""
    world: WorldCfg = WorldCfg()
    """The simulated world: a run's training world (its behaviour included), with any
    --world.* flag (--behavior, --scene) on top of it (baselines: the library default)."""


def _run_world(target: str) -> WorldCfg | None:
    """The training world recorded in a run folder's checkpoint, or None if not a run."""
    path = checkpoint_path(target)
    if not path.is_file():
        return None
    return header_world(path, read_header(path))


def run_world_default(cmd: EvalCmd) -> EvalCmd:
    """The command's defaults with a run's training world in place of the library's."""
    world = _run_world(cmd.method)
    return cmd if world is None else dataclasses.replace(cmd, world=world)


def run_eval(cmd: EvalCmd) -> dict:
    if cmd.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {cmd.episodes}")
    validate_speeds(cmd.speeds, "--speeds")
    fullbody_changes = config_diff(FullBodyCfg(), cmd.fullbody)
    fullbody = None
    if fullbody_changes:
        get_backend(cmd.backend, cmd.fullbody)  # refuses --fullbody.* off the full body
        fullbody = validate_fullbody(cmd.fullbody)
    policy, method, trained_world = resolve_policy(
        cmd.method, cmd.world, cmd.as_method, cmd.predictor
    )
    world = validate_world(cmd.world)

    if trained_world is None and cmd.scan != "auto":
        raise ValueError("--scan applies to trained runs; a baseline reads no scan")
    policy = deploy(
        policy, trained_world, world, cmd.blend, None if cmd.scan == "auto" else cmd.scan
    )

    inner = policy.catch if isinstance(policy, Blended) else policy
    deployment = {
        "blend": cmd.blend,
        "scan": None
        if trained_world is None
        else "plane"
        if isinstance(inner, PlaneScan)
        else "own",
    }
    # Speeds are set per row, so they are no change of world.
    changes = {}
    if trained_world is not None:
        diff = config_diff(trained_world, world)
        changes = {k: v for k, v in diff.items() if not k.startswith("target.speed_")}
    rows = evaluate_speeds(
        policy,
        world,
        world.target.behavior,
        cmd.speeds,
        cmd.episodes,
        cmd.seed,
        method,
        cmd.backend,
        fullbody,
    )
    result = {
        "rows": rows,
        "world_changes": {k: list(v) for k, v in changes.items()},
        "deployment": deployment,
    }
    if fullbody_changes:
        result["fullbody_changes"] = {k: list(v) for k, v in fullbody_changes.items()}
    if cmd.json:
        print(json.dumps(result))
        return result
    print(f"{method} vs {world.target.behavior}, {cmd.episodes} episodes per speed ({cmd.backend})")
    if cmd.blend or deployment["scan"] == "plane":
        print(f"deployed with blend={cmd.blend}, scan={deployment['scan']} (docs/scenes.md)")
    if changes:
        shown = ", ".join(f"{k} {a} -> {b}" for k, (a, b) in changes.items())
        print(f"evaluated in another world than it was trained in: {shown}")
    print("| speed (m/s) | success [95% CI] | catch time (s) |\n|---:|---|---:|")
    for r in rows:
        lo, hi = r["success_ci95"]
        print(
            f"| {r['speed_mps']:.1f} | {r['success_rate']:.3f} [{lo:.3f}, {hi:.3f}] | "
            f"{r['catch_time_s']:.2f} |"
        )
    return result
