"""Who runs a stage's independent jobs (``dyncatch.reproduce.jobs.Job``): this process,
one after another, or Ray tasks on a local Ray or a cluster.

Every job writes its outputs under the results folder and skips what exists, and a stage
reads its results back from those files, so the executor changes who computes, never what:
the cache, the resume rules and the report are the same. A Ray job whose worker dies is
retried (``max_retries``); a job that raises is not (the error is a bug or a bad config,
and a retry would only repeat it), but the other jobs of the stage still finish and keep
their outputs before the error is raised, so a re-run skips them.
"""

from __future__ import annotations

import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from dyncatch.reproduce.jobs import Job
from dyncatch.reproduce.plan import Plan
from dyncatch.sim.behaviors import BEHAVIORS, registered_behavior
from dyncatch.utils.jax_setup import compilation_cache_dir, setup_jax

RAY_INSTALL = "pip install 'dyncatch[ray]' (or pip install 'ray[default]')"

_FORWARDED_ENV = ("MPLBACKEND", "WANDB_MODE")
"""Environment variables a Ray worker gets from the driver (besides every ``JAX_*`` and
``XLA_*`` one: the compilation cache, XLA_FLAGS, XLA_PYTHON_CLIENT_MEM_FRACTION, ...)."""


_LOCAL_OBJECT_STORE_BYTES = 256 * 2**20


def remaining_note(done: int, total: int, spent_s: float) -> str:
    """What the log adds to job ``done + 1`` of ``total``: the stage's time left at its mean
    measured job so far (the printed estimate is calibrated on one machine; this one is
    measured on the machine that runs). Empty for the first job."""
    if done < 1:
        return ""
    mean_s = spent_s / done
    left_min = mean_s * (total - done) / 60
    return (
        f" (job {done + 1} of {total}; at this stage's mean so far, {mean_s:.0f} s a job, "
        f"about {left_min:.0f} min left in it)"
    )


@dataclass
class SerialExecutor:
    """Each job in this process, in order, with the caller's progress bars. From the second
    job on, the log says how long the stage's rest takes at its mean measured job
    (``remaining_note``)."""

    log: Callable[[str], None] = print
    progress: object | None = None
    clock: Callable[[], float] = time.perf_counter
    """Seconds, for the measured mean (a test's fake clock)."""

    def run(self, jobs: Sequence[Job]) -> None:
        start = self.clock()
        for i, job in enumerate(jobs):
            self.log(job.name + remaining_note(i, len(jobs), self.clock() - start))
            job(self.progress)

    def close(self) -> None:
        pass


def worker_env(local: bool) -> dict[str, str]:
    """What a Ray worker's environment needs from the driver's: the JAX settings (the
    persistent compilation cache, made absolute, so workers reuse the driver's compiled
    programs) and the XLA flags; on a local Ray also ``sys.path``, so code registered at
    run time (a behaviour defined in a script or test) can be unpickled by the workers."""
    import jax

    env = {
        k: v for k, v in os.environ.items() if k.startswith(("JAX_", "XLA_")) or k in _FORWARDED_ENV
    }
    cache = jax.config.jax_compilation_cache_dir or compilation_cache_dir()
    env["JAX_COMPILATION_CACHE_DIR"] = str(Path(cache).resolve())
    if local:
        env["PYTHONPATH"] = os.pathsep.join(p for p in sys.path if p and os.path.isdir(p))
    return env


def _run_on_worker(job: Job, behaviors: dict, cwd: str) -> None:
    """A Ray task: the driver's working directory (where it exists: a relative --out means
    the same folder; on a cluster use a shared filesystem), JAX settings and behaviour
    registry, then the job."""
    from contextlib import ExitStack

    if os.path.isdir(cwd):
        os.chdir(cwd)
    setup_jax()
    with ExitStack() as stack:
        for name, behavior in behaviors.items():
            if BEHAVIORS.get(name) != behavior:  # equal: a built-in, sent by reference
                stack.enter_context(registered_behavior(name, behavior, replace=True))
        job()


@dataclass
class RayExecutor:
    """Each job as a Ray task (1 CPU, ``gpus_per_job`` GPUs); a local Ray when ``address``
    is None, else the cluster at ``address``. Jobs of one stage run concurrently; the
    stages stay in order (each stage reads the files the one before wrote)."""

    address: str | None = None
    workers: int | None = None
    """Worker processes of a local Ray (default one per core); unused with ``address``."""
    gpus_per_job: float = 0.0
    log: Callable[[str], None] = print
    max_retries: int = 3
    """Re-runs of a job whose worker died (a killed process, a lost node)."""
    worker_niceness: int = 0
    """The ``nice`` value of a local Ray's worker processes (unused with ``address``). Ray's
    own default, 15, lets any other busy process on the machine starve the jobs, which are
    the run's whole work: beside one busy process on the 2-core Xeon, a local Ray's two
    workers got a few per cent of a core and a 16 s test took 202 s (2026-12-05,
    docs/performance.md, "The test suite")."""
    _started: bool = field(default=False, init=False)

    def __post_init__(self) -> None:
        import ray

        if not ray.is_initialized():
            local = self.address is None
            try:
                self._init(ray, local)
            except ConnectionError as err:
                raise ValueError(
                    f"--ray-address {self.address}: no Ray cluster to join ({err}); start one "
                    "with `ray start --head`, or leave --ray-address unset for a local Ray"
                ) from None
            self._started = True
        self._remote = ray.remote(_run_on_worker).options(
            num_cpus=1, num_gpus=self.gpus_per_job, max_retries=self.max_retries
        )

    def _init(self, ray, local: bool) -> None:
        ray.init(
            address=self.address,
            num_cpus=self.workers if local else None,
            runtime_env={"env_vars": worker_env(local)},
            # Jobs pass configs and paths, never arrays: a small local object store.
            object_store_memory=_LOCAL_OBJECT_STORE_BYTES if local else None,
            include_dashboard=False,
            log_to_driver=False,
            logging_level="ERROR",
            # Ray's system config is set only by the process that starts the cluster.
            _system_config={"worker_niceness": self.worker_niceness} if local else None,
        )

    def run(self, jobs: Sequence[Job]) -> None:
        import ray

        behaviors = dict(BEHAVIORS)
        cwd = os.getcwd()
        pending = {self._remote.remote(job, behaviors, cwd): job for job in jobs}
        errors = []
        while pending:
            done, _ = ray.wait(list(pending), num_returns=1)
            job = pending.pop(done[0])
            try:
                ray.get(done[0])
                self.log(f"done: {job.name}")
            except Exception as err:  # noqa: BLE001 - reported below, after the others
                errors.append(f"{job.name}: {err}")
                self.log(f"failed: {job.name}")
        if errors:
            raise RuntimeError(
                f"{len(errors)} job(s) failed (finished ones are kept; re-run to retry): "
                + "; ".join(errors)
            )

    def close(self) -> None:
        import ray

        if self._started:
            ray.shutdown()


def validate_executor(plan: Plan) -> None:
    """Raise ValueError naming the flag when the executor flags cannot work."""
    if plan.executor not in EXECUTORS:
        raise ValueError(f"--executor {plan.executor}: choose from {', '.join(EXECUTORS)}")
    if plan.executor != "ray" and (plan.ray_address is not None or plan.ray_gpus_per_job):
        raise ValueError("--ray-address and --ray-gpus-per-job need --executor ray")
    if plan.ray_workers is not None and (plan.executor != "ray" or plan.ray_address):
        raise ValueError(
            "--ray-workers sizes a local Ray: it needs --executor ray and no --ray-address"
        )
    if plan.ray_workers is not None and plan.ray_workers < 1:
        raise ValueError(f"--ray-workers must be >= 1, got {plan.ray_workers}")
    if plan.ray_gpus_per_job < 0:
        raise ValueError(f"--ray-gpus-per-job must be >= 0, got {plan.ray_gpus_per_job}")
    if plan.executor == "ray":
        try:
            import ray  # noqa: F401
        except ImportError:
            raise ValueError(f"--executor ray needs Ray: {RAY_INSTALL}") from None


EXECUTORS: dict[str, Callable[..., SerialExecutor | RayExecutor]] = {
    "serial": lambda plan, log, progress: SerialExecutor(log, progress),
    "ray": lambda plan, log, progress: RayExecutor(
        plan.ray_address, plan.ray_workers, plan.ray_gpus_per_job, log
    ),
}
"""The executors of ``dyncatch reproduce --executor``: (plan, log, progress) -> executor."""


def make_executor(plan: Plan, log: Callable[[str], None] = print, progress=None):
    """The executor ``plan.executor`` names (``close()`` it when done)."""
    return EXECUTORS[plan.executor](plan, log, progress)
