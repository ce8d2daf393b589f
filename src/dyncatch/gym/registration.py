"""Gymnasium ids of the catch world: ``dyncatch/Catch-v0`` and ``dyncatch/CatchVector-v0``.

Entry points are strings, so registering imports neither JAX nor the simulator. No
``max_episode_steps``: the environment truncates itself at ``cfg.episode.max_steps``.
"""

from __future__ import annotations

import gymnasium

CATCH_ID = "dyncatch/Catch-v0"
CATCH_VECTOR_ID = "dyncatch/CatchVector-v0"


def register_envs() -> None:
    """Register both ids with gymnasium; ids already registered are left as they are."""
    if CATCH_ID not in gymnasium.registry:
        gymnasium.register(id=CATCH_ID, entry_point="dyncatch.gym.catch_env:CatchEnv")
    if CATCH_VECTOR_ID not in gymnasium.registry:
        gymnasium.register(
            id=CATCH_VECTOR_ID, vector_entry_point="dyncatch.gym.vector_env:CatchVectorEnv"
        )
