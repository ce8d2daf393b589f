"""The compared methods (paper Section V-C) as a registry of what the policy sees.

Every learned method runs the same PPO; they differ only in the velocity input appended to
the observation: nothing (``rl``), a learned predictor's v_hat_{t+1} (``p_rl`` vanilla,
``sp_rl`` self-aware), or the target's true velocity (``gt_rl``, the paper's GT-Pred).
``sp_fp`` is not trained: it is the ``gt_rl`` policy run with the self-aware predictor's
output in place of the ground truth. Velocities enter in the base frame, with a flag that
says whether the input is defined (a predictor needs two consecutive sightings).
"""

from __future__ import annotations

from dataclasses import dataclass

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.predictor.features import history_from_state
from dyncatch.predictor.model import Predictor
from dyncatch.sim.geometry import world_to_body
from dyncatch.sim.state import EnvState, Obs


@dataclass(frozen=True)
class Method:
    doc: str
    velocity_input: str | None
    """None (no prediction input), "ground_truth" or a predictor kind ("vanilla", ...)."""
    trained_as: str | None = None
    """For evaluation-only methods: the method whose trained policy is reused."""


METHODS: dict[str, Method] = {
    "rl": Method("monolithic RL, no prediction input", None),
    "p_rl": Method("vanilla predictor + RL", "vanilla"),
    "sp_rl": Method("self-aware predictor + RL (the paper's method)", "self_aware"),
    "gt_rl": Method("RL with the ground-truth target velocity (GT-Pred)", "ground_truth"),
    "sp_fp": Method("gt_rl policy run with the self-aware predictor", "self_aware", "gt_rl"),
}


def get_method(name: str) -> Method:
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}: choose one of {', '.join(METHODS)}")
    return METHODS[name]


@struct.dataclass
class MethodObs:
    """``(state, obs) -> (D,)`` for one environment: the observation plus the velocity input.

    A pytree: ``predictor_params`` are its leaves, the rest is static, so policies built on
    it can be jit arguments (one compilation per method, not per checkpoint). In training it
    is closed over, so the frozen predictor's weights are constants of the compiled update.
    """

    velocity_input: str | None = struct.field(pytree_node=False)
    predictor: Predictor | None = struct.field(pytree_node=False, default=None)
    predictor_params: object = None

    def velocity(self, state: EnvState) -> tuple[jax.Array, jax.Array]:
        """(world velocity (2,), defined flag ())."""
        if self.velocity_input == "ground_truth":
            return state.target.vel_mps, jnp.ones(())
        history = history_from_state(state)
        v = self.predictor.predict(self.predictor_params, history)
        ok = state.sensor.consecutive
        return jnp.where(ok, v, 0.0), ok.astype(jnp.float32)

    def __call__(self, state: EnvState, obs: Obs) -> jax.Array:
        if self.velocity_input is None:
            return obs.flat
        v_world, ok = self.velocity(state)
        v_body = world_to_body(v_world, state.robot.yaw_rad)
        return jnp.concatenate([obs.flat, v_body, ok[None]])


def method_obs(
    name: str, predictor: Predictor | None = None, predictor_params=None, *, evaluation=False
) -> MethodObs:
    """The input function of a method; predictor methods need the matching predictor.

    With ``evaluation=True`` an evaluation-only method (``sp_fp``) gets its own input; in
    training it is refused (train its ``trained_as`` method instead).
    """
    m = get_method(name)
    if m.trained_as is not None and not evaluation:
        raise ValueError(
            f"method {name!r} is not trained: train {m.trained_as!r} and evaluate it as {name!r}"
        )
    if m.velocity_input in (None, "ground_truth"):
        return MethodObs(m.velocity_input)
    if predictor is None or predictor_params is None:
        raise ValueError(
            f"method {name!r} needs a trained {m.velocity_input!r} predictor "
            "checkpoint (dyncatch predictor train --kind "
            f"{m.velocity_input})"
        )
    if predictor.cfg.kind != m.velocity_input:
        raise ValueError(
            f"method {name!r} needs a {m.velocity_input!r} predictor, got a "
            f"{predictor.cfg.kind!r} one"
        )
    return MethodObs(m.velocity_input, predictor, predictor_params)
