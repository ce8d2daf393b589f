"""Any pytree of arrays to one safetensors file and back (no pickle), written atomically.

Leaves are stored under their tree paths; a JSON ``header`` rides in the file's metadata.
Loading needs a *template* of the same structure (e.g. a freshly initialised state): every
leaf's path, shape and dtype must match, else ``TreeFileError`` says which one differs.
Typed PRNG keys are stored as their raw key data. A SHA-256 of the tensors (names, dtypes,
shapes and bytes) rides in the metadata too and is checked on load, so a damaged data byte
is refused with the file's name (files written before the checksum load unchecked).
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
from safetensors import SafetensorError
from safetensors.numpy import load_file, save_file

from dyncatch.utils.files import honour_umask

_HEADER_KEY = "dyncatch_header"
DIGEST_KEY = "dyncatch_sha256"
"""The metadata key of the tensors' checksum (``tensor_digest``)."""


class TreeFileError(ValueError):
    """A file that does not hold the expected tree; the message says what differs."""


def tensor_digest(arrays: dict[str, np.ndarray]) -> str:
    """SHA-256 (hex) of named arrays: each name, dtype, shape and bytes, in name order."""
    h = hashlib.sha256()
    for name in sorted(arrays):
        a = np.ascontiguousarray(arrays[name])
        h.update(f"{name}\0{a.dtype.str}\0{a.shape}\0".encode())
        h.update(a.tobytes())
    return h.hexdigest()


def digest_ok(metadata: dict, arrays: dict[str, np.ndarray]) -> bool:
    """Whether ``arrays`` match the checksum in a file's ``metadata`` (True without one)."""
    want = metadata.get(DIGEST_KEY)
    return want is None or want == tensor_digest(arrays)


def write_atomic_safetensors(path: Path, arrays: dict[str, np.ndarray], metadata: dict) -> Path:
    """``arrays`` to ``path`` through a temporary file and ``os.replace``, with ``metadata``
    and the tensors' checksum; the file gets the mode a plain ``open`` would (umask)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        save_file(arrays, tmp, metadata={**metadata, DIGEST_KEY: tensor_digest(arrays)})
        honour_umask(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)
    return path


def _is_key(x) -> bool:
    return isinstance(x, jax.Array | jax.ShapeDtypeStruct) and jax.dtypes.issubdtype(
        x.dtype, jax.dtypes.prng_key
    )


def _spec(leaf) -> tuple[tuple[int, ...], np.dtype]:
    """Shape and dtype a template leaf is stored with (an array or a ShapeDtypeStruct)."""
    if _is_key(leaf):
        leaf = jax.eval_shape(jax.random.key_data, leaf)
    if isinstance(leaf, jax.ShapeDtypeStruct):
        return tuple(leaf.shape), np.dtype(leaf.dtype)
    return np.shape(leaf), np.asarray(leaf).dtype


def _named_leaves(tree) -> list[tuple[str, object]]:
    leaves, _ = jax.tree_util.tree_flatten_with_path(tree)
    return [(jax.tree_util.keystr(path), leaf) for path, leaf in leaves]


def save_tree(path: str | os.PathLike, tree, header: dict) -> Path:
    arrays = {
        name: np.asarray(jax.random.key_data(leaf) if _is_key(leaf) else leaf)
        for name, leaf in _named_leaves(tree)
    }
    return write_atomic_safetensors(Path(path), arrays, {_HEADER_KEY: json.dumps(header)})


def read_header(path: str | os.PathLike) -> dict:
    from safetensors import safe_open

    try:
        with safe_open(str(path), framework="numpy") as f:
            return json.loads((f.metadata() or {})[_HEADER_KEY])
    except FileNotFoundError:
        raise
    except (SafetensorError, KeyError, json.JSONDecodeError, OSError) as err:
        raise TreeFileError(f"{path}: not a dyncatch checkpoint or corrupt ({err})") from None


def _read_arrays(path: Path) -> tuple[dict, dict]:
    if not path.exists():
        raise FileNotFoundError(f"{path}: no such checkpoint")
    from safetensors import safe_open

    header = read_header(path)
    try:
        with safe_open(str(path), framework="numpy") as f:
            metadata = f.metadata() or {}
        arrays = load_file(str(path))
    except (SafetensorError, OSError) as err:
        raise TreeFileError(f"{path}: corrupt checkpoint ({err})") from None
    if not digest_ok(metadata, arrays):
        raise TreeFileError(
            f"{path}: corrupt checkpoint (its tensors do not match their checksum); "
            "copy it again or retrain"
        )
    return arrays, header


def _fill(path: Path, arrays: dict, template, prefix: str = ""):
    """``template`` with every leaf read from ``arrays`` under ``prefix`` + its tree path."""
    leaves, treedef = jax.tree_util.tree_flatten(template)
    out = []
    for (name, tleaf), _ in zip(_named_leaves(template), leaves, strict=True):
        name = prefix + name
        if name not in arrays:
            raise TreeFileError(f"{path}: missing {name}; it was saved by another config")
        value = arrays[name]
        shape, dtype = _spec(tleaf)
        if value.shape != shape or value.dtype != dtype:
            raise TreeFileError(
                f"{path}: {name} has shape {value.shape} {value.dtype}, expected "
                f"{shape} {dtype}: it was saved by another config"
            )
        out.append(jax.random.wrap_key_data(value) if _is_key(tleaf) else jnp.asarray(value))
    return jax.tree_util.tree_unflatten(treedef, out)


def load_tree(path: str | os.PathLike, template):
    """(tree shaped like ``template``, header). The template may be abstract
    (``jax.eval_shape`` of an initialiser), so loading need not build a real state."""
    path = Path(path)
    arrays, header = _read_arrays(path)
    tree = _fill(path, arrays, template)
    if len(arrays) != len(_named_leaves(template)):
        raise TreeFileError(
            f"{path}: holds {len(arrays)} arrays, expected {len(_named_leaves(template))}"
        )
    return tree, header


def load_fields(path: str | os.PathLike, template, fields: tuple[str, ...]):
    """({field: subtree}, header): only the named top-level fields of a dataclass-shaped
    ``template`` (e.g. a policy's parameters and normaliser out of a training state). The
    other fields are neither read into the template nor checked, so a policy stays loadable
    when a part of the state it does not need (the environment's) has changed shape."""
    path = Path(path)
    arrays, header = _read_arrays(path)
    return {f: _fill(path, arrays, getattr(template, f), prefix=f".{f}") for f in fields}, header
