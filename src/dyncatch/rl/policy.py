"""A trained PPO run as a policy for evaluation and rendering.

``load_run(run_dir)`` reads the checkpoint header (method, behaviour, PPO and world
configs), rebuilds the network and the observation normaliser from the saved arrays and
returns a ``LearnedPolicy``: the deterministic mean action, mapped to a base command. The
method's input function is rebuilt too, so ``sp_fp`` is the ``gt_rl`` run loaded with the
self-aware predictor in place of the ground truth. A method with memory (``rnn_rl``) is
trained by recurrent PPO and loaded as a ``MemoryPolicy``: ``learner(method)`` is the one
place that picks the trainer and the policy class from ``Method.memory``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import jax
from flax import struct

from dyncatch.predictor.checkpoint import load_any
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.methods import GROUND_TRUTH, GROUND_TRUTH_READING, METHODS, MethodObs, get_method
from dyncatch.rl.networks import ActorCritic
from dyncatch.rl.normalize import RunningNorm
from dyncatch.rl.recurrent import MemoryPolicy
from dyncatch.rl.recurrent_train import make_recurrent_train
from dyncatch.rl.train import make_train, to_command
from dyncatch.sim.api import Environment, JaxCatchEnv
from dyncatch.sim.config import LEGACY_WORLD, WorldCfg
from dyncatch.sim.state import EnvState, Obs
from dyncatch.sim.validate import ConfigError, validate_world
from dyncatch.utils.config_io import ConfigDictError, fill_missing, from_dict
from dyncatch.utils.tree_io import TreeFileError, load_fields, read_header

CHECKPOINT = "checkpoint.safetensors"
"""The checkpoint's name in a run folder (``rl.runner`` writes it, ``load_run`` reads it)."""
TRAIN_FORMAT = "dyncatch.train/2"
"""Checkpoint format; /2 reads the visibility weight per second by a named field and keeps
each behaviour's typed state (runs of /1 must be retrained)."""


@struct.dataclass
class LearnedPolicy:
    """Recurrent-protocol policy around a trained actor; its carry is the input function's
    (``MethodObs.init_carry``: the tracker's memory, ``()`` for every other method).

    A pytree (weights, normaliser, predictor weights and the training environment are
    leaves; the network and the method's input kind are static), so evaluation passes it to
    jit as an argument: every checkpoint of one method shares one compilation. Actions are
    scaled to commands by the training environment's limits, the ones the policy learned.
    """

    net: ActorCritic = struct.field(pytree_node=False)
    params: dict
    norm: RunningNorm
    obs_fn: MethodObs
    env: Environment
    is_pytree_policy: bool = struct.field(pytree_node=False, default=True)

    def init_carry(self, state: EnvState, obs: Obs) -> Any:
        return self.obs_fn.init_carry(state)

    def step(self, carry: Any, state: EnvState, obs: Obs, key: jax.Array):
        del key  # the mean action: evaluation is deterministic given the world's noise
        carry, x = self.obs_fn.step(carry, state, obs)
        mean, _, _ = self.net.apply(self.params, self.norm(x))
        return carry, to_command(mean, self.env)


@dataclass(frozen=True)
class Learner:
    """How a method's policy is trained and run: ``make_train(env, ppo, obs_fn, mesh) ->
    (init, iterate, net)`` and the policy class built as ``policy(net, params, norm, obs_fn,
    env)``."""

    make_train: Callable
    policy: type[LearnedPolicy] | type[MemoryPolicy]


FEED_FORWARD = Learner(make_train, LearnedPolicy)
RECURRENT = Learner(make_recurrent_train, MemoryPolicy)


def learner(method: str) -> Learner:
    """The learner of a method by name: recurrent PPO where ``Method.memory``."""
    return RECURRENT if get_method(method).memory else FEED_FORWARD


@dataclass(frozen=True)
class Run:
    policy: LearnedPolicy | MemoryPolicy
    method: str
    """The method evaluated (``sp_fp`` for a ``gt_rl`` run evaluated with the predictor)."""
    trained_method: str
    behavior: str
    world: WorldCfg
    header: dict


def checkpoint_path(run: str | Path) -> Path:
    p = Path(run)
    return p / CHECKPOINT if p.is_dir() else p


def header_field(path: Path, header: dict, name: str, kind: type = str) -> Any:
    """``header[name]``, or TreeFileError naming the file and the field."""
    if name not in header:
        raise TreeFileError(f"{path}: its header has no {name!r}; retrain the run or restore it")
    if not isinstance(header[name], kind):
        raise TreeFileError(
            f"{path}: header field {name!r} is {header[name]!r}, expected a {kind.__name__}; "
            "retrain the run or restore it"
        )
    return header[name]


def header_world(path: Path, header: dict) -> WorldCfg:
    """The training world of a checkpoint's header: typed and checked, or TreeFileError
    naming the file and the field. A field the header lacks takes what the code did before
    it was recorded where that is not today's default (``LEGACY_WORLD``: a run trained
    before ``observation.staleness_inputs`` existed fed the staleness inputs)."""

    recorded = fill_missing(header_field(path, header, "world", dict), LEGACY_WORLD)
    try:
        world = from_dict(WorldCfg, recorded, "world")
        return validate_world(world)
    except (ConfigDictError, ConfigError) as err:
        raise TreeFileError(f"{path}: header {err}; retrain the run or restore it") from None


def header_ppo(path: Path, header: dict) -> PPOCfg:
    """The PPO config of a checkpoint's header, typed and checked (TreeFileError else).

    A header written before ``obs_min_std`` existed trained with no floor on the
    normaliser's scale, so it is evaluated with none (0.0), not with today's default."""
    recorded = header_field(path, header, "ppo", dict)
    recorded = {"obs_min_std": 0.0, **recorded}
    try:
        return validate_ppo(from_dict(PPOCfg, recorded, "ppo"))
    except ValueError as err:
        raise TreeFileError(f"{path}: header {err}; retrain the run or restore it") from None


def load_run(
    run: str | Path, as_method: str | None = None, predictor: str | Path | None = None
) -> Run:
    """Load a run folder (or its checkpoint file) written by ``dyncatch train``.

    ``as_method`` evaluates the policy as another method that reuses it (``sp_fp`` for a
    ``gt_rl`` run); ``predictor`` overrides the predictor checkpoint named in the header.
    """
    path = checkpoint_path(run)
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such run checkpoint (dyncatch train --out ...)")
    header = read_header(path)
    fmt = header.get("format")
    if fmt != TRAIN_FORMAT:
        if str(fmt).startswith("dyncatch.train/"):
            raise TreeFileError(
                f"{path}: written by an older dyncatch ({fmt}, this one reads "
                f"{TRAIN_FORMAT}); retrain it with dyncatch train"
            )
        raise TreeFileError(f"{path}: not a dyncatch train checkpoint ({fmt})")
    trained = header_field(path, header, "method")
    method = as_method or trained
    m = get_method(method)
    if method != trained and m.trained_as != trained:
        reusers = [k for k, v in METHODS.items() if v.trained_as == trained]
        raise ValueError(
            f"a {trained!r} run cannot be evaluated as {method!r}"
            + (f"; it can be evaluated as {', '.join(reusers)}" if reusers else "")
        )
    reading = header.get("ground_truth")
    if reading is None and get_method(trained).velocity_input == GROUND_TRUTH:
        # Such runs trained with the flag always 1 or, for a while, under the availability
        # rule: which one is not known, so neither is assumed.
        raise TreeFileError(
            f"{path}: a {trained!r} run that does not record its ground-truth reading "
            "(trained before it was recorded); retrain it with dyncatch train"
        )
    reading = reading or GROUND_TRUTH_READING
    ppo = header_ppo(path, header)
    world = header_world(path, header)
    pred = pred_params = None
    if m.predictor_kind is not None:
        pred_path = predictor or header.get("predictor")
        if pred_path is None:
            raise ValueError(
                f"method {method!r} needs --predictor PATH (a {m.predictor_kind!r} one)"
            )

        pred, pred_params = load_any(pred_path, world)
    obs_fn = m.obs_fn(pred, pred_params, evaluation=True, ground_truth=reading)
    # The template is the train state of the method it was trained as (same input size).
    train_fn = (
        get_method(trained).obs_fn(pred, pred_params, ground_truth=reading)
        if method != trained
        else obs_fn
    )
    env = JaxCatchEnv(world)
    how = learner(trained)
    init, _, net = how.make_train(env, ppo, train_fn)
    template = jax.eval_shape(init, jax.random.key(0))
    # Only what the policy needs: the environment's part of the state may have changed
    # shape since training (a scene added a field) without changing the policy.
    got, _ = load_fields(path, template, ("params", "norm"))
    policy = how.policy(net, got["params"], got["norm"], obs_fn, env)
    return Run(policy, method, trained, world.target.behavior, world, header)
