"""Where ``dyncatch eval`` plays its episodes: one entry per physics backend.

Each entry's ``run`` has ``evaluation.episodes.run_episodes``' signature and returns at
least its ``success``, ``catch_time_s`` and ``return``; the same key plays the same
episodes on every backend, so their rows compare episode for episode.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

from dyncatch.evaluation.episodes import run_episodes, run_episodes_at_speeds
from dyncatch.utils.cli_types import live_name


@dataclasses.dataclass(frozen=True)
class EvalBackend:
    run: Callable
    """``(policy, key, env_or_world, num_episodes) -> {"success", "catch_time_s", ...}``."""
    doc: str
    """One line for ``--help`` and the docs."""
    extra_keys: tuple[str, ...] = ()
    """Outcome keys beyond success, catch time and return that a row reports as rates
    (``fell`` -> ``fell_rate``)."""
    run_speeds: Callable | None = None
    """Optional: ``(policy, keys (S,), env_or_world, speeds (S,), num_episodes)`` -> the
    outcomes of ``run`` at each speed with its key, as (S, N) arrays, in one call
    (``evaluation.grid.evaluate_speeds`` loops over ``run`` without it)."""


def _run_mujoco(policy, key, env, num_episodes):
    # Imported here: MuJoCo is an optional dependency (the fullbody extra).
    from dyncatch.fullbody.catch import run_fullbody_episodes

    return run_fullbody_episodes(policy, key, env, num_episodes)


EVAL_BACKENDS: dict[str, EvalBackend] = {
    "jax": EvalBackend(
        run_episodes,
        "the reduced-order JAX world (sim.env)",
        run_speeds=run_episodes_at_speeds,
    ),
    "mujoco": EvalBackend(
        _run_mujoco,
        "the full-body Aliengo + Z1 in MuJoCo under the trot and the arm's IK "
        "(fullbody.catch; needs the fullbody extra)",
        ("fell",),
    ),
}

EvalBackendName = live_name(lambda: tuple(EVAL_BACKENDS), "BACKEND")
"""A key of ``EVAL_BACKENDS``, read when the command line is parsed."""


def get_backend(name: str) -> EvalBackend:
    if name not in EVAL_BACKENDS:
        raise ValueError(f"unknown backend {name!r}: choose from {', '.join(EVAL_BACKENDS)}")
    return EVAL_BACKENDS[name]
