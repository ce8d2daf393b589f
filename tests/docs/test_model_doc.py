"""docs/model.md (and docs/scenes.md, for the scenes' own groups) documents every model
constant, with the default the code uses."""

import dataclasses
import math
import re
from pathlib import Path

import pytest

from dyncatch.sim.config import WorldCfg

DOCS = Path(__file__).resolve().parents[2] / "docs"
DOC = (DOCS / "model.md").read_text() + "\n" + (DOCS / "scenes.md").read_text()
WORLD = WorldCfg()
FIELDS = [
    (group.name, f.name, getattr(getattr(WORLD, group.name), f.name))
    for group in dataclasses.fields(WORLD)
    for f in dataclasses.fields(getattr(WORLD, group.name))
]


@pytest.mark.parametrize(
    ("group", "name", "default"), FIELDS, ids=[f"{g}.{n}" for g, n, _ in FIELDS]
)
def test_every_constant_has_a_row_with_its_default(group, name, default):
    names = (f"`{name}`", f"`{group}.{name}`")
    rows = [
        line for line in DOC.splitlines() if line.startswith("|") and any(n in line for n in names)
    ]
    assert rows, f"docs/model.md and docs/scenes.md have no table row for {group}.{name}"
    cells = " ".join(rows)
    if isinstance(default, bool):
        assert str(default) in cells, f"{group}.{name} = {default} not in: {cells}"
    elif isinstance(default, str):
        assert default in cells
    elif isinstance(default, tuple) and all(isinstance(v, str) for v in default):
        assert all(v in cells for v in default), f"{group}.{name} = {default} not in: {cells}"
    elif isinstance(default, tuple):
        numbers = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", cells)]
        assert all(any(math.isclose(v, x, abs_tol=1e-9) for x in numbers) for v in default)
    elif math.isinf(default):
        assert " inf " in cells, f"{group}.{name} = inf not written as inf in: {cells}"
    else:
        numbers = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", cells)]
        # Angles are written in degrees in the doc.
        candidates = {float(default), round(math.degrees(default), 1)}
        assert any(
            math.isclose(c, x, rel_tol=1e-3, abs_tol=1e-9) for c in candidates for x in numbers
        ), f"{group}.{name} = {default} not in: {cells}"
