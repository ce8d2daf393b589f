"""docs/tracker.md documents every constant of the tracker, with the default the code uses."""

import dataclasses
import math
import re
from pathlib import Path

import pytest

from dyncatch.predictor.tracker.config import TrackerCfg, TrackerDataCfg, TrackerTrainCfg

DOC = (Path(__file__).resolve().parents[2] / "docs" / "tracker.md").read_text()
DATA = TrackerDataCfg()
FIELDS = [
    *((f.name, getattr(TrackerCfg(), f.name)) for f in dataclasses.fields(TrackerCfg)),
    *((f.name, getattr(TrackerTrainCfg(), f.name)) for f in dataclasses.fields(TrackerTrainCfg)),
    ("collect.episode_s", DATA.collect.episode_s),
    ("sample_every_steps", DATA.sample_every_steps),
]


@pytest.mark.parametrize(("name", "default"), FIELDS, ids=[n for n, _ in FIELDS])
def test_every_tracker_constant_has_a_row_with_its_default(name, default):
    rows = [line for line in DOC.splitlines() if line.startswith(f"| `{name}` |")]
    assert rows, f"docs/tracker.md has no constants row for {name}"
    cells = rows[0].split("|")[2]
    numbers = [float(x) for x in re.findall(r"-?\d+(?:\.\d+)?", cells)]
    for value in default if isinstance(default, tuple) else (default,):
        assert any(math.isclose(float(value), x) for x in numbers), (name, default, cells)
