"""Fig. 9: policies trained on the plane, deployed in rooms and woods (paper Sec. V-E).

Each cell is (scene, behaviour, row, seed): success, mean catch time and contacts per
episode over ``plan.fig9_episodes`` episodes of the scene's length (40 s), the target's
speed drawn per episode from the world's range (the paper gives none for Fig. 9). A row is
a policy with or without eq. 10's collision-avoidance blend (``policies.blend``): the
paper's method (``sp_rl``, over the plan's seeds, trained on the plane) without and with
it, and the scripted baselines with it. A learned policy keeps the scan width it was
trained with (its input size) and, trained on the plane, is shown the plane's scan (every
ray at its cap: ``policies.blend.plane_scan``); pi_collid reads a 32-ray scan of its own.
Every row of a cell plays the same episodes (same key). One GIF per scene shows the blended
``sp_rl``.

Layout: ``eval/fig9/{scene}/{behavior}/{row}[_seed{s}].json`` and
``videos/fig9_{scene}.gif``.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass
from pathlib import Path

from dyncatch.reproduce.layout import cached, cell_name, source_behavior
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.stages import Job, load_policy
from dyncatch.utils.files import read_json

CONTACT_TOL_M = 1e-3
"""A contact: the footprint within 1 mm of a wall or obstacle (a push-out leaves it at 0;
``evaluation.episodes.run_episodes``)."""


@dataclass(frozen=True)
class Fig9Row:
    policy: str
    """A method (trained on the plane, evaluated over seeds) or a baseline, by name."""
    blend: bool
    """Eq. 10's collision avoidance on."""

    @property
    def name(self) -> str:
        return self.policy + ("+blend" if self.blend else "")

    @property
    def label(self) -> str:
        from dyncatch.reproduce.report import label

        return label(self.policy) + (" + blend" if self.blend else "")

    @property
    def learned(self) -> bool:
        from dyncatch.rl.methods import METHODS

        return self.policy in METHODS


FIG9_ROWS: tuple[Fig9Row, ...] = (
    Fig9Row("sp_rl", False),
    Fig9Row("sp_rl", True),
    Fig9Row("pursuit", True),
    Fig9Row("intercept", True),
)
"""The rows of Fig. 9: the paper's method without and with the blend (its effect), and
the baselines with it."""


def rows_of(plan: Plan) -> tuple[Fig9Row, ...]:
    """The rows a plan evaluates: ``FIG9_ROWS``, then each selected method beyond the
    paper that PPO trains (``st_rl``), with the blend, as the paper's method is shown."""
    from dyncatch.rl.methods import METHODS, trained_methods

    extra = [m for m in trained_methods(plan.method_names) if not METHODS[m].reproduced]
    return FIG9_ROWS + tuple(Fig9Row(m, True) for m in extra)


def row_named(name: str) -> Fig9Row:
    """The row of a name (``policy`` or ``policy+blend``)."""
    policy, plus, rest = name.partition("+")
    if plus and rest != "blend":
        raise ValueError(f"not a Fig. 9 row: {name!r} (want POLICY or POLICY+blend)")
    return Fig9Row(policy, bool(plus))


def scene_world(world, scene: str, behavior: str, plan: Plan):
    """``world`` in ``scene`` with ``behavior`` and the scene's episode length (or
    ``plan.fig9_duration_s``); the scan keeps its rays (a trained policy's input size)."""
    from dyncatch.sim.scenes import get_scene

    duration = plan.fig9_duration_s or get_scene(scene).duration_s
    w = world.with_scene(scene).with_behavior(behavior)
    return w.replace(episode=w.episode.replace(duration_s=duration))


def cell_key(scene: str, behavior: str):
    """The evaluation key of a (scene, behaviour) cell: every row and seed plays the same
    episodes, and no key depends on which other scenes the plan holds."""
    import jax

    from dyncatch.evaluation.grid import EVAL_STREAM

    key = jax.random.fold_in(jax.random.key(0), EVAL_STREAM)
    return jax.random.fold_in(key, zlib.crc32(f"fig9/{scene}/{behavior}".encode()) & 0x7FFFFFFF)


def deployed(plan: Plan, out: Path, scene: str, behavior: str, row: Fig9Row, seed):
    """(policy, world) of a row in a scene: the plane-trained policy (or the baseline),
    blended if the row says so. A policy trained where the scan reads nothing (no walls,
    no obstacles) is shown that scan (``policies.blend.plane_scan``)."""
    from dyncatch.policies.blend import deploy

    policy, trained_world = load_policy(plan, out, behavior, row.policy, seed)
    world = scene_world(trained_world, scene, behavior, plan)
    if not row.learned:  # a baseline is built for the world it plays in
        from dyncatch.policies.registry import BASELINES

        return deploy(BASELINES[row.policy](world), None, world, row.blend), world
    return deploy(policy, trained_world, world, row.blend), world


def cell_path(out: Path, scene: str, behavior: str, row: str, seed) -> Path:
    return out / "eval" / "fig9" / scene / behavior / f"{cell_name(row, seed)}.json"


def _cell_job(plan: Plan, out: Path, scene, behavior, row: str, seed, progress=None) -> None:
    def compute():
        import jax
        import numpy as np

        from dyncatch.evaluation.episodes import run_episodes
        from dyncatch.evaluation.stats import summarize

        policy, world = deployed(plan, out, scene, behavior, row_named(row), seed)
        key = cell_key(scene, behavior)
        outcome = jax.device_get(
            run_episodes(policy, key, world, plan.fig9_episodes, contact_tol_m=CONTACT_TOL_M)
        )
        s = summarize(outcome)
        return {
            "scene": scene,
            "behavior": behavior,
            "method": row,
            "seed": seed,
            "episodes": s["episodes"],
            "success_rate": s["success_rate"],
            "success_ci95": s["success_ci95"],
            "catch_time_s": s["catch_time_s"],
            "contacts_per_episode": float(np.mean(outcome["contacts"])),
            "trained_on": source_behavior(plan, behavior) if row_named(row).learned else None,
        }

    cached(cell_path(out, scene, behavior, row, seed), compute)


def _cells(plan: Plan, rows) -> list[tuple]:
    return [
        (scene, behavior, r.name, seed)
        for scene in plan.fig9_scenes
        for behavior in plan.fig9_behaviors
        for r in rows
        for seed in (range(plan.seeds) if r.learned else (None,))
    ]


def evaluate(plan: Plan, out: Path, executor, rows=None) -> list[dict]:
    """Every cell of Fig. 9 (cached one file each; default rows: ``rows_of(plan)``); the
    rows of all of them."""
    cells = _cells(plan, rows_of(plan) if rows is None else rows)
    executor.run(
        [
            Job(
                f"fig9: {r}{'' if s is None else f' seed {s}'} in {sc} on {b}",
                _cell_job,
                (plan, out, sc, b, r, s),
            )
            for sc, b, r, s in cells
            if not cell_path(out, sc, b, r, s).exists()
        ]
    )
    return [read_json(cell_path(out, *c)) for c in cells]


def _video_job(plan: Plan, out: Path, scene: str, row: str, progress=None) -> None:
    import jax

    from dyncatch.viz.render import render_frames, write_video
    from dyncatch.viz.trajectory import catch_time_s, record_episode, scene_extras

    path = out / "videos" / f"fig9_{scene}.gif"
    behavior = plan.fig9_behaviors[0]
    r = row_named(row)

    def compute():
        policy, world = deployed(plan, out, scene, behavior, r, 0 if r.learned else None)
        extra = scene_extras(world, policy.cfg if r.blend else None)
        traj = record_episode(policy, jax.random.key(0), world, extra_fn=extra)
        write_video(render_frames(traj, world, every=5, size_px=400), path, fps=10)
        t = catch_time_s(traj)
        return {
            "scene": scene,
            "behavior": behavior,
            "method": row,
            "file": str(path.relative_to(out)),
            "caught": t is not None,
            "catch_time_s": t,
        }

    cached(path.with_suffix(".json"), compute)


def record_videos(plan: Plan, out: Path, executor, row: str = "sp_rl+blend") -> list[dict]:
    """One GIF per scene of ``row`` (seed 0) on the first Fig. 9 behaviour."""
    path = lambda sc: out / "videos" / f"fig9_{sc}.json"  # noqa: E731
    executor.run(
        [
            Job(f"fig9 video in {sc}", _video_job, (plan, out, sc, row))
            for sc in plan.fig9_scenes
            if not path(sc).exists()
        ]
    )
    return [read_json(path(sc)) for sc in plan.fig9_scenes]


def summarize(rows: list[dict]) -> list[dict]:
    """Cells over seeds per (scene, behaviour, row): ``aggregate.summarize_cells``'s success
    and catch time (CIs over seeds with 2+ seeds, else Wilson over episodes) plus the mean
    contacts per episode with its CI over seeds."""
    from dyncatch.reproduce.aggregate import mean_ci, summarize_cells

    out = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        mine = [{**r, "speed_mps": None} for r in rows if r["scene"] == scene]
        for c in summarize_cells(mine):
            contacts = [
                r["contacts_per_episode"]
                for r in mine
                if (r["behavior"], r["method"]) == (c["behavior"], c["method"])
            ]
            m, ci = mean_ci(contacts)
            c.pop("speed_mps")
            out.append(
                {"scene": scene, **c, "contacts_per_episode": m, "contacts_ci95": ci and list(ci)}
            )
    return out
