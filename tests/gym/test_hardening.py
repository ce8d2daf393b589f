"""Bad inputs at the Gymnasium edge: non-finite actions and speeds are refused, never
propagated; the async vector mode of ``gymnasium.make_vec`` works (spawned workers)."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import gymnasium
import numpy as np
import pytest

import dyncatch  # noqa: F401  (registers the ids)
from dyncatch.gym.catch_env import CatchEnv
from dyncatch.gym.vector_env import CatchVectorEnv


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_non_finite_action_is_refused_and_the_state_kept(bad):
    env = CatchEnv(behavior="circle")
    obs, _ = env.reset(seed=0)
    state = env.state
    with pytest.raises(ValueError, match="action must be finite"):
        env.step(np.array([bad, 0.0, 0.0], np.float32))
    assert env.state is state
    obs, reward, *_ = env.step(np.zeros(3, np.float32))
    assert np.isfinite(obs).all() and np.isfinite(reward)


def test_a_non_finite_vector_action_is_refused():
    env = CatchVectorEnv(num_envs=2, behavior="circle")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"finite .*rows \[1\]"):
        env.step(np.array([[0, 0, 0], [0, np.nan, 0]], np.float32))


@pytest.mark.parametrize("speed", [float("inf"), float("nan"), "fast"])
def test_a_non_finite_speed_is_refused_at_make(speed):
    with pytest.raises(ValueError, match="speed_mps must be a finite number"):
        gymnasium.make("dyncatch/Catch-v0", speed_mps=speed)


def test_async_make_vec_returns_and_steps(tmp_path):
    """In a fresh interpreter, as a user runs it (the start method is process-wide)."""
    script = tmp_path / "async_vec.py"
    script.write_text(
        textwrap.dedent(
            """
            import gymnasium, numpy as np, dyncatch
            if __name__ == "__main__":
                env = gymnasium.make_vec(
                    "dyncatch/Catch-v0", num_envs=2, vectorization_mode="async"
                )
                obs, _ = env.reset(seed=0)
                obs, reward, *_ = env.step(np.zeros((2, 3), np.float32))
                assert obs.shape == (2, env.single_observation_space.shape[0]), obs.shape
                assert np.isfinite(obs).all() and np.isfinite(reward).all()
                env.close()
                print("stepped")
            """
        )
    )
    out = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, timeout=400,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )  # fmt: skip
    assert out.returncode == 0 and "stepped" in out.stdout, out.stderr[-2000:]
