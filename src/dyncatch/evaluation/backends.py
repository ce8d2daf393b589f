"""Where ``dyncatch eval`` plays its episodes: one entry per physics backend.

Every backend is an environment (the protocol of ``sim.api``) played by the one episode
loop, ``evaluation.episodes.run_episodes``; an entry says how to open it over the world of
the evaluation. The same key plays the same episodes on every backend, so their rows compare
episode for episode. Importing ``fullbody.catch`` imports no MuJoCo (an optional
dependency, the fullbody extra): ``fullbody.model`` imports it where a full body is built.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import os
import time
from collections.abc import Callable
from contextlib import AbstractContextManager

import jax
import numpy as np

from dyncatch.evaluation.episodes import run_episodes, run_episodes_at_speeds
from dyncatch.fullbody.catch import FullBodies
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.cli_types import live_name


@dataclasses.dataclass(frozen=True)
class EvalBackend:
    doc: str
    """One line for ``--help`` and the docs."""
    open: Callable[[Environment], AbstractContextManager[Environment]] = contextlib.nullcontext
    """``with open(env) as backend_env:`` the backend's environment over ``env.world``
    (the default: ``env`` itself, the JAX world)."""
    events: tuple[str, ...] = ()
    """Boolean ``info`` keys of the backend's step that each episode reports (whether one
    happened; ``run_episodes``' ``events``) and a row reports as rates (``fell`` ->
    ``fell_rate``)."""
    run_speeds: Callable | None = None
    """Optional: ``(policy, keys (S,), env_or_world, speeds (S,), num_episodes)`` -> the
    outcomes of ``run`` at each speed with its key, as (S, N) arrays, in one call
    (``evaluation.grid.evaluate_speeds`` loops over ``run`` without it)."""

    def run(
        self, policy, key: jax.Array, env: Environment | WorldCfg, num_episodes: int
    ) -> dict[str, jax.Array]:
        """``run_episodes`` on this backend: ``success``, ``catch_time_s``, ``return`` and
        the ``events``, (N,) each."""
        with self.open(as_env(env)) as backend_env:
            return run_episodes(policy, key, backend_env, num_episodes, events=self.events)


FULLBODY_EVENTS = ("fell", "arm_over_limit")
"""The full body's events (``fullbody.catch.MujocoCatchEnv``'s ``info``)."""


@contextlib.contextmanager
def _open_fullbody(env: Environment, fullbody: FullBodyCfg | None = None):
    with FullBodies(env, fullbody) as bodies:
        yield bodies.env


EVAL_BACKENDS: dict[str, EvalBackend] = {
    "jax": EvalBackend(
        "the reduced-order JAX world (sim.env)",
        run_speeds=run_episodes_at_speeds,
    ),
    "mujoco": EvalBackend(
        "the full-body Aliengo + Z1 in MuJoCo under the trot and the arm's IK "
        "(fullbody.catch; needs the fullbody extra)",
        _open_fullbody,
        FULLBODY_EVENTS,
    ),
}

EvalBackendName = live_name(lambda: tuple(EVAL_BACKENDS), "BACKEND")
"""A key of ``EVAL_BACKENDS``, read when the command line is parsed."""


def get_backend(name: str, fullbody: FullBodyCfg | None = None) -> EvalBackend:
    """The backend ``name``; ``fullbody`` (the ``mujoco`` backend's only) replaces the
    library's ``FullBodyCfg``."""
    if name not in EVAL_BACKENDS:
        raise ValueError(f"unknown backend {name!r}: choose from {', '.join(EVAL_BACKENDS)}")
    if fullbody is None:
        return EVAL_BACKENDS[name]
    if name != "mujoco":
        raise ValueError(
            f"--fullbody.* configures the full body, which backend {name!r} does not play; "
            "use --backend mujoco or leave the --fullbody.* flags out"
        )
    return dataclasses.replace(
        EVAL_BACKENDS[name], open=functools.partial(_open_fullbody, fullbody=fullbody)
    )


def run_fullbody_episodes(
    policy,
    key: jax.Array,
    env: Environment | WorldCfg,
    num_episodes: int,
    fullbody: FullBodyCfg | None = None,
    record: int | None = None,
    probe: Callable | None = None,
    workers: int | None = None,
) -> dict[str, np.ndarray]:
    """The ``mujoco`` entry's ``run`` with the measurements of the full-body benchmarks.

    Returns ``success``, ``catch_time_s``, ``return``, ``fell`` and ``arm_over_limit`` (N,),
    ``arm_speed_ratio`` and ``arm_torque_ratio`` (N,) (each episode's largest arm joint
    speed and torque over their limits, over every physics step), ``env_steps`` (the 50 Hz
    steps simulated on the full bodies, over all episodes), ``wall_s`` and ``cpu_s`` (CPU
    time of this process and its workers: the honest cost on a shared machine), and with
    ``record`` the recorded episode's ``qpos`` and ``target_m`` (``FullBodies``, which also
    takes ``fullbody``, ``probe`` and ``workers``).
    """
    t0, c0 = time.perf_counter(), _cpu_s()
    with FullBodies(env, fullbody, record, probe, workers) as bodies:
        out = run_episodes(policy, key, bodies.env, num_episodes, events=FULLBODY_EVENTS)
        out = {k: np.asarray(v) for k, v in out.items()}
        peaks = bodies.peaks()
        recorded = bodies.recorded()
    return {
        **out,
        "arm_speed_ratio": peaks[:, 0],
        "arm_torque_ratio": peaks[:, 1],
        "env_steps": bodies.env_steps,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": _cpu_s() - c0,
        **recorded,
    }


def _cpu_s() -> float:
    """CPU seconds of this process and of its children that have ended."""
    t = os.times()
    return t.user + t.system + t.children_user + t.children_system
