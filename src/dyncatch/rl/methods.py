"""The compared methods (paper Section V-C): a registry of self-describing ``Method``s.

Every learned method runs the same PPO; they differ only in the velocity input appended to
the observation: nothing (``rl``), a learned predictor's v_hat_{t+1} (``p_rl`` vanilla,
``sp_rl`` self-aware), or the target's true velocity (``gt_rl``, the paper's GT-Pred).
``sp_fp`` is not trained: it is the ``gt_rl`` policy run with the self-aware predictor's
output in place of the ground truth. Velocities enter in the base frame, with a flag that
says whether the input is defined (a predictor needs two consecutive sightings).

Beyond the paper, ``st_rl`` reads the self-aware tracker (``docs/tracker.md``): its current
position and velocity estimate and their uncertainty (``TRACK_INPUTS``); ``st_fp`` is the
``gt_rl`` policy run with the tracker's velocity. The tracker carries a memory per
environment: ``MethodObs.init_carry`` / ``MethodObs.step`` are the seam every rollout calls
(the carry is ``()`` and ``step`` is ``__call__`` for every other method).

Beyond the paper too, ``rnn_rl`` is ``rl``'s input read by a GRU actor-critic trained by
recurrent PPO (``Method.memory``; ``rl.recurrent``, ``rl.recurrent_train``): the
reviewer's question whether memory does what the explicit predictor does; ``rnn_sp_rl``
is ``sp_rl``'s input under the same memory.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Literal

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.predictor.features import history_from_state
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.tracker.model import TRACKER, Tracker
from dyncatch.sim.api import obs_layout
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import world_to_body
from dyncatch.sim.state import EnvState, Obs
from dyncatch.utils.cli_types import live_name

GROUND_TRUTH = "ground_truth"
"""The velocity input of the oracle: the target's true velocity (the paper's GT-Pred)."""

GroundTruthReading = Literal["when_predicted", "always"]
"""How GT-Pred reads "ground truth prediction" (Section V-C):

- ``when_predicted`` (default): the target's true velocity where the predictor gives one
  (the last two camera frames both saw the target), else 0 with the flag at 0: the
  predictor's availability rule, in the predictor's frame (world velocity rotated into the
  current base frame). A policy trained on it has seen the flag at 0, so SP+FP, which
  swaps in the predictor, changes only the value, never the input's distribution.
- ``always``: the true velocity at every step, the flag always 1 (before issue 31). Its
  flag has no spread in training, so SP+FP's flag at 0 is an input never seen.

The value is the target's instantaneous velocity: its commanded heading at the speed cap,
which Section III-A names what the predictor approximates, "the object's desired velocity
in the next step". The predictor's label, the mean velocity over the next camera period
(``predictor.data``), needs positions up to the next frame, which depend on the policy's
own next actions when the target reacts to the robot: it cannot be computed inside the
step without running the policy ahead of itself.
"""

GROUND_TRUTH_READING: GroundTruthReading = "when_predicted"
"""The default reading: ``TrainRunCfg.ground_truth`` (``dyncatch train --ground-truth``) and
``Plan.ground_truth`` choose one per run, and the run's checkpoint records it."""

VELOCITY_INPUTS: tuple[tuple[str, int, str], ...] = (
    (
        "target_vel_body_mps",
        2,
        "the target's velocity (true, or the predictor's v_hat_{t+1}) in the current base "
        "frame (forward, left); 0 where not defined",
    ),
    (
        "target_vel_defined",
        1,
        "1 if the velocity is defined (the last two camera frames both saw the target; ground "
        "truth read 'always': always), else 0",
    ),
)
"""(name, size, meaning) of what a method with a velocity input appends to ``Obs.flat``."""

TRACK_INPUTS: tuple[tuple[str, int, str], ...] = (
    (
        "target_track_body_m",
        2,
        "the tracker's estimate of the target's current position relative to the robot, "
        "current base frame (forward, left); 0 before the first sighting",
    ),
    (
        "target_track_vel_body_mps",
        2,
        "the tracker's estimate of the target's current velocity, current base frame; 0 "
        "before the first sighting",
    ),
    (
        "target_track_pos_std_m",
        1,
        "RMS of the tracker's two position standard deviations; 0 before the first sighting",
    ),
    (
        "target_track_vel_std_mps",
        1,
        "RMS of the tracker's two velocity standard deviations; 0 before the first sighting",
    ),
    ("target_track_defined", 1, "1 once the camera has seen the target this episode, else 0"),
)
"""(name, size, meaning) of what ``st_rl`` appends to ``Obs.flat``."""

InputLayout = Literal["velocity", "track"]


@dataclass(frozen=True)
class Method:
    """A compared method: what training and evaluation ask about it. How a reproduction
    shows and judges it (label, colour, the paper's claims) is
    ``dyncatch.reproduce.presentation``.

    The registry's order is the order of tables, legends and training.
    """

    name: str
    doc: str
    velocity_input: str | None = None
    """None (no prediction input), ``GROUND_TRUTH`` or a predictor kind (``vanilla``, ...)."""
    trained_as: str | None = None
    """For evaluation-only methods: the method whose trained policy is reused."""
    input_layout: InputLayout = "velocity"
    """What is appended to the observation: ``VELOCITY_INPUTS`` (where ``velocity_input``
    is set) or, from the tracker, ``TRACK_INPUTS``."""
    memory: bool = False
    """The policy carries a GRU hidden state between control steps (``rl.recurrent``),
    trained by recurrent PPO (``rl.recurrent_train``); else a feed-forward MLP."""

    @property
    def trained(self) -> bool:
        """Trained by PPO (else evaluated with the policy of ``trained_as``)."""
        return self.trained_as is None

    @property
    def policy_source(self) -> str:
        """The method whose training run provides this method's policy."""
        return self.trained_as or self.name

    @property
    def oracle(self) -> bool:
        """Reads the target's true velocity (``gt_rl``): the upper reference of a benchmark,
        not a method a robot can run."""
        return self.velocity_input == GROUND_TRUTH and self.trained

    @property
    def predictor_kind(self) -> str | None:
        """The frozen predictor this method reads, if any."""
        return None if self.velocity_input in (None, GROUND_TRUTH) else self.velocity_input

    def obs_fn(
        self,
        predictor: Predictor | None = None,
        predictor_params=None,
        *,
        evaluation=False,
        ground_truth: GroundTruthReading = GROUND_TRUTH_READING,
    ) -> MethodObs:
        """The policy's input function; predictor methods need the matching predictor.

        With ``evaluation=True`` an evaluation-only method (``sp_fp``) gets its own input;
        in training it is refused (train its ``trained_as`` method instead).
        ``ground_truth`` is how the oracle's input reads the truth (a run records it:
        ``TrainRunCfg.ground_truth``); other methods ignore it.
        """
        if not self.trained and not evaluation:
            raise ValueError(
                f"method {self.name!r} is not trained: train {self.trained_as!r} and "
                f"evaluate it as {self.name!r}"
            )
        kind = self.predictor_kind
        if kind is None:
            return MethodObs(self.velocity_input, ground_truth=ground_truth)
        if predictor is None or predictor_params is None:
            raise ValueError(
                f"method {self.name!r} needs a trained {kind!r} predictor "
                f"checkpoint (dyncatch predictor train --kind {kind})"
            )
        if predictor.kind != kind:
            raise ValueError(
                f"method {self.name!r} needs a {kind!r} predictor, got a {predictor.kind!r} one"
            )
        return MethodObs(self.velocity_input, predictor, predictor_params, self.input_layout)


METHODS: dict[str, Method] = {
    m.name: m
    for m in (
        Method("rl", "monolithic RL, no prediction input"),
        Method("p_rl", "vanilla predictor + RL", "vanilla"),
        Method(
            "sp_fp",
            "gt_rl policy run with the self-aware predictor",
            "self_aware",
            trained_as="gt_rl",
        ),
        Method("sp_rl", "self-aware predictor + RL (the paper's method)", "self_aware"),
        Method("gt_rl", "RL with the ground-truth target velocity (GT-Pred)", GROUND_TRUTH),
        Method(
            "st_fp",
            "gt_rl policy run with the self-aware tracker's current velocity",
            TRACKER,
            trained_as="gt_rl",
        ),
        Method(
            "st_rl",
            "self-aware tracker (position, velocity, uncertainty at 50 Hz) + RL",
            TRACKER,
            input_layout="track",
        ),
        Method("rnn_rl", "monolithic RL with a GRU memory (recurrent PPO)", memory=True),
        Method(
            "rnn_sp_rl",
            "self-aware predictor + RL with a GRU memory (recurrent PPO)",
            "self_aware",
            memory=True,
        ),
    )
}

MethodName = live_name(lambda: tuple(METHODS), "METHOD")
"""A key of ``METHODS``, read when the command line is parsed."""


def get_method(name: str) -> Method:
    if name not in METHODS:
        raise ValueError(f"unknown method {name!r}: choose one of {', '.join(METHODS)}")
    return METHODS[name]


def selected(names: Iterable[str]) -> dict[str, Method]:
    """The registry's entries named in ``names``, in registry order."""
    chosen = set(names)
    return {name: m for name, m in METHODS.items() if name in chosen}


def trained_methods(names: Iterable[str]) -> tuple[str, ...]:
    """Names of the methods PPO trains among ``names``, in registry order."""
    return tuple(name for name, m in selected(names).items() if m.trained)


def predictor_kinds(names: Iterable[str]) -> tuple[str, ...]:
    """The frozen predictor kinds the methods ``names`` read, in registry order."""
    kinds = (m.predictor_kind for m in selected(names).values())
    return tuple(dict.fromkeys(k for k in kinds if k is not None))


def check_selection(names: Iterable[str]) -> None:
    """Raise ValueError naming an unknown method, or one whose policy source is missing."""
    names = tuple(names)
    for name in names:
        m = get_method(name)
        if m.policy_source not in names:
            raise ValueError(
                f"method {name!r} is evaluated with {m.policy_source!r}'s policy: "
                f"add {m.policy_source} to --methods"
            )


@struct.dataclass
class MethodObs:
    """``(state, obs) -> (D,)`` for one environment: the observation plus the method's input.

    A pytree: ``predictor_params`` are its leaves, the rest is static, so policies built on
    it can be jit arguments (one compilation per method, not per checkpoint). In training it
    is closed over, so the frozen predictor's weights are constants of the compiled update.

    Rollouts call it through ``init_carry(state)`` at each episode start and
    ``step(carry, state, obs) -> (carry, x)`` at every control step: a tracker method
    carries its ``Memory``, every other method the empty carry ``()``.
    """

    velocity_input: str | None = struct.field(pytree_node=False)
    predictor: Predictor | Tracker | None = struct.field(pytree_node=False, default=None)
    predictor_params: object = None
    input_layout: InputLayout = struct.field(pytree_node=False, default="velocity")
    ground_truth: GroundTruthReading = struct.field(pytree_node=False, default=GROUND_TRUTH_READING)
    """How the oracle's input reads the ground truth (``GroundTruthReading``)."""

    @property
    def stateful(self) -> bool:
        """Whether the input depends on a carry (the tracker's memory)."""
        return self.predictor is not None and self.predictor.stateful

    def init_carry(self, state: EnvState) -> Any:
        """The carry at an episode start, ``()`` for a stateless input."""
        del state
        return self.predictor.init_carry() if self.stateful else ()

    def step(self, carry: Any, state: EnvState, obs: Obs) -> tuple[Any, jax.Array]:
        """(carry after ``state``, the policy's input vector (D,)); call once per step."""
        if not self.stateful:
            return carry, self(state, obs)
        carry = self.predictor.ingest(carry, state)
        est = self.predictor.estimate(self.predictor_params, carry, state)
        if self.input_layout == "track":
            extra = [
                est.pos_body_m,
                est.vel_body_mps,
                est.pos_std_m[None],
                est.vel_std_mps[None],
                est.defined[None],
            ]
        else:
            extra = [est.vel_body_mps, est.defined[None]]
        return carry, jnp.concatenate([obs.flat, *extra])

    def velocity(self, state: EnvState) -> tuple[jax.Array, jax.Array]:
        """(world velocity (2,), defined flag ()) of a stateless input."""
        if self.stateful:
            raise ValueError("a tracker's velocity needs its carry: use MethodObs.step")
        ok = state.sensor.consecutive
        if self.velocity_input == GROUND_TRUTH:
            if self.ground_truth == "always":
                return state.target.vel_mps, jnp.ones(())
            return jnp.where(ok, state.target.vel_mps, 0.0), ok.astype(jnp.float32)
        history = history_from_state(state)
        v = self.predictor.predict(self.predictor_params, history)
        return jnp.where(ok, v, 0.0), ok.astype(jnp.float32)

    def layout(self, world: WorldCfg) -> tuple[tuple[str, int], ...]:
        """(name, size) of each part of the input vector in ``world`` (whose ray count sets
        the scan's width), in order (sizes sum to D)."""
        if self.velocity_input is None:
            extra = ()
        else:
            extra = TRACK_INPUTS if self.input_layout == "track" else VELOCITY_INPUTS
        return obs_layout(world) + tuple((name, size) for name, size, _ in extra)

    def __call__(self, state: EnvState, obs: Obs) -> jax.Array:
        """The policy's input vector, (D,), of a stateless input: ``obs.flat`` then the
        ``VELOCITY_INPUTS``."""
        if self.velocity_input is None:
            return obs.flat
        v_world, ok = self.velocity(state)
        v_body = world_to_body(v_world, state.robot.yaw_rad)
        return jnp.concatenate([obs.flat, v_body, ok[None]])


def method_obs(
    name: str,
    predictor: Predictor | None = None,
    predictor_params=None,
    *,
    evaluation=False,
    ground_truth: GroundTruthReading = GROUND_TRUTH_READING,
) -> MethodObs:
    """``get_method(name).obs_fn(...)``: the input function of a method by name."""
    return get_method(name).obs_fn(
        predictor, predictor_params, evaluation=evaluation, ground_truth=ground_truth
    )
