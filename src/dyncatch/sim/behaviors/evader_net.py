"""A trained evader's network as a file, and its forward pass in plain ``jnp``.

The ``learned`` behaviour runs it inside the world's step; the simulator may not import the
trainer's Flax networks (``rl`` sits above ``sim``), so the actor is stored as a list of
dense layers and evaluated here with the same ELU the trainer's ``rl.networks.MLP`` uses.
The file is one safetensors checkpoint (``utils.tree_io``: atomic, checksummed, no pickle)
whose header records the architecture, the feature names, the turn range, what the turn
is added to (its action frame) and whether it also picks its speed (its speed action), so a
file is refused when it does not match the features this version computes.
"""

from __future__ import annotations

import functools
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.utils.tree_io import TreeFileError, load_tree, read_header, save_tree

EVADER_FORMAT = "dyncatch.evader/1"
"""Format of an evader checkpoint (``save_evader`` writes it, ``load_evader`` reads it)."""
EVADER_CHECKPOINT = "evader.safetensors"
"""The checkpoint's name in an evader run folder (``dyncatch evader train --out DIR``)."""
FLAG = "--world.target.evader-checkpoint"

FULL_VIEW_RAD = 2 * math.pi
"""An evader field of view of a whole turn: it sees the robot wherever it is (the default,
and the reading of a file that records none)."""
"""The flag that names the file (``TargetCfg.evader_checkpoint``)."""
NORM_CLIP = 10.0
"""Normalised inputs are clipped to +-this, as the trainer's ``rl.normalize.RunningNorm``."""


class EvaderCheckpointError(ValueError):
    """An evader checkpoint that is missing, damaged or of another layout; the message names
    the flag and the fix."""


def elu(x: jax.Array) -> jax.Array:
    """ELU (alpha 1), the numbers of ``rl.networks.elu``."""
    return jnp.where(x > 0, x, jnp.expm1(jnp.minimum(x, 0.0)))


@dataclass(frozen=True, eq=False)
class EvaderNet:
    """A frozen evader actor: dense layers ``(kernel (in, out), bias (out,))``, ELU between
    them, the observation normaliser, the turn range actions map to and the training
    policy's action std (None in a file that does not record it)."""

    layers: tuple[tuple[np.ndarray, np.ndarray], ...]
    norm_mean: np.ndarray
    norm_std: np.ndarray
    turn_limit_rad: float
    header: dict
    action_std: float | None = None
    """The trained Gaussian policy's std of the turn action, in action units ([-1, 1] spans
    the turn range)."""
    action_frame: str = "heading"
    """What the turn is added to (``sim.behaviors.learned.ACTION_FRAMES``): ``heading``, the
    target's own heading, in a file that does not record it."""
    fov_rad: float = FULL_VIEW_RAD
    """The evader's field of view, its full angle centred on its heading
    (``sim.behaviors.learned.evader_features``); a whole turn in a file that records none."""
    speed_action: bool = False
    """A second action picks the speed, a share of the cap
    (``sim.behaviors.learned.speed_share_of``); False (a file that records none): it runs at
    the cap."""
    speed_action_std: float | None = None
    """The trained Gaussian policy's std of the speed action (None without one)."""

    @property
    def action_dim(self) -> int:
        """1 (the turn), or 2 (turn, speed) with ``speed_action``."""
        return 2 if self.speed_action else 1

    def std_vector(self) -> jax.Array:
        """The trained policy's std per action, (action_dim,)."""
        stds = [self.action_std] + ([self.speed_action_std] if self.speed_action else [])
        return jnp.asarray(stds, jnp.float32)

    def action_mean(self, features: jax.Array) -> jax.Array:
        """The actor's mean action, (action_dim,), from the features (D,), normalised and
        clipped as in training."""
        x = jnp.clip((features - self.norm_mean) / self.norm_std, -NORM_CLIP, NORM_CLIP)
        for i, (kernel, bias) in enumerate(self.layers):
            x = x @ kernel + bias
            if i + 1 < len(self.layers):
                x = elu(x)
        return x

    def turn(self, action: jax.Array) -> jax.Array:
        """An action, clipped to [-1, 1], as a turn in rad, as ``rl.train.to_command`` maps
        it in training."""
        return jnp.clip(action, -1.0, 1.0) * self.turn_limit_rad

    def mean_turn(self, features: jax.Array) -> jax.Array:
        """The deterministic turn, (), rad, in [-turn_limit, turn_limit]."""
        return self.turn(self.action_mean(features)[0])


def actor_tree(layers, norm_mean, norm_std) -> dict:
    """The pytree an evader file stores: ``{"actor": {"layer<i>": {kernel, bias}}, "norm":
    {mean, std}}``."""
    return {
        "actor": {f"layer{i}": {"kernel": k, "bias": b} for i, (k, b) in enumerate(layers)},
        "norm": {"mean": norm_mean, "std": norm_std},
    }


def save_evader(path: str | os.PathLike, net: EvaderNet) -> Path:
    """Write ``net`` to ``path`` atomically; its header gains the format and layer sizes."""
    sizes = [int(k.shape[1]) for k, _ in net.layers]
    header = {
        **net.header,
        "format": EVADER_FORMAT,
        "obs_dim": int(net.layers[0][0].shape[0]),
        "layer_sizes": sizes,
        "activation": "elu",
        "turn_limit_rad": float(net.turn_limit_rad),
        "action_std": None if net.action_std is None else float(net.action_std),
        "action_frame": net.action_frame,
        "fov_rad": float(net.fov_rad),
        "speed_action": bool(net.speed_action),
        "speed_action_std": None if net.speed_action_std is None else float(net.speed_action_std),
    }
    tree = actor_tree(
        [(np.asarray(k, np.float32), np.asarray(b, np.float32)) for k, b in net.layers],
        np.asarray(net.norm_mean, np.float32),
        np.asarray(net.norm_std, np.float32),
    )
    return save_tree(path, tree, header)


def _bad(path: str, why: str) -> EvaderCheckpointError:
    return EvaderCheckpointError(
        f"evader checkpoint {path!r}: {why}; pass {FLAG} PATH of a file written by "
        f"`dyncatch evader train --out DIR` (DIR/{EVADER_CHECKPOINT})"
    )


def load_evader(path: str, feature_names: Callable[[float, bool], tuple[str, ...]]) -> EvaderNet:
    """The evader network in ``path`` (cached per file and its modification time), checked
    against ``feature_names(fov_rad, speed_action)``, the features this version computes for
    the file's field of view and speed action; EvaderCheckpointError naming the flag for an
    empty path, a missing, damaged or mismatched file."""
    if not path:
        raise _bad(path, "is empty, and the learned behaviour runs a trained evader")
    p = Path(path)
    if p.is_dir():
        p = p / EVADER_CHECKPOINT
    try:
        stat = p.stat()
    except OSError:
        raise _bad(path, "no such file") from None
    return _load_cached(str(p.resolve()), stat.st_mtime_ns, stat.st_size, feature_names)


@functools.lru_cache(maxsize=16)
def _load_cached(path: str, mtime_ns: int, size: int, names_of: Callable[[float, bool], tuple]):
    del mtime_ns, size  # part of the key only: a rewritten file is read again
    try:
        header = read_header(path)
    except TreeFileError as err:
        raise _bad(path, f"not an evader checkpoint or damaged ({err})") from None
    if header.get("format") != EVADER_FORMAT:
        raise _bad(path, f"format {header.get('format')!r}, expected {EVADER_FORMAT!r}")
    try:
        fov_rad = float(header.get("fov_rad", FULL_VIEW_RAD))
    except (TypeError, ValueError):
        raise _bad(path, f"its field of view {header.get('fov_rad')!r} is no angle") from None
    speed_action = header.get("speed_action", False)
    if not isinstance(speed_action, bool):
        raise _bad(path, f"its speed_action {speed_action!r} is not true or false")
    feature_names = names_of(fov_rad, speed_action)
    if tuple(header.get("features", ())) != feature_names:
        raise _bad(
            path,
            f"trained on features {header.get('features')}, this version computes "
            f"{list(feature_names)}; retrain it",
        )
    try:
        sizes = [int(s) for s in header["layer_sizes"]]
        turn_limit = float(header["turn_limit_rad"])
    except (KeyError, TypeError, ValueError) as err:
        raise _bad(path, f"its header lacks the architecture ({err})") from None
    dims = [len(feature_names), *sizes]
    f32 = lambda *shape: jax.ShapeDtypeStruct(shape, jnp.float32)  # noqa: E731
    template = actor_tree(
        [(f32(a, b), f32(b)) for a, b in zip(dims[:-1], dims[1:], strict=True)],
        f32(dims[0]),
        f32(dims[0]),
    )
    try:
        # A first load may happen while a step is traced (a world not validated first):
        # the arrays are constants, never tracers.
        with jax.ensure_compile_time_eval():
            tree, _ = load_tree(path, template)
    except TreeFileError as err:
        raise _bad(path, f"damaged ({err})") from None
    actor = tree["actor"]
    layers = tuple(
        (np.asarray(actor[f"layer{i}"]["kernel"]), np.asarray(actor[f"layer{i}"]["bias"]))
        for i in range(len(sizes))
    )
    want = 2 if speed_action else 1
    if sizes[-1] != want:
        what = "turn and speed" if speed_action else "turn"
        raise _bad(path, f"its actor has {sizes[-1]} outputs, the evader's action ({what}) {want}")
    speed_std = header.get("speed_action_std")
    return EvaderNet(
        layers,
        np.asarray(tree["norm"]["mean"]),
        np.asarray(tree["norm"]["std"]),
        turn_limit,
        header,
        None if header.get("action_std") is None else float(header["action_std"]),
        str(header.get("action_frame", "heading")),
        fov_rad,
        speed_action,
        None if speed_std is None else float(speed_std),
    )
