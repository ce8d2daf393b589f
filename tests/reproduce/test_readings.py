"""Each named reading changes exactly the fields it names, and flags still override it."""

import math

import pytest

from dyncatch.cli.main import parse
from dyncatch.reproduce.plan import PROFILES
from dyncatch.reproduce.readings import PAPER_LITERAL, READINGS, apply_readings, setting_name
from dyncatch.utils.config_io import config_diff

EXPECTED = {
    "eq9_per_step": {"world.reward.visibility_per": ("per_second", "per_step")},
    "success_every_step": {"world.reward.success_per": ("terminal", "every_step")},
    "legged_yaw": {"world.base.max_yaw_rate_rps": (2.0, 1.0)},
    "legged_turning": {"world.base.max_lateral_accel_mps2": (float("inf"), 3.0)},
    "slow_tracking": {"world.base.lag_s": (0.1, 0.3)},
    "narrow_speeds": {"world.target.speed_min_mps": (0.0, 0.8)},
    "fullbody_base": {
        "world.base.max_forward_mps": (2.0, 2.3),
        "world.base.max_backward_mps": (1.0, 2.0),
        "world.base.max_yaw_rate_rps": (2.0, 3.0),
        "world.base.max_lateral_accel_mps2": (float("inf"), 2.9),
        "world.base.lag_s": (0.1, 0.09),
        "world.base.max_lin_accel_mps2": (4.0, 2.0),
        "world.base.max_yaw_accel_rps2": (10.0, 9.5),
    },
    "trot_envelope": {"world.base.max_speed_mps": (float("inf"), 1.93)},
    "paper_budget": {"train_steps": (4_000_000, 20_000_000)},
    "gamma_held": {"world.target.gamma_hold_s": (0.0, 0.5)},
    # The paper's observation is the standard one since issue 32: the reading changes
    # nothing, and the earlier standard is a reading of its own.
    "paper_observation": {},
    "staleness_observation": {"world.observation.staleness_inputs": (False, True)},
    "fov_half_angle": {"world.sensor.fov_rad": (math.radians(120.0), math.radians(240.0))},
    "beta_heading": {"world.target.beta_reading": ("bearing", "heading_difference")},
    "arm_on_sighting": {"world.arm.aim": ("true", "sighting")},
}
EXPECTED["paper_literal"] = {k: v for name in PAPER_LITERAL for k, v in EXPECTED[name].items()}


def test_every_reading_is_documented_here():
    assert set(READINGS) == set(EXPECTED)


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_a_reading_changes_exactly_what_it_says(name):
    base = PROFILES["full"]
    diff = config_diff(base.to_json(), apply_readings(base, [name]).to_json())
    diff.pop("setting")
    assert diff == {k: tuple(v) for k, v in EXPECTED[name].items()}


def test_readings_compose_in_order_and_name_the_setting():
    plan = apply_readings(PROFILES["quick"], ["legged_yaw", "legged_turning"])
    assert plan.setting == ("legged_yaw", "legged_turning")
    assert (plan.world.base.max_yaw_rate_rps, plan.world.base.max_lateral_accel_mps2) == (1.0, 3.0)
    assert plan.ppo.hidden_sizes == (128, 128, 64)  # the profile is kept
    assert setting_name(plan.setting) == "legged_yaw+legged_turning"
    assert setting_name(()) == "default"
    with pytest.raises(ValueError, match="legged_yaw"):
        apply_readings(PROFILES["quick"], ["telepathy"])


def test_the_command_line_applies_a_setting_and_flags_override_it():
    plan = parse(["reproduce", "--quick", "--setting", "legged_yaw"])[1]
    assert plan.world.base.max_yaw_rate_rps == 1.0 and plan.setting == ("legged_yaw",)
    argv = ["reproduce", "--setting", "legged_yaw", "--world.base.max-yaw-rate-rps", "1.5"]
    assert parse(argv)[1].world.base.max_yaw_rate_rps == 1.5


def test_docs_list_every_reading():
    from pathlib import Path

    docs = Path(__file__).resolve().parents[2] / "docs"
    for page in ("fidelity.md", "model.md"):
        doc = (docs / page).read_text()
        for name in READINGS:
            assert f"| `{name}` |" in doc, (page, name)


def test_the_new_fields_are_flags_of_their_own():
    argv = [
        "reproduce",
        "--quick",
        "--world.target.gamma-hold-s",
        "0.5",
        "--world.target.beta-reading",
        "heading_difference",
        "--world.arm.aim",
        "sighting",
        "--world.observation.staleness-inputs",
    ]
    w = parse(argv)[1].world
    assert (w.target.gamma_hold_s, w.target.beta_reading, w.arm.aim) == (
        0.5,
        "heading_difference",
        "sighting",
    )
    assert w.observation.staleness_inputs is True
    argv = [
        "reproduce",
        "--setting",
        "staleness_observation",
        "--world.observation.no-staleness-inputs",
    ]
    assert parse(argv)[1].world.observation.staleness_inputs is False


def test_the_standard_observation_is_the_papers():
    """Issue 32: s_obj = [p_obj] (IV-A), no age of the sighting; the earlier standard stays
    a reading."""
    assert PROFILES["full"].world.observation.staleness_inputs is False
    plan = parse(["reproduce", "--setting", "staleness_observation"])[1]
    assert plan.world.observation.staleness_inputs is True
    assert plan.setting == ("staleness_observation",)


def test_paper_literal_combines_the_literal_readings_and_flags_still_override():
    assert "eq9_per_step" not in PAPER_LITERAL  # no method learns under it (docs/fidelity.md)
    argv = ["reproduce", "--quick", "--setting", "paper_literal", "--train-steps", "100000"]
    plan = parse(argv)[1]
    assert plan.setting == ("paper_literal",) and plan.train_steps == 100_000
    w = plan.world
    assert (w.target.gamma_hold_s, w.arm.aim, w.reward.success_per) == (
        0.5,
        "sighting",
        "every_step",
    )
    assert not w.observation.staleness_inputs
