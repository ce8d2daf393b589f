"""The input and output layouts of the exported graphs, read off the code that builds them.

A layout is a list of ``{"name", "offset", "size", "unit", "doc"}`` entries, one per named
slice of a vector, in order. Names come from ``Obs``'s fields and sizes (``Obs.layout``),
the methods' velocity inputs (``VELOCITY_INPUTS``) and the predictor encoders' named parts
(``Encoder.layout``); units from the name's suffix (``UNIT_SUFFIXES``); meanings from the
fields' docstrings and ``FEATURE_DOCS``. A new field or feature updates the layout.
"""

from __future__ import annotations

import ast
import inspect
import textwrap
from collections.abc import Iterable

from dyncatch.predictor.features import FEATURE_DOCS, get_encoder
from dyncatch.predictor.model import Predictor
from dyncatch.rl.methods import VELOCITY_INPUTS, MethodObs
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import Obs

UNIT_SUFFIXES: dict[str, str] = {
    "_frac": "1 (metres over arena_size_m)",
    "_cos_sin": "1 (cos, sin)",
    "_unit": "1 (unit vector)",
    "_mps": "m/s",
    "_rps": "rad/s",
    "_rad": "rad",
    "_m": "m",
    "_s": "s",
    "visible": "1 (0 or 1)",
    "_defined": "1 (0 or 1)",
}
"""Name suffix -> unit; every name in an exported layout ends in one of these."""

COMMAND: tuple[tuple[str, str], ...] = (
    ("vx_mps", "forward velocity command, base frame"),
    ("vy_mps", "leftward velocity command, base frame"),
    ("yaw_rate_rps", "yaw rate command, counter-clockwise"),
)
"""The policy's output, the base command (``ACTION_DIM`` entries)."""

FRAMES = {
    "world": "the arena's frame: origin at a corner, walls at x, y = 0 and arena_size_m",
    "base": "the robot's frame now: x forward, y left, origin at the base centre",
}


def unit_of(name: str) -> str:
    """The unit of a layout entry from its name's suffix."""
    for suffix, unit in UNIT_SUFFIXES.items():
        if name.endswith(suffix):
            return unit
    raise ValueError(f"{name!r} has no unit suffix ({', '.join(UNIT_SUFFIXES)}): rename it")


def attribute_docs(cls: type) -> dict[str, str]:
    """The docstrings written under a class's annotated fields (as tyro reads them)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    body = tree.body[0].body  # type: ignore[attr-defined]
    docs = {}
    for field, after in zip(body, body[1:], strict=False):
        if (
            isinstance(field, ast.AnnAssign)
            and isinstance(field.target, ast.Name)
            and isinstance(after, ast.Expr)
            and isinstance(after.value, ast.Constant)
            and isinstance(after.value.value, str)
        ):
            docs[field.target.id] = " ".join(after.value.value.split())
    return docs


def entries(parts: Iterable[tuple[str, int]], docs: dict[str, str]) -> list[dict]:
    """Layout entries with running offsets; every name needs a unit and a doc."""
    out, offset = [], 0
    for name, size in parts:
        if name not in docs:
            raise ValueError(f"{name!r} is undocumented: document it where it is defined")
        out.append(
            {"name": name, "offset": offset, "size": size, "unit": unit_of(name), "doc": docs[name]}
        )
        offset += size
    return out


def policy_layout(obs_fn: MethodObs, world: WorldCfg) -> list[dict]:
    """The policy's input vector (D,) in ``world``: ``Obs.flat`` (its scan as wide as the
    world's rays) then the method's velocity inputs."""
    docs = attribute_docs(Obs) | {name: doc for name, _, doc in VELOCITY_INPUTS}
    return entries(obs_fn.layout(world), docs)


def command_layout() -> list[dict]:
    """The policy's output (3,)."""
    return entries(((name, 1) for name, _ in COMMAND), dict(COMMAND))


def predictor_layout(predictor: Predictor) -> list[dict]:
    """The predictor's encoded inputs x (D_pred,) of its (kind, frame) encoder."""
    return entries(get_encoder(predictor.cfg.kind, predictor.cfg.frame).layout(), FEATURE_DOCS)
