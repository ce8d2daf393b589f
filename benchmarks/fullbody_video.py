"""A video of one full-body catch (MuJoCo's offscreen renderer), for docs/fullbody.md.

``MUJOCO_GL=egl python benchmarks/fullbody_video.py [--policy pursuit|RUN_DIR]
[--speed-mps 1.2] [--seed 0] [--out results/fullbody_catch.mp4]``: plays episodes of the
reactive target on the full body (``fullbody.catch``) until one is caught, then replays
that episode's recorded state into MuJoCo and renders it from a camera that follows the
trunk. Nothing is written into the repository unless ``--out`` says so.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import jax
import numpy as np
import tyro

from dyncatch.evaluation.resolve import resolve_policy
from dyncatch.fullbody.catch import run_fullbody_episodes
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


@dataclasses.dataclass(frozen=True)
class VideoCmd:
    policy: str = "pursuit"
    """A baseline name or a run folder (as ``dyncatch eval``)."""
    speed_mps: float = 1.2
    """Target speed (reactive)."""
    seed: int = 0
    """First episode key; the next seeds are tried until an episode ends in a catch."""
    tries: int = 5
    """Seeds tried."""
    out: Path = Path("results/fullbody_catch.mp4")
    """The video (MP4 or GIF by its suffix)."""
    size_px: tuple[int, int] = (480, 360)
    """Width and height."""
    fps: int = 25
    """Frames per second; every second 50 Hz step is drawn, so it plays in real time."""


def render(qpos: np.ndarray, target_m: np.ndarray, cmd: VideoCmd) -> list[np.ndarray]:
    import mujoco

    from dyncatch.fullbody.model import build_model

    model, idx = build_model(FullBodyCfg())
    data = mujoco.MjData(model)
    width, height = cmd.size_px
    model.vis.global_.offwidth, model.vis.global_.offheight = max(width, 640), max(height, 480)
    renderer = mujoco.Renderer(model, height, width)
    cam = mujoco.MjvCamera()
    cam.type = mujoco.mjtCamera.mjCAMERA_TRACKING
    cam.trackbodyid = idx.base_body
    cam.distance, cam.elevation, cam.azimuth = 3.0, -25.0, 135.0
    every = max(1, round(50 / cmd.fps))
    frames = []
    for q, t in zip(qpos[::every], target_m[::every], strict=True):
        data.qpos[:] = q
        data.mocap_pos[idx.target_mocap] = t
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, cam)
        frames.append(renderer.render().copy())
    return frames


def main(cmd: VideoCmd) -> Path:
    import imageio.v2 as imageio

    world = WorldCfg().with_speed(cmd.speed_mps)
    policy, _, trained = resolve_policy(cmd.policy, world)
    world = (trained or world).with_behavior("reactive").with_speed(cmd.speed_mps)
    for seed in range(cmd.seed, cmd.seed + cmd.tries):
        out = run_fullbody_episodes(policy, jax.random.key(seed), world, 1, record=0)
        if out["success"][0]:
            break
    print(f"seed {seed}: caught {bool(out['success'][0])} at {out['catch_time_s'][0]:.2f} s")
    frames = render(out["qpos"], out["target_m"], cmd)
    cmd.out.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(cmd.out, frames, fps=cmd.fps)
    print("wrote", cmd.out, f"({len(frames)} frames)")
    return cmd.out


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(VideoCmd))
