"""The jobs of a reproduction's stages: small typed specs, each holding only what it needs.

A job is a frozen dataclass of plain values and configs (paths, names, a world, a training
run's config), never the whole ``Plan``, so a Ray task carries a few kilobytes and a job
says by its fields what it reads. ``job(progress)`` writes its outputs under the results
folder, atomically or behind a completion marker, and returns nothing; running it again
after it finished, or after it died, is safe. The stages (``stages.py``) build the jobs of
what is unfinished and read the results back from the files.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import jax

from dyncatch.evaluation.grid import evaluate_speeds
from dyncatch.policies.registry import BASELINES
from dyncatch.predictor.checkpoint import PREDICTOR_FILE
from dyncatch.predictor.config import CollectCfg, PredictorCfg, TrainCfg
from dyncatch.predictor.pipeline import PredictorTrainCfg, train_predictor
from dyncatch.predictor.table import TableCfg, run_table, write
from dyncatch.reproduce.layout import cached, predictor_path, run_dir, source_behavior, write_json
from dyncatch.reproduce.paper import PAPER_TABLE_II_ERRORS
from dyncatch.reproduce.plan import Plan
from dyncatch.rl.methods import METHODS
from dyncatch.rl.policy import load_run
from dyncatch.rl.runner import CHECKPOINT, TrainRunCfg, TrainRunner
from dyncatch.rl.seeds import SeedGroupRunner
from dyncatch.sim.config import WorldCfg
from dyncatch.viz.render import render_frames, write_video
from dyncatch.viz.trajectory import catch_time_s, record_episode

MAPPINGS_RELEASE_FRACTION = 0.5
"""A job releases the compiled programs once the process holds this fraction of the
kernel's limit on memory mappings (``release_compiled``)."""


def _mappings() -> tuple[int, int] | None:
    """(memory mappings this process holds, the kernel's limit), where Linux tells."""
    try:
        with open("/proc/self/maps") as f:
            held = sum(1 for _ in f)
        with open("/proc/sys/vm/max_map_count") as f:
            return held, int(f.read())
    except (OSError, ValueError):
        return None


def release_compiled() -> None:
    """Drop JAX's in-memory compiled programs (the persistent cache on disk keeps them)
    once the process nears the kernel's limit on memory mappings (or always, where the
    count cannot be read).

    Each XLA:CPU executable holds memory mappings of its own, and a process that compiles
    job after job keeps every one: a full reproduction (about 200 Fig. 9 cells, each its
    own program) reached ``vm.max_map_count`` (65530) and died with "LLVM compilation
    error: Cannot allocate memory" after 2 h. After a release the count falls to a few
    thousand, and a program needed again is loaded back from the persistent cache
    (measured: Fig. 9 cells took the same 11 s each). Releasing after every job instead
    made the test suite's tiny reproduction recompile what its jobs share: 168 s against
    132 s."""
    counts = _mappings()
    if counts is None or counts[0] >= MAPPINGS_RELEASE_FRACTION * counts[1]:
        jax.clear_caches()


class Job:
    """One independent piece of a stage. A subclass is a frozen dataclass with a ``name``
    (for the log) and ``run(progress)``; calling the job runs it, then releases compiled
    programs near the mappings limit, even when it fails."""

    name: str

    def run(self, progress=None) -> None:
        raise NotImplementedError

    def __call__(self, progress=None) -> None:
        try:
            self.run(progress)
        finally:
            release_compiled()


@dataclass(frozen=True)
class PolicySpec:
    """Where an evaluated policy comes from: a method's training run (``run``, with the
    frozen predictor it reads) or, when ``run`` is None, a baseline built for ``world``."""

    name: str
    """A method (evaluated as this method) or a baseline."""
    seed: int | None = None
    run: Path | None = None
    predictor: Path | None = None
    world: WorldCfg | None = None
    """A baseline's world (a trained policy brings its own)."""

    @property
    def learned(self) -> bool:
        return self.run is not None

    def load(self):
        """(policy, the world it was trained in, or the baseline's)."""
        if self.run is None:
            return BASELINES[self.name](self.world), self.world
        run = load_run(self.run, self.name, self.predictor)
        return run.policy, run.world

    def label(self, where: str) -> str:
        return f"{self.name}{'' if self.seed is None else f' seed {self.seed}'} {where}"


def policy_spec(
    plan: Plan, out: Path, behavior: str, name: str, seed: int | None, table: str | None = None
) -> PolicySpec:
    """The policy evaluated as ``name`` (seed ``seed``; None: a baseline) on ``behavior`` in
    ``table``: the run of its policy source trained on ``source_behavior``'s behaviour
    (``behavior`` itself, or ``transfer_from`` in the transfer table), with that
    behaviour's predictor."""
    if seed is None:
        return PolicySpec(name, world=plan.world)
    src = source_behavior(plan, behavior, table)
    run = run_dir(out, src, METHODS[name].policy_source, seed)
    return PolicySpec(name, seed, run, predictor_path(out, src, name))


def predictor_done(d: Path) -> bool:
    return (d / "metrics.json").exists() and (d / PREDICTOR_FILE).exists()


@dataclass(frozen=True)
class PredictorJob(Job):
    """Train one frozen predictor into ``cfg.out``."""

    cfg: PredictorTrainCfg

    @property
    def name(self) -> str:
        return f"predictor {self.cfg.kind} on {self.cfg.world.target.behavior}"

    def run(self, progress=None) -> None:
        if not predictor_done(self.cfg.out):
            train_predictor(self.cfg, progress)


@dataclass(frozen=True)
class TableIIJob(Job):
    """Table II into ``folder`` (``table_ii.json`` last), the paper's errors beside ours."""

    table: TableCfg
    train: TrainCfg
    world: WorldCfg
    folder: Path
    name: str = "Table II"

    def run(self, progress=None) -> None:
        def compute():
            rows = run_table(
                self.table,
                PredictorCfg(),
                self.train,
                CollectCfg(),
                self.world,
                paper_errors=PAPER_TABLE_II_ERRORS,
            )
            write(rows, self.folder)
            return rows

        cached(self.folder / "table_ii.json", compute)


def run_done(cfg: TrainRunCfg) -> bool:
    return (cfg.out / "done.json").exists()


@dataclass(frozen=True)
class TrainJob(Job):
    """Train the unfinished runs of one (method, behaviour): one vmap-ped group when more
    than one is left, else one ``TrainRunner``. Each resumes its checkpoint if one exists
    (read when the job starts, so a retried job continues where the dead one saved)."""

    runs: tuple[TrainRunCfg, ...]

    @property
    def name(self) -> str:
        first, seeds = self.runs[0], [c.seed for c in self.runs]
        plural = "s" * (len(seeds) > 1)
        return f"train {first.method} on {first.world.target.behavior}, seed{plural} " + ", ".join(
            map(str, seeds)
        )

    def run(self, progress=None) -> None:
        cfgs = [
            dataclasses.replace(c, resume=(c.out / CHECKPOINT).exists())
            for c in self.runs
            if not run_done(c)
        ]
        if len(cfgs) > 1:
            finals = SeedGroupRunner(cfgs).learn(progress)
        else:
            finals = [TrainRunner(c).learn(progress) for c in cfgs]
        for cfg, final in zip(cfgs, finals, strict=True):
            write_json(cfg.out / "done.json", final)


@dataclass(frozen=True)
class EvalCell:
    """One policy's row of a grid (its speeds on one behaviour), written to ``path``."""

    path: Path
    policy: PolicySpec


def seeds_label(name: str, seeds) -> str:
    """``sp_rl seeds 0, 2``, ``sp_rl seed 1`` or ``pursuit`` (no seed)."""
    seeds = [s for s in seeds if s is not None]
    if not seeds:
        return name
    return f"{name} seed{'s' * (len(seeds) > 1)} " + ", ".join(map(str, seeds))


@dataclass(frozen=True)
class EvalJob(Job):
    """One method's unfinished cells of a grid on one behaviour, a file per seed: its seeds
    play through one compiled program (a learned policy's parameters and the speeds are
    arguments, ``evaluation.episodes.run_episodes_at_speeds``), whatever process runs the
    job."""

    table: str
    behavior: str
    cells: tuple[EvalCell, ...]
    speeds_mps: tuple[float, ...]
    episodes: int

    @property
    def name(self) -> str:
        label = seeds_label(self.cells[0].policy.name, [c.policy.seed for c in self.cells])
        return f"{self.table}: {label} on {self.behavior}"

    def run(self, progress=None) -> None:
        for cell in self.cells:

            def compute(spec=cell.policy):
                policy, world = spec.load()
                return evaluate_speeds(
                    policy, world, self.behavior, self.speeds_mps, self.episodes, 0, spec.name
                )

            cached(cell.path, compute)


@dataclass(frozen=True)
class VideoJob(Job):
    """A GIF of a method's policy (the plan's first seed) on a behaviour, with its predicted
    velocity."""

    out: Path
    behavior: str
    trained_on: str
    speed_mps: float
    policy: PolicySpec

    @property
    def path(self) -> Path:
        return self.out / "videos" / f"{self.policy.name}_{self.behavior}.gif"

    @property
    def name(self) -> str:
        return f"video {self.policy.name} on {self.behavior}"

    def run(self, progress=None) -> None:
        def compute():
            policy, trained_world = self.policy.load()
            cfg = trained_world.with_behavior(self.behavior).with_speed(self.speed_mps)

            def extra(state, obs):
                return {"pred_vel_mps": policy.obs_fn.velocity(state)[0]}

            arrow = METHODS[self.policy.name].velocity_input is not None
            traj = record_episode(policy, jax.random.key(0), cfg, extra_fn=extra if arrow else None)
            write_video(render_frames(traj, cfg, every=3, size_px=400), self.path, fps=17)
            t = catch_time_s(traj)
            return {
                "method": self.policy.name,
                "behavior": self.behavior,
                "trained_on": self.trained_on,
                "speed_mps": self.speed_mps,
                "file": str(self.path.relative_to(self.out)),
                "caught": t is not None,
                "catch_time_s": t,
            }

        cached(self.path.with_suffix(".json"), compute)
