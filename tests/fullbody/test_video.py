"""The full-body video's fallback: the recorded state drawn from above where MuJoCo cannot
make an OpenGL context (benchmarks/fullbody_video.py)."""

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("mujoco")

_PATH = Path(__file__).parents[2] / "benchmarks" / "fullbody_video.py"
_spec = importlib.util.spec_from_file_location("fullbody_video", _PATH)
video = importlib.util.module_from_spec(_spec)
sys.modules["fullbody_video"] = video  # its dataclass looks its module up
_spec.loader.exec_module(video)


def test_top_down_frames_follow_the_trunk_and_show_the_target():
    from dyncatch.fullbody.config import FullBodyCfg
    from dyncatch.fullbody.model import build_model

    model, _ = build_model(FullBodyCfg())
    q = np.stack([model.qpos0.copy() for _ in range(2)])
    q[:, 2] = 0.45
    q[1, :2] = [50.0, -20.0]  # far from the origin: the window follows the trunk
    target = np.array([[1.0, 0.5, 0.15], [51.0, -19.5, 0.15]])
    frames = video.render_top_down(q, target, video.VideoCmd(fps=50, size_px=(240, 180)))
    assert [f.shape for f in frames] == [(180, 240, 3)] * 2
    # The same scene relative to the trunk draws the same picture.
    np.testing.assert_array_equal(frames[0], frames[1])
    # The target's red disc is drawn: pixels that are red and not grey.
    red = (frames[0][..., 0] > 180) & (frames[0][..., 1] < 80) & (frames[0][..., 2] < 80)
    assert red.sum() > 20
