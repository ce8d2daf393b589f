"""Fig. 9: policies trained on the plane, deployed in rooms and woods (paper Sec. V-E).

Each cell is (scene, behaviour, row, seed): success, mean catch time and contacts per
episode over ``plan.fig9_episodes`` episodes of the scene's length (40 s), the target at
``plan.fig9_speed_mps`` (1.8 m/s, the paper's high speed; None: the variant that draws it
per episode from the world's range), recorded in each cell. A policy is deployed on the
behaviour it was trained on, with that behaviour's predictor. A row is
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

import jax
import numpy as np

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.evaluation.grid import EVAL_STREAM
from dyncatch.evaluation.stats import summarize as summarize_outcome
from dyncatch.policies.blend import deploy
from dyncatch.policies.registry import BASELINES
from dyncatch.reproduce.aggregate import mean_ci, summarize_cells
from dyncatch.reproduce.jobs import Job, PolicySpec, policy_spec, seeds_label
from dyncatch.reproduce.layout import cached, cell_name, source_behavior
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.presentation import PRESENTATION
from dyncatch.rl.methods import METHODS, trained_methods
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import get_scene
from dyncatch.utils.files import read_json
from dyncatch.viz.render import render_frames, write_video
from dyncatch.viz.trajectory import catch_time_s, record_episode, scene_extras

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
    def learned(self) -> bool:
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
    extra = [m for m in trained_methods(plan.method_names) if not PRESENTATION[m].reproduced]
    return FIG9_ROWS + tuple(Fig9Row(m, True) for m in extra)


def row_named(name: str) -> Fig9Row:
    """The row of a name (``policy`` or ``policy+blend``)."""
    policy, plus, rest = name.partition("+")
    if plus and rest != "blend":
        raise ValueError(f"not a Fig. 9 row: {name!r} (want POLICY or POLICY+blend)")
    return Fig9Row(policy, bool(plus))


def scene_world(
    world: WorldCfg,
    scene: str,
    behavior: str,
    duration_s: float | None,
    speed_mps: float | None = None,
) -> WorldCfg:
    """``world`` in ``scene`` with ``behavior`` and the scene's episode length (or
    ``duration_s``, the plan's ``fig9_duration_s``), the target's speed fixed at
    ``speed_mps`` (None: drawn from the world's range); the scan keeps its rays (a trained
    policy's input size)."""
    duration = duration_s or get_scene(scene).duration_s
    w = world.with_scene(scene).with_behavior(behavior)
    if speed_mps is not None:
        w = w.with_speed(speed_mps)
    return w.replace(episode=w.episode.replace(duration_s=duration))


def cell_key(scene: str, behavior: str):
    """The evaluation key of a (scene, behaviour) cell: every row and seed plays the same
    episodes, and no key depends on which other scenes the plan holds."""
    key = jax.random.fold_in(jax.random.key(0), EVAL_STREAM)
    return jax.random.fold_in(key, zlib.crc32(f"fig9/{scene}/{behavior}".encode()) & 0x7FFFFFFF)


@dataclass(frozen=True)
class Deployment:
    """A row's policy in a scene: the plane-trained policy (or the baseline), blended if
    the row says so."""

    scene: str
    behavior: str
    blend: bool
    policy: PolicySpec
    duration_s: float | None = None
    speed_mps: float | None = None
    """The target's speed (None: drawn per episode)."""

    def load(self, blend_as_flag: bool = False):
        """(policy, world). A policy trained where the scan reads nothing (no walls, no
        obstacles) is shown that scan (``policies.blend.plane_scan``). ``blend_as_flag``:
        the blend a flag of the policy (``policies.blend.deploy``), so a learned policy's
        rows with and without it share one compiled evaluation."""
        policy, trained_world = self.policy.load()
        world = scene_world(
            trained_world, self.scene, self.behavior, self.duration_s, self.speed_mps
        )
        if not self.policy.learned:  # a baseline is built for the world it plays in
            policy, trained_world = BASELINES[self.policy.name](world), None
        return deploy(policy, trained_world, world, self.blend, blend_as_flag=blend_as_flag), world


def deployment(plan: Plan, out: Path, scene: str, behavior: str, row: Fig9Row, seed):
    return Deployment(
        scene,
        behavior,
        row.blend,
        policy_spec(plan, out, behavior, row.policy, seed if row.learned else None),
        plan.fig9_duration_s,
        plan.fig9_speed_mps,
    )


def cell_path(out: Path, scene: str, behavior: str, row: str, seed) -> Path:
    return out / "eval" / "fig9" / scene / behavior / f"{cell_name(row, seed)}.json"


@dataclass(frozen=True)
class Fig9Cell:
    """One (scene, behaviour, row, seed) cell, written to ``path``."""

    path: Path
    row: str
    deployed: Deployment
    trained_on: str | None


@dataclass(frozen=True)
class Fig9Job(Job):
    """One policy's unfinished cells in one (scene, behaviour): its rows (with and without
    the blend) and seeds play through one compiled program (the parameters and the blend
    flag are arguments: ``Deployment.load(blend_as_flag=True)``), a file per cell."""

    cells: tuple[Fig9Cell, ...]
    episodes: int

    @property
    def name(self) -> str:
        d = self.cells[0].deployed
        rows = ", ".join(dict.fromkeys(c.row for c in self.cells))
        seeds = dict.fromkeys(c.deployed.policy.seed for c in self.cells)
        seeds = seeds_label("", seeds).strip()
        return f"fig9: {rows}{' ' * bool(seeds)}{seeds} in {d.scene} on {d.behavior}"

    def run(self, progress=None) -> None:
        for cell in self.cells:
            cached(cell.path, lambda cell=cell: self._evaluate(cell))

    def _evaluate(self, cell: Fig9Cell) -> dict:
        d = cell.deployed
        policy, world = d.load(blend_as_flag=True)
        key = cell_key(d.scene, d.behavior)
        outcome = jax.device_get(
            run_episodes(policy, key, world, self.episodes, contact_tol_m=CONTACT_TOL_M)
        )
        s = summarize_outcome(outcome)
        return {
            "scene": d.scene,
            "behavior": d.behavior,
            "method": cell.row,
            "seed": d.policy.seed,
            "episodes": s["episodes"],
            "success_rate": s["success_rate"],
            "success_ci95": s["success_ci95"],
            "catch_time_s": s["catch_time_s"],
            "contacts_per_episode": float(np.mean(outcome["contacts"])),
            "speed_mps": d.speed_mps,
            "trained_on": cell.trained_on,
        }


def _cells(plan: Plan, rows) -> list[tuple]:
    return [
        (scene, behavior, r.name, seed)
        for scene in plan.fig9_scenes
        for behavior in plan.fig9_columns
        for r in rows
        for seed in (plan.seed_ids if r.learned else (None,))
    ]


def cell_jobs(plan: Plan, out: Path, rows=None) -> list[Job]:
    """The unfinished cells of Fig. 9 (default rows: ``rows_of(plan)``), a job per (scene,
    behaviour, policy): the rows of one policy, blended or not, share its program."""
    groups: dict[tuple, list[Fig9Cell]] = {}
    for sc, b, r, s in _cells(plan, rows_of(plan) if rows is None else rows):
        path = cell_path(out, sc, b, r, s)
        if not path.exists():
            row = row_named(r)
            trained_on = source_behavior(plan, b) if row.learned else None
            d = deployment(plan, out, sc, b, row, s)
            groups.setdefault((sc, b, row.policy), []).append(Fig9Cell(path, r, d, trained_on))
    return [Fig9Job(tuple(cells), plan.fig9_episodes) for cells in groups.values()]


def cell_rows(plan: Plan, out: Path, rows=None) -> list[dict]:
    """Every cell of Fig. 9, read back (one file each)."""
    cells = _cells(plan, rows_of(plan) if rows is None else rows)
    return [read_json(cell_path(out, *c)) for c in cells]


FILMED_ROW = "sp_rl+blend"
"""The row filmed in each scene."""


def _video_path(out: Path, scene: str) -> Path:
    return out / "videos" / f"fig9_{scene}.gif"


@dataclass(frozen=True)
class Fig9VideoJob(Job):
    """One GIF of a row (seed 0) in a scene."""

    out: Path
    deployed: Deployment
    row: str

    @property
    def name(self) -> str:
        return f"fig9 video in {self.deployed.scene}"

    def run(self, progress=None) -> None:
        d = self.deployed
        path = _video_path(self.out, d.scene)

        def compute():
            policy, world = d.load()
            extra = scene_extras(world, policy.cfg if d.blend else None)
            traj = record_episode(policy, jax.random.key(0), world, extra_fn=extra)
            write_video(render_frames(traj, world, every=5, size_px=400), path, fps=10)
            t = catch_time_s(traj)
            return {
                "scene": d.scene,
                "behavior": d.behavior,
                "method": self.row,
                "file": str(path.relative_to(self.out)),
                "caught": t is not None,
                "catch_time_s": t,
            }

        cached(path.with_suffix(".json"), compute)


def video_jobs(plan: Plan, out: Path, row: str = FILMED_ROW) -> list[Job]:
    """One GIF per scene of ``row`` (the first seed) on the first Fig. 9 behaviour, where
    missing."""
    r = row_named(row)
    return [
        Fig9VideoJob(out, deployment(plan, out, sc, plan.fig9_columns[0], r, plan.first_seed), row)
        for sc in plan.fig9_scenes
        if not _video_path(out, sc).with_suffix(".json").exists()
    ]


def videos(plan: Plan, out: Path) -> list[dict]:
    return [read_json(_video_path(out, sc).with_suffix(".json")) for sc in plan.fig9_scenes]


def summarize(rows: list[dict]) -> list[dict]:
    """Cells over seeds per (scene, behaviour, row): ``aggregate.summarize_cells``'s success
    and catch time (CIs over seeds with 2+ seeds, else Wilson over episodes) plus the mean
    contacts per episode with its CI over seeds."""
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
