"""render_mode="rgb_array" of both adapters: the frame of the current state equals the
trajectory renderer's, the trail restarts with each episode, and Gymnasium's RecordVideo
wrappers (single and vector) write MP4s from it unmodified."""

from __future__ import annotations

import gymnasium
import imageio_ffmpeg
import jax
import numpy as np
import pytest
from matplotlib.colors import to_rgb

import dyncatch  # noqa: F401  (registers the gymnasium ids)
from dyncatch.gym import CATCH_ID
from dyncatch.gym.catch_env import CatchEnv
from dyncatch.gym.vector_env import CatchVectorEnv
from dyncatch.sim.config import EpisodeCfg, WorldCfg
from dyncatch.viz.render import TARGET_COLOR, pixel_of, render_frames
from dyncatch.viz.trajectory import state_row

SIZE_PX = 128
NUM_ENVS = 4
EPISODE_STEPS = 10
SHORT_WORLD = WorldCfg(episode=EpisodeCfg(duration_s=EPISODE_STEPS / 50))
"""10-step episodes at 50 Hz; duration_s is a traced leaf, so nothing recompiles for it."""
ACTION = np.array([1.0, 0.3, -0.5], np.float32)


def host_row(state, index: int | None = None) -> dict[str, np.ndarray]:
    """``state_row`` on the host, of one environment of a batch if ``index`` is given."""
    row = jax.device_get(state_row(state))
    return row if index is None else {k: v[index] for k, v in row.items()}


def as_traj(rows: list[dict], dt_s: float) -> dict[str, np.ndarray]:
    """Rows of consecutive states as the trajectory dict ``render_frames`` draws."""
    traj = {k: np.stack([r[k] for r in rows]) for k in rows[0]}
    traj["time_s"] = traj["step"] * dt_s
    return traj


@pytest.fixture(scope="module")
def env() -> CatchEnv:
    return CatchEnv(render_mode="rgb_array", render_size_px=SIZE_PX)


class TestCatchEnvRender:
    def test_metadata(self, env):
        assert env.metadata["render_modes"] == ["rgb_array"]
        assert env.metadata["render_fps"] == 50  # the control rate: one frame per step

    def test_frames_equal_the_trajectory_renderer(self, env):
        """Rendered only now and then, the frame still has the whole 2 s trail (100 steps)."""
        env.reset(seed=3)
        rows, frames = [host_row(env.state)], {0: env.render()}
        for t in range(1, 131):
            env.step(ACTION)
            rows.append(host_row(env.state))
            if t in (40, 130):
                frames[t] = env.render()
        reference = render_frames(as_traj(rows, env.world.episode.dt_s), env.world, 1, SIZE_PX)
        for t, frame in frames.items():
            assert frame.shape == (SIZE_PX, SIZE_PX, 3) and frame.dtype == np.uint8
            np.testing.assert_array_equal(frame, reference[t], err_msg=f"step {t}")
        assert not np.array_equal(frames[0], frames[130])

    def test_target_is_drawn_where_it_is(self):
        size_px = 240  # large enough for a disc of several pixels
        env = CatchEnv(render_mode="rgb_array", render_size_px=size_px)
        env.reset(seed=4)
        for _ in range(5):
            env.step(ACTION)
        frame = env.render().astype(float)
        match = np.abs(frame - 255 * np.array(to_rgb(TARGET_COLOR))).max(axis=-1) <= 12
        size = env.world.arena.size_m
        robot = np.asarray(env.state.origin_xy_m)  # the view follows the robot
        half = 0.5 * size
        (left, top), (right, bottom) = pixel_of(
            robot + np.array([[-half, half], [half, -half]]), env.world, size_px, robot
        )
        match[: int(top)] = match[int(bottom) + 1 :] = False  # not the key's marker below
        match[:, : int(left)] = match[:, int(right) + 1 :] = False
        rows, cols = np.nonzero(match)
        assert rows.size >= 4
        world_xy = env.state.target.xy_m + env.state.origin_xy_m  # stored relative to the robot
        expected = pixel_of(np.asarray(world_xy), env.world, size_px, robot)
        np.testing.assert_allclose([cols.mean(), rows.mean()], expected, atol=2.0)

    def test_a_room_frame_draws_the_scan_and_occlusion_as_the_videos_do(self):
        from dyncatch.sim.env import observe
        from dyncatch.viz.trajectory import scene_extras

        world = WorldCfg().for_scene("room_8")
        env = CatchEnv(world=world, render_mode="rgb_array", render_size_px=SIZE_PX)
        env.reset(seed=5)
        extras = scene_extras(env.world)

        def row(state):
            return {**host_row(state), **jax.device_get(extras(state, observe(state, env.world)))}

        rows = [row(env.state)]
        for _ in range(3):
            env.step(ACTION)
            rows.append(row(env.state))
        assert rows[-1]["scan_m"].shape == (world.scene.scan_rays,)
        frame = env.render()
        reference = render_frames(as_traj(rows, env.world.episode.dt_s), env.world, 1, SIZE_PX)
        np.testing.assert_array_equal(frame, reference[-1])
        bare = [{k: v for k, v in r.items() if k not in ("scan_m", "occluded")} for r in rows]
        without = render_frames(as_traj(bare, env.world.episode.dt_s), env.world, 1, SIZE_PX)
        assert not np.array_equal(frame, without[-1])  # the rays are drawn

    def test_no_render_mode_renders_nothing(self):
        with pytest.warns(UserWarning, match="render_mode"):
            assert CatchEnv().render() is None


class TestVectorRender:
    def test_one_frame_per_env_with_the_trail_of_its_own_episode(self):
        """After the same-step auto-reset each frame shows the new episode only."""
        venv = CatchVectorEnv(
            NUM_ENVS, world=SHORT_WORLD, render_mode="rgb_array", render_size_px=SIZE_PX
        )
        assert venv.metadata["render_modes"] == ["rgb_array"]
        assert venv.metadata["render_fps"] == 50
        venv.reset(seed=1)
        rows = [[host_row(venv.state, i)] for i in range(NUM_ENVS)]
        actions = np.tile(ACTION, (NUM_ENVS, 1))
        for _ in range(EPISODE_STEPS + 3):
            *_, truncated, _ = venv.step(actions)
            for i in range(NUM_ENVS):
                rows[i] = [] if truncated[i] else rows[i]  # the episode ended: a new trail
                rows[i].append(host_row(venv.state, i))
        assert all(len(r) == 4 for r in rows)
        frames = venv.render()
        assert isinstance(frames, tuple) and len(frames) == NUM_ENVS
        for i, frame in enumerate(frames):
            reference = render_frames(as_traj(rows[i], 0.02), venv.world, 1, SIZE_PX)[-1]
            np.testing.assert_array_equal(frame, reference, err_msg=f"env {i}")
        assert not np.array_equal(frames[0], frames[1])


def check_video(path, num_frames: int, size: tuple[int, int]) -> None:
    """``path`` holds ``num_frames`` frames of ``size`` (width, height) at 50 fps; or one
    fewer: moviepy 2.2's ``ImageSequenceClip.write_videofile`` drops the last frame."""
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = next(reader)
    count = sum(1 for _ in reader)
    assert (tuple(meta["size"]), meta["fps"]) == (size, 50.0)
    assert count in (num_frames - 1, num_frames)


# moviepy runs ffmpeg in a subprocess; JAX warns on any fork, harmlessly for an exec.
FORK_WARNING = "ignore:os.fork:RuntimeWarning"


@pytest.mark.filterwarnings(FORK_WARNING)
def test_record_video_writes_an_mp4(tmp_path):
    env = gymnasium.make(
        CATCH_ID, render_mode="rgb_array", render_size_px=SIZE_PX, world=SHORT_WORLD
    )
    videos = tmp_path / "videos"
    env = gymnasium.wrappers.RecordVideo(env, str(videos), episode_trigger=lambda e: e == 0)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(ACTION)
        done = terminated or truncated
    # The reset frame and one per step, at the control rate.
    assert len(env.recorded_frames) == EPISODE_STEPS + 1
    assert env.recorded_frames[0].shape == (SIZE_PX, SIZE_PX, 3)
    env.close()
    (path,) = videos.glob("*.mp4")
    check_video(path, EPISODE_STEPS + 1, (SIZE_PX, SIZE_PX))


@pytest.mark.filterwarnings(FORK_WARNING)
def test_vector_record_video_tiles_the_envs(tmp_path):
    venv = CatchVectorEnv(
        NUM_ENVS, world=SHORT_WORLD, render_mode="rgb_array", render_size_px=SIZE_PX
    )
    with pytest.warns(UserWarning, match="same-step"):
        env = gymnasium.wrappers.vector.RecordVideo(
            venv, str(tmp_path / "videos"), episode_trigger=lambda e: e == 0
        )
    env.reset(seed=0)
    for _ in range(EPISODE_STEPS + 2):
        env.step(np.tile(ACTION, (NUM_ENVS, 1)))
    env.close()
    (path,) = (tmp_path / "videos").glob("*.mp4")
    # Same-step auto-reset: the video of episode 0 (the reset frame and steps 1-9) stops
    # before the episode's last frame, as Gymnasium documents; four envs are tiled 2 x 2.
    check_video(path, EPISODE_STEPS, (2 * SIZE_PX, 2 * SIZE_PX))


def test_a_step_with_rendering_on_moves_nothing_to_the_host():
    """``push`` keeps references to the device arrays; a frame's trail is built at render."""
    from dyncatch.gym.rendering import StateFrames
    from dyncatch.sim.env import reset

    state = jax.jit(reset)(jax.random.key(0), WorldCfg())
    frames = StateFrames(WorldCfg(), SIZE_PX)
    with jax.transfer_guard("disallow"):  # raises on an accelerator; on CPU, the next line
        frames.start(state)
        frames.push(state)
    assert all(isinstance(a, jax.Array) for pair in frames._trail for a in pair)
    trail = frames._trail_xy()
    assert trail.shape == (2, 2) and trail.dtype == np.float64
    np.testing.assert_array_equal(trail[0], np.asarray(state.target.xy_m + state.origin_xy_m))
