"""What a target behaviour is, the body config every behaviour shares, and shared helpers."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, Any

import jax
import jax.numpy as jnp
import numpy as np
import tyro
from flax import struct

from dyncatch.sim.fields import static
from dyncatch.sim.state import RobotState, TargetState
from dyncatch.utils.cli_types import live_name

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg


BEHAVIORS: dict[str, Behavior] = {}
"""Target behaviours by name, filled in ``dyncatch.sim.behaviors`` (import it from there)."""

BehaviorName = live_name(lambda: tuple(BEHAVIORS), "BEHAVIOR")
"""A key of ``BEHAVIORS``, read when the command line is parsed."""


@struct.dataclass
class TargetBodyCfg:
    """The planar target body, whatever its behaviour."""

    behavior: Annotated[BehaviorName, tyro.conf.arg(aliases=("--behavior",))] = static("reactive")
    """Behaviour, a key of ``dyncatch.sim.behaviors.BEHAVIORS`` (the library's one default);
    ``--behavior`` on every command."""
    speed_min_mps: float = 0.0
    """Lower end of the per-episode speed cap (paper V-B: caps drawn within 1.8 m/s in
    training; the ``narrow_speeds`` reading restores the first slice's 0.8)."""
    speed_max_mps: float = 1.8
    """Upper end of the per-episode speed cap."""
    max_turn_rate_rps: float = 10.0
    """Largest heading rate of the target (a quick animal turns about 2 turns per second)."""
    radius_m: float = 0.10
    """Body radius, kept off walls."""
    height_m: float = 0.15
    """Height of the target centre above the ground."""


@struct.dataclass
class NoState:
    """The state of a behaviour that remembers nothing between steps (no leaves)."""


Check = tuple[bool, str, str]
"""(ok, dotted field name, what is wrong and what to do), as ``sim.validate`` reports it."""

DesiredHeadingFn = Callable[[TargetState, RobotState, "WorldCfg", jax.Array], tuple[Any, Any]]
"""(target, robot, world_cfg, key) -> (desired heading (), new behaviour state pytree)."""

InitStateFn = Callable[[jax.Array, "WorldCfg"], tuple[jax.Array, jax.Array, Any]]
"""(key, world_cfg) -> (xy (2,), heading (), behaviour state pytree)."""

ValidateFn = Callable[["WorldCfg"], list[Check]]
"""world_cfg -> the behaviour's own checks; ``sim.validate`` raises on the first failed one."""

SpeedShareFn = Callable[[Any, "WorldCfg"], jax.Array]
"""(behaviour state pytree after ``desired_heading``, world_cfg) -> the share of the
episode's speed cap the body runs at this step, () in [0, 1] (clipped by ``sim.target.steer``)."""


def uniform_init(key: jax.Array, cfg: WorldCfg) -> tuple[jax.Array, jax.Array, NoState]:
    """Anywhere at least 1 m from the walls, any heading, no behaviour state."""
    k_xy, k_h = jax.random.split(key)
    margin = 1.0
    xy = jax.random.uniform(k_xy, (2,), minval=margin, maxval=cfg.arena.size_m - margin)
    heading = jax.random.uniform(k_h, (), minval=-jnp.pi, maxval=jnp.pi)
    return xy, heading, NoState()


def no_checks(cfg: WorldCfg) -> list[Check]:
    """A behaviour without parameters of its own has nothing to check."""
    del cfg
    return []


@dataclass(frozen=True)
class Behavior:
    """A target behaviour: its parameters, its state, one pure policy and how it meets walls.

    ``desired_heading`` is eq. 1's pi_obj: it sees the target (its ``behavior_state`` is this
    behaviour's state pytree), the robot (reactive targets react to it), the world config and
    a key. The body then turns toward the heading under the turn-rate limit and moves at the
    episode's speed cap, or at the share of it that ``speed_share`` reads from the new state.
    """

    desired_heading: DesiredHeadingFn
    cfg_cls: type | None = None
    """A ``struct.dataclass`` of this behaviour's own parameters (every field with a default),
    read from ``world_cfg.target``; ``None`` or ``TargetBodyCfg``: no parameters of its own."""
    init_state: InitStateFn = uniform_init
    """Where an episode starts and the behaviour's first state."""
    validate: ValidateFn = no_checks
    """Checks of the behaviour's own parameters."""
    speed_share: SpeedShareFn | None = None
    """The share of the speed cap to run at, read from the state ``desired_heading`` returned
    (a learned evader's speed action); None: always the cap (every scripted target, eq. 11-12's
    constant speed)."""
    reflects_off_walls: bool = False
    """True: hitting a wall mirrors the heading (a bounce); False: the body slides along it."""
    scripted: bool = True
    """False: the behaviour needs more than its config to run (a trained network's file,
    ``learned``; an outer controller, ``commanded``), so listings of "every behaviour" (the
    demo, the predictor table's default, the Gymnasium tests) take ``scripted_behaviors``."""
    doc: str = ""
    """One line for tables and ``--help``."""

    @property
    def param_names(self) -> tuple[str, ...]:
        """Names of this behaviour's own fields of ``TargetCfg`` (the body's excluded)."""
        if self.cfg_cls is None:
            return ()
        body = {f.name for f in dataclasses.fields(TargetBodyCfg)}
        return tuple(f.name for f in dataclasses.fields(self.cfg_cls) if f.name not in body)

    def params(self, target: Any) -> dict[str, Any]:
        """This behaviour's own fields of ``target`` (a ``TargetCfg``) as JSON values (tuples
        as lists), by name: what a record of data drawn from it must name besides the
        behaviour, e.g. ``learned``'s evader file (two evaders share one behaviour name)."""
        return {name: _json_value(getattr(target, name)) for name in self.param_names}


def _json_value(v: Any) -> Any:
    """A config value as JSON: tuples as lists, arrays (a non-static field of a world that
    went through jit or the CLI) as numbers."""
    if isinstance(v, tuple):
        return [_json_value(x) for x in v]
    return np.asarray(v).tolist() if hasattr(v, "shape") else v
