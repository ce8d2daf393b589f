"""A target that is a mixture: each episode draws one member of a league (scripted
behaviours and frozen learned evaders) and plays it to the end.

A pursuer trained against ``league`` meets every member at its weight, so it does not
overfit the last evader of a self-play round (``dyncatch.rl.selfplay``). The draw and every
member run inside the jitted step: the state holds every member's own state and the drawn
index; ``desired_heading`` runs the drawn member through ``lax.switch`` (under ``vmap`` every
member is evaluated and the drawn one selected). A member is given the league's key as it
is, so a league whose weight is all on one member plays exactly that behaviour's episodes.

Members that reflect off walls (``bounce``) are refused: the world picks wall handling per
behaviour at trace time, not per episode.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dyncatch.sim.behaviors.base import BEHAVIORS, Behavior, Check
from dyncatch.sim.behaviors.evader_net import FLAG, EvaderCheckpointError
from dyncatch.sim.behaviors.learned import LEARNED, evader_net
from dyncatch.sim.fields import static

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg

LEAGUE_STREAM = 0x1EA6
"""The episode's member is drawn with the init key folded with this (the members' own
draws take the key as it is)."""


@struct.dataclass
class LeagueCfg:
    league_behaviors: tuple[str, ...] = static(("reactive",))
    """league: the scripted members, keys of BEHAVIORS that do not reflect off walls
    (reactive, random_reactive, circle)."""
    league_evaders: tuple[str, ...] = static(())
    """league: the learned members, evader checkpoints (files or run folders of `dyncatch
    evader train`), each run as the learned behaviour (its evader_sample applies)."""
    league_scripted_share: float = static(0.5)
    """league: the share of episodes that draw a scripted member when both kinds are
    present, split evenly among them; the rest is split evenly among the evaders (ignored
    when league_weights is given or one kind is absent)."""
    league_weights: tuple[float, ...] = static(())
    """league: explicit weights, one per member, scripted members first then the evaders,
    in order (normalised; a 0 never plays); empty: the league_scripted_share rule."""


@struct.dataclass
class LeagueState:
    """The state of a ``league`` target: the episode's member and every member's state."""

    member: jax.Array
    """The drawn member, () int32: an index into ``members(cfg)``."""
    states: tuple
    """Each member's behaviour state, in ``members(cfg)`` order (only the drawn one moves)."""


def members(cfg: WorldCfg) -> tuple[tuple[Behavior, WorldCfg], ...]:
    """(behaviour, the world it runs in) per member: the scripted ones in ``cfg`` as it is,
    each evader as ``learned`` with its checkpoint."""
    t = cfg.target
    scripted = tuple((BEHAVIORS[name], cfg) for name in t.league_behaviors)
    learned = tuple(
        (LEARNED, cfg.replace(target=t.replace(evader_checkpoint=path)))
        for path in t.league_evaders
    )
    return scripted + learned


def league_weights(cfg: WorldCfg) -> np.ndarray:
    """The members' draw probabilities, (M,), summing to 1 (``LeagueCfg`` says how)."""
    t = cfg.target
    n_s, n_e = len(t.league_behaviors), len(t.league_evaders)
    if t.league_weights:
        w = np.asarray(t.league_weights, np.float64)
    elif n_s and n_e:
        share = t.league_scripted_share
        w = np.concatenate([np.full(n_s, share / n_s), np.full(n_e, (1 - share) / n_e)])
    else:
        w = np.ones(n_s + n_e)
    return w / w.sum()


def league_init(key: jax.Array, cfg: WorldCfg):
    """Every member placed from ``key``; the drawn member's place and heading are kept."""
    draws = [b.init_state(key, c) for b, c in members(cfg)]
    logits = jnp.log(jnp.asarray(league_weights(cfg), jnp.float32))
    member = jax.random.categorical(jax.random.fold_in(key, LEAGUE_STREAM), logits)
    xy = jnp.stack([d[0] for d in draws])[member]
    heading = jnp.stack([jnp.asarray(d[1], jnp.float32) for d in draws])[member]
    return xy, heading, LeagueState(member.astype(jnp.int32), tuple(d[2] for d in draws))


def league_heading(target, robot, cfg: WorldCfg, key: jax.Array):
    """The drawn member's desired heading; only its state is updated."""
    state: LeagueState = target.behavior_state
    pairs = members(cfg)

    def branch(i: int):
        behavior, world = pairs[i]

        def run(states: tuple):
            heading, new = behavior.desired_heading(
                target.replace(behavior_state=states[i]), robot, world, key
            )
            return jnp.asarray(heading, jnp.float32), states[:i] + (new,) + states[i + 1 :]

        return run

    if len(pairs) == 1:
        heading, states = branch(0)(state.states)
    else:
        branches = [branch(i) for i in range(len(pairs))]
        heading, states = jax.lax.switch(state.member, branches, state.states)
    return heading, state.replace(states=states)


def league_speed_share(state: LeagueState, cfg: WorldCfg) -> jax.Array:
    """The drawn member's share of the speed cap (``Behavior.speed_share``; 1 for a member
    without one: the scripted members, an evader without a speed action)."""
    shares = [
        jnp.ones(()) if b.speed_share is None else jnp.asarray(b.speed_share(s, w), jnp.float32)
        for (b, w), s in zip(members(cfg), state.states, strict=True)
    ]
    return shares[0] if len(shares) == 1 else jnp.stack(shares)[state.member]


def league_validate(cfg: WorldCfg) -> list[Check]:
    t = cfg.target
    bad = [
        n
        for n in t.league_behaviors
        if n not in BEHAVIORS or not BEHAVIORS[n].scripted or BEHAVIORS[n].reflects_off_walls
    ]
    fit = [n for n, b in BEHAVIORS.items() if b.scripted and not b.reflects_off_walls]
    checks: list[Check] = [
        (
            not bad,
            "target.league_behaviors",
            f"{bad} cannot be league members; choose from {', '.join(fit)} (learned evaders "
            "go in --world.target.league-evaders)",
        ),
        (
            bool(t.league_behaviors or t.league_evaders),
            "target.league_behaviors",
            "the league is empty; give scripted members or --world.target.league-evaders",
        ),
        (
            0.0 <= t.league_scripted_share <= 1.0,
            "target.league_scripted_share",
            f"{t.league_scripted_share} is not a share; use a value in [0, 1]",
        ),
    ]
    n = len(t.league_behaviors) + len(t.league_evaders)
    if t.league_weights:
        w = np.asarray(t.league_weights, np.float64)
        ok = w.size == n and bool(np.all(w >= 0)) and float(w.sum()) > 0
        why = (
            f"{list(t.league_weights)}: give {n} non-negative weights (scripted members then "
            "evaders) with a positive sum, or none"
        )
        checks.append((ok, "target.league_weights", why))
    for path in t.league_evaders:
        try:
            evader_net(cfg.replace(target=t.replace(evader_checkpoint=path)))
        except EvaderCheckpointError as err:
            msg = str(err).replace(FLAG, "--world.target.league-evaders")
            checks.append((False, "target.league_evaders", msg))
    return checks


LEAGUE = Behavior(
    desired_heading=league_heading,
    cfg_cls=LeagueCfg,
    init_state=league_init,
    validate=league_validate,
    speed_share=league_speed_share,
    scripted=False,
    doc="each episode one member of a league (scripted behaviours, frozen evaders) by weight",
)
