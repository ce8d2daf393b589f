"""A video of one full-body catch (MuJoCo's offscreen renderer), for docs/fullbody.md.

``MUJOCO_GL=egl python benchmarks/fullbody_video.py [--policy pursuit|RUN_DIR]
[--speed-mps 1.2] [--seed 0] [--out results/fullbody_catch.mp4]``: plays episodes of the
reactive target on the full body (``fullbody.catch``) until one is caught, then replays
that episode's recorded state into MuJoCo and renders it from a camera that follows the
trunk. Where no OpenGL context can be made (no EGL or OSMesa library), it draws the same
recorded state from above instead (``render_top_down``: the trunk's footprint and heading,
the feet, the gripper and the target, from MuJoCo's forward kinematics), and says so.
Nothing is written into the repository unless ``--out`` says so.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import jax
import numpy as np
import tyro

from dyncatch.evaluation.backends import run_fullbody_episodes
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.rl.resolve import resolve_policy
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


def render_top_down(qpos: np.ndarray, target_m: np.ndarray, cmd: VideoCmd) -> list[np.ndarray]:
    """The recorded state from above, drawn with matplotlib (no OpenGL): a 4 m window that
    follows the trunk, the trunk as its 0.65 x 0.30 m footprint with a heading tick, the feet,
    the gripper, and the target's 0.10 m disc."""
    import mujoco
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle, Polygon

    from dyncatch.fullbody.model import build_model

    model, idx = build_model(FullBodyCfg())
    data = mujoco.MjData(model)
    width, height = cmd.size_px
    every = max(1, round(50 / cmd.fps))
    frames = []
    for q, t in zip(qpos[::every], target_m[::every], strict=True):
        data.qpos[:] = q
        mujoco.mj_forward(model, data)
        x, y = q[0], q[1]
        w, _, _, z = q[3:7]
        yaw = 2.0 * np.arctan2(z, w)  # the trunk's heading (its roll and pitch are small)
        c, s = np.cos(yaw), np.sin(yaw)
        corners = np.array([[0.325, 0.15], [0.325, -0.15], [-0.325, -0.15], [-0.325, 0.15]])
        body = corners @ np.array([[c, s], [-s, c]]) + [x, y]
        fig = Figure(figsize=(width / 100, height / 100), dpi=100)
        ax = fig.add_axes((0, 0, 1, 1))
        ax.add_patch(Polygon(body, closed=True, color="0.3"))
        ax.plot([x, x + 0.45 * c], [y, y + 0.45 * s], color="k", lw=2)
        for f in idx.foot_body:
            ax.plot(*data.xpos[f][:2], "o", color="0.6", ms=4)
        ax.plot(*data.site_xpos[idx.gripper_site][:2], "s", color="C1", ms=5)
        ax.add_patch(Circle(t[:2], 0.10, color="C3"))
        half = 2.0 * width / height
        ax.set_xlim(x - half, x + half)
        ax.set_ylim(y - 2.0, y + 2.0)
        ax.set_aspect("equal")
        ax.grid(alpha=0.3)
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        frames.append(np.asarray(canvas.buffer_rgba())[..., :3].copy())
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
    try:
        frames = render(out["qpos"], out["target_m"], cmd)
    except Exception as e:  # no GL context here: mujoco raises on Renderer or GL loading
        print(f"MuJoCo's renderer is not available ({type(e).__name__}: {e}); drawing from above")
        frames = render_top_down(out["qpos"], out["target_m"], cmd)
    cmd.out.parent.mkdir(parents=True, exist_ok=True)
    imageio.mimsave(cmd.out, frames, fps=cmd.fps)
    print("wrote", cmd.out, f"({len(frames)} frames)")
    return cmd.out


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(VideoCmd))
