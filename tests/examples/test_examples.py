"""The outside-library examples run end to end on a small budget, where their library is
installed (the ``examples`` extra; ``make examples``). CI installs only ``dev``, so there
they are skipped, each with the reason."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
STEPS = 4096
EPISODES = 8


def load(script: str):
    spec = importlib.util.spec_from_file_location(script.removesuffix(".py"), EXAMPLES / script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize(
    ("script", "library", "num_envs"),
    [("sb3_ppo.py", "stable_baselines3", 8), ("skrl_ppo.py", "skrl", 16)],
)
def test_example_trains_and_evaluates(script, library, num_envs):
    pytest.importorskip(
        library, reason=f"{library} is in the 'examples' extra (make examples), not in 'dev'"
    )
    argv = ["--total-steps", str(STEPS), "--episodes", str(EPISODES)]
    result = load(script).main([*argv, "--num-envs", str(num_envs), "--json"])
    assert result["total_steps"] >= STEPS
    assert result["samples_per_s"] > 0
    assert result["episodes"] == EPISODES
    lo, hi = result["success_ci95"]
    assert 0.0 <= lo <= result["success_rate"] <= hi <= 1.0
    # Mean catch time: failures count as the 20 s limit, catches as less.
    assert 0.0 < result["catch_time_s"] <= 20.0
    if result["success_rate"] < 1.0:
        assert result["catch_time_s"] > 20.0 * (1.0 - result["success_rate"])
