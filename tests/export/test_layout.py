"""Layouts of the exported graphs: every input slot has a unit and a meaning."""

import pytest

from dyncatch.export.layout import command_layout, entries, policy_layout, predictor_layout
from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.features import FEATURES
from dyncatch.predictor.model import Predictor
from dyncatch.rl.methods import METHODS
from dyncatch.sim.state import ACTION_DIM, OBS_DIM


@pytest.mark.parametrize(
    ("kind", "frame"), [(k, f) for k in FEATURES for f in FEATURES[k]], ids=lambda v: v
)
def test_every_predictor_layout_has_units_and_meanings(kind, frame):
    layout = predictor_layout(Predictor(PredictorCfg(kind=kind, frame=frame, hidden=(8,))))
    assert all(e["unit"] and e["doc"] for e in layout)
    assert (
        layout[-1]["offset"] + layout[-1]["size"]
        == Predictor(PredictorCfg(kind=kind, frame=frame)).input_dim
    )


def test_a_name_without_a_unit_or_a_meaning_is_refused():
    with pytest.raises(ValueError, match="unit suffix"):
        entries([("speed", 1)], {"speed": "how fast"})
    with pytest.raises(ValueError, match="undocumented"):
        entries([("speed_mps", 1)], {})


@pytest.mark.parametrize(
    "method", [name for name, m in METHODS.items() if m.predictor_kind is None]
)
def test_the_policy_layout_covers_the_input_vector(method):
    layout = policy_layout(METHODS[method].obs_fn())
    end = layout[-1]["offset"] + layout[-1]["size"]
    assert end == OBS_DIM + (3 if METHODS[method].velocity_input else 0)
    assert [e["offset"] for e in layout[1:]] == [e["offset"] + e["size"] for e in layout[:-1]]
    assert {e["unit"] for e in layout} >= {"m", "m/s", "rad/s", "s", "1 (0 or 1)"}


def test_the_command_has_one_named_slot_per_action():
    assert [e["name"] for e in command_layout()] == ["vx_mps", "vy_mps", "yaw_rate_rps"]
    assert len(command_layout()) == ACTION_DIM
