"""Save and load a predictor or a tracker: arrays in safetensors, the config as JSON in the
same file's header (no pickle), written atomically (temporary file + ``os.replace``).

Loading checks the file's config against the one expected and every array's shape, and
raises ``CheckpointError`` (a ``ValueError``, so the CLI prints one line) naming what to do.
"""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from safetensors.numpy import load_file

from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.tracker.config import TrackerCfg
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.tree_io import digest_ok, write_atomic_safetensors

FORMAT = "dyncatch.predictor/1"
TRACKER_FORMAT = "dyncatch.tracker/1"
_SEP = "/"


class CheckpointError(ValueError):
    """A checkpoint that cannot be used; the message says why and what to do."""


def _flatten(tree: dict, prefix: str = "") -> dict[str, np.ndarray]:
    flat = {}
    for name, value in tree.items():
        key = f"{prefix}{_SEP}{name}" if prefix else name
        if isinstance(value, dict):
            flat.update(_flatten(value, key))
        else:
            flat[key] = np.asarray(value)
    return flat


def _unflatten(flat: dict[str, np.ndarray]) -> dict:
    tree: dict = {}
    for key, value in flat.items():
        *parents, leaf = key.split(_SEP)
        node = tree
        for p in parents:
            node = node.setdefault(p, {})
        node[leaf] = jnp.asarray(value)
    return tree


def predictor_to_json(predictor: Predictor) -> dict:
    return dataclasses.asdict(predictor)


def predictor_from_json(d: dict) -> Predictor:
    cfg = dict(d["cfg"])
    cfg["hidden"] = tuple(cfg["hidden"])
    return Predictor(PredictorCfg(**cfg), float(d["arena_size_m"]), float(d["frame_dt_s"]))


def tracker_from_json(d: dict) -> Tracker:
    cfg = dict(d["cfg"])
    cfg["hidden"] = tuple(cfg["hidden"])
    return Tracker(TrackerCfg(**cfg), float(d["control_dt_s"]))


PREDICTOR_FILE = "predictor.safetensors"
"""The checkpoint's name in a `dyncatch predictor train --out` folder."""


def save(
    path: str | os.PathLike,
    predictor: Predictor | Tracker,
    params: dict,
    info: dict | None = None,
):
    """Write ``params`` and ``predictor`` (a frame predictor or a tracker, plus optional
    JSON-able ``info``) to ``path``."""
    meta = {
        "format": TRACKER_FORMAT if predictor.stateful else FORMAT,
        "predictor": json.dumps(dataclasses.asdict(predictor)),
        "info": json.dumps(info or {}),
    }
    write_atomic_safetensors(Path(path), _flatten(jax.device_get(params)), meta)


def _read(path: Path, formats: tuple[str, ...] = (FORMAT,)) -> tuple[dict, dict[str, np.ndarray]]:
    if path.is_dir():
        inside = sorted(p.name for p in path.glob("*.safetensors"))
        hint = f" (it holds {', '.join(inside)})" if inside else ""
        raise FileNotFoundError(
            f"{path} is a folder{hint}: give the predictor's checkpoint file, "
            f"e.g. {path / PREDICTOR_FILE}"
        )
    if not path.is_file():
        raise FileNotFoundError(f"no predictor checkpoint at {path}: train one first")
    try:
        from safetensors import safe_open

        with safe_open(str(path), framework="numpy") as f:
            meta = f.metadata() or {}
        flat = load_file(str(path))
        if meta.get("format") not in formats:
            raise CheckpointError(f"{path} is not a {' or '.join(formats)} checkpoint")
        if not digest_ok(meta, flat):
            raise CheckpointError(
                f"{path} is corrupt (its tensors do not match their checksum): "
                "retrain or copy it again"
            )
        return meta, flat
    except CheckpointError:
        raise
    except Exception as err:  # safetensors raises several types on damaged files
        msg = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise CheckpointError(f"{path} is corrupt ({msg}): retrain or copy it again") from None


def load(path: str | os.PathLike, expected: Predictor | None = None) -> tuple[Predictor, dict]:
    """(predictor, params) from ``path``; if ``expected`` is given, the file must match it."""
    path = Path(path)
    meta, flat = _read(path)
    try:
        predictor = predictor_from_json(json.loads(meta["predictor"]))
    except (KeyError, TypeError, ValueError) as err:
        raise CheckpointError(f"{path} has an unreadable config ({err}): retrain it") from None
    if expected is not None and predictor != expected:
        diff = [
            f"{k}: file {v!r} vs expected {predictor_to_json(expected)[k]!r}"
            for k, v in predictor_to_json(predictor).items()
            if v != predictor_to_json(expected)[k]
        ]
        raise CheckpointError(
            f"{path} does not match the predictor config ({'; '.join(diff)}): "
            "pass the config it was trained with or retrain"
        )
    return predictor, _checked_params(path, predictor, flat)


def _checked_params(path: Path, predictor: Predictor | Tracker, flat: dict) -> dict:
    reference = _flatten(jax.device_get(predictor.init(jax.random.key(0))))
    if set(reference) != set(flat):
        missing = sorted(set(reference) ^ set(flat))[:3]
        raise CheckpointError(f"{path} has the wrong arrays (e.g. {missing}): retrain it")
    for name, ref in reference.items():
        if flat[name].shape != ref.shape:
            raise CheckpointError(
                f"{path}: array {name} has shape {flat[name].shape}, the config needs "
                f"{ref.shape}: retrain it"
            )
    return _unflatten(flat)


def load_tracker(path: str | os.PathLike) -> tuple[Tracker, dict]:
    """(tracker, params) from a tracker checkpoint at ``path``."""
    path = Path(path)
    meta, flat = _read(path, (TRACKER_FORMAT,))
    try:
        tracker = tracker_from_json(json.loads(meta["predictor"]))
    except (KeyError, TypeError, ValueError) as err:
        raise CheckpointError(f"{path} has an unreadable config ({err}): retrain it") from None
    return tracker, _checked_params(path, tracker, flat)


def check_world(path: str | os.PathLike, predictor: Predictor | Tracker, world: WorldCfg):
    """Refuse a predictor or tracker whose recorded world quantities (arena size, camera
    period, control period) are not ``world``'s: its inputs would be scaled wrongly."""
    want = type(predictor).for_world(predictor.cfg, world)
    got_d, want_d = dataclasses.asdict(predictor), dataclasses.asdict(want)
    diff = [f"{k} {v!r} (the world: {want_d[k]!r})" for k, v in got_d.items() if v != want_d[k]]
    if diff:
        raise CheckpointError(
            f"{path} was made for another world: {'; '.join(diff)}; use that world "
            "(--world.arena.size-m, --world.sensor.rate-hz, --world.episode.control-hz) or "
            "retrain the predictor in this one"
        )


def load_any(
    path: str | os.PathLike, world: WorldCfg | None = None
) -> tuple[Predictor | Tracker, dict]:
    """A frame predictor's or a tracker's checkpoint, whichever ``path`` holds; with
    ``world``, refused unless it was made for that world (``check_world``)."""
    meta, _ = _read(Path(path), (FORMAT, TRACKER_FORMAT))
    predictor, params = (load_tracker if meta["format"] == TRACKER_FORMAT else load)(path)
    if world is not None:
        check_world(path, predictor, world)
    return predictor, params


def read_info(path: str | os.PathLike) -> dict:
    return json.loads(_read(Path(path), (FORMAT, TRACKER_FORMAT))[0].get("info", "{}"))
