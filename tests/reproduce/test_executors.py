"""What a Ray worker inherits from the driver, and the serial executor's order (no Ray
started here: tests/cli/test_reproduce.py runs the real local Ray)."""

import os
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import jax
import pytest

from dyncatch.reproduce.executors import SerialExecutor, worker_env
from dyncatch.reproduce.jobs import Job


def test_a_worker_gets_the_drivers_jax_settings_and_on_a_local_ray_its_path(monkeypatch):
    monkeypatch.setenv("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=true")
    monkeypatch.setenv("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0.5")
    monkeypatch.setenv("HOME_ONLY_VARIABLE", "x")
    env = worker_env(local=True)
    # The cache the driver uses (tests/conftest.py turned it on), as an absolute path.
    cache = Path(env["JAX_COMPILATION_CACHE_DIR"])
    assert cache.is_absolute() and cache == Path(jax.config.jax_compilation_cache_dir).resolve()
    assert env["XLA_FLAGS"] == "--xla_cpu_multi_thread_eigen=true"
    assert env["JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS"] == "0.5"
    assert "HOME_ONLY_VARIABLE" not in env
    path = env["PYTHONPATH"].split(os.pathsep)
    # Among them the repository root pytest put there: the workers can import this test
    # module's jobs and the behaviour tests/cli/test_reproduce.py registers at run time.
    assert all(p in sys.path for p in path) and any(Path(p, "tests", "cli").is_dir() for p in path)
    # A cluster's nodes have their own paths.
    assert "PYTHONPATH" not in worker_env(local=False)


@dataclass(frozen=True)
class Call(Job):
    """A job that calls ``fn(*args)``: the executors run any ``Job``."""

    name: str
    fn: Callable
    args: tuple = ()

    def run(self, progress=None) -> None:
        self.fn(*self.args)


def _append(path, item):
    with open(path, "a") as f:
        f.write(item)


def test_the_serial_executor_runs_each_job_in_order_and_logs_it_with_the_time_left(tmp_path):
    logs = []
    out = tmp_path / "order"
    jobs = [Call(f"job {c}", _append, (out, c)) for c in "abcd"]
    ticks = iter([0.0, 0.0, 90.0, 300.0, 360.0])  # jobs of 90, 210 and 60 s
    SerialExecutor(logs.append, clock=lambda: next(ticks)).run(jobs)
    assert out.read_text() == "abcd"
    assert logs == [
        "job a",
        "job b (job 2 of 4; at this stage's mean so far, 90 s a job, about 4 min left in it)",
        "job c (job 3 of 4; at this stage's mean so far, 150 s a job, about 5 min left in it)",
        "job d (job 4 of 4; at this stage's mean so far, 120 s a job, about 2 min left in it)",
    ]


def _registered(path, name):
    from dyncatch.sim.behaviors import BEHAVIORS

    Path(path).write_text(" ".join(sorted(BEHAVIORS)) if name in BEHAVIORS else "missing")


def test_a_worker_runs_a_job_with_the_drivers_behaviours_then_restores_its_own(
    tmp_path, monkeypatch
):
    from dyncatch.reproduce.executors import _run_on_worker
    from dyncatch.sim.behaviors import BEHAVIORS
    from tests.cli.test_reproduce import STRAIGHT

    monkeypatch.chdir(tmp_path)  # restored after the test: the worker changes directory
    driver_cwd = tmp_path / "driver"
    driver_cwd.mkdir()
    before = dict(BEHAVIORS)
    out = tmp_path / "seen"
    job = Call("sees straight", _registered, (str(out), "straight"))
    _run_on_worker(job, {**BEHAVIORS, "straight": STRAIGHT}, str(driver_cwd))
    assert out.read_text() == " ".join(sorted([*before, "straight"]))
    assert BEHAVIORS == before and os.getcwd() == str(driver_cwd)


@jax.jit
def _doubled(x):
    return 2.0 * x


def _job_that_compiles(out: Path) -> None:
    out.write_text(str(float(_doubled(jax.numpy.float32(3.0)))))


def test_a_job_keeps_its_programs_far_from_the_mappings_limit(tmp_path, monkeypatch):
    import dyncatch.reproduce.jobs as jobs

    _doubled(jax.numpy.float32(0.0))
    monkeypatch.setattr(jobs, "_mappings", lambda: (100, 65530))
    Call("compile", _job_that_compiles, (tmp_path / "x",))()
    assert _doubled._cache_size() == 1
    jax.clear_caches()


def test_a_job_releases_the_programs_it_compiled_near_the_limit_even_when_it_fails(
    tmp_path, monkeypatch
):
    # A long reproduction compiles hundreds of programs; kept, their memory mappings reach
    # the kernel's limit (vm.max_map_count) and the process dies.
    import dyncatch.reproduce.jobs as jobs

    monkeypatch.setattr(jobs, "_mappings", lambda: (40_000, 65530))
    Call("compile", _job_that_compiles, (tmp_path / "x",))()
    assert (tmp_path / "x").read_text() == "6.0"
    assert _doubled._cache_size() == 0

    def fails():
        _doubled(jax.numpy.float32(1.0))
        raise RuntimeError("boom")

    with pytest.raises(RuntimeError, match="boom"):
        Call("fails", fails)()
    assert _doubled._cache_size() == 0
