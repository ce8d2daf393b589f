"""docs/fullbody.md has a row for every full-body constant, with the default the code uses."""

import dataclasses
from pathlib import Path

import pytest

from dyncatch.fullbody.config import FullBodyCfg, GaitCfg, MpcCfg, Z1Cfg

DOC = (Path(__file__).resolve().parents[2] / "docs" / "fullbody.md").read_text()
FIELDS = [
    (cls.__name__, f.name, getattr(cls(), f.name))
    for cls in (FullBodyCfg, Z1Cfg, GaitCfg, MpcCfg)
    for f in dataclasses.fields(cls)
    if not dataclasses.is_dataclass(getattr(cls(), f.name))
]


def _fmt(v):
    if v is None or isinstance(v, bool | str):
        return str(v)
    if isinstance(v, tuple):
        return "(" + ", ".join(f"{x:g}" for x in v) + ")"
    return f"{v:g}"


@pytest.mark.parametrize(("cls", "name", "default"), FIELDS, ids=[f"{c}.{n}" for c, n, _ in FIELDS])
def test_every_constant_has_a_row_with_its_default(cls, name, default):
    rows = [line for line in DOC.splitlines() if line.startswith(f"| `{name}` |")]
    assert rows, f"docs/fullbody.md has no row for {cls}.{name}"
    assert any(f"| {_fmt(default)} |" in row for row in rows), (name, rows)
