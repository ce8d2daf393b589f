"""Recording, drawing and writing one episode (pursuit vs a slow circle target)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import imageio.v3 as iio
import jax
import numpy as np
import pytest
from matplotlib.colors import to_rgb

from dyncatch.cli.render import RenderCmd, resolve, run_render
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim.config import WorldCfg
from dyncatch.viz.render import (
    FLOOR_COLOR,
    FOV_SEEN_COLOR,
    ROBOT_COLOR,
    TARGET_COLOR,
    VIRTUAL_COLOR,
    WALL_COLOR,
    follows_robot,
    frame_rows,
    pixel_of,
    render_frames,
    write_video,
)
from dyncatch.viz.trajectory import catch_time_s, record_episode

SPEED_MPS = 0.3
CFG = WorldCfg().with_scene("arena").with_behavior("circle").with_speed(SPEED_MPS)
POLICY = pursuit_policy(CFG)
SIZE_PX = 240


def _true_velocity(state, obs):
    del obs
    return {"pred_vel_mps": state.target.vel_mps}


@pytest.fixture(scope="module")
def traj() -> dict[str, np.ndarray]:
    return record_episode(POLICY, jax.random.PRNGKey(0), CFG, extra_fn=_true_velocity)


@pytest.fixture(scope="module")
def frames(traj) -> list[np.ndarray]:
    return render_frames(traj, CFG, every=10, size_px=SIZE_PX)


class TestRecordEpisode:
    def test_arrays_share_one_length_and_have_their_shapes(self, traj):
        n = len(traj["time_s"])
        assert n > 1
        assert {k: v.shape[0] for k, v in traj.items()} == {k: n for k in traj}
        assert traj["robot_xy_m"].shape == (n, 2)
        assert traj["gripper_xyz_m"].shape == (n, 3)
        assert traj["obs_xy_m"].shape == (n, 2)
        assert traj["pred_vel_mps"].shape == (n, 2)
        assert traj["visible"].dtype == bool

    def test_time_starts_at_zero_and_steps_by_dt(self, traj):
        # Row 0 is the reset state; control runs at 50 Hz.
        assert traj["time_s"][0] == 0.0
        np.testing.assert_allclose(np.diff(traj["time_s"]), 0.02, atol=1e-12)
        np.testing.assert_array_equal(traj["step"], np.arange(len(traj["step"])))

    def test_episode_ends_at_the_first_done(self, traj):
        assert traj["done"][-1]
        assert not traj["done"][:-1].any()
        # A 0.3 m/s target on a fixed circle is caught well before the 20 s limit.
        assert traj["success"][-1]
        assert not traj["success"][:-1].any()
        assert catch_time_s(traj) == pytest.approx(traj["time_s"][-1])
        assert 0.0 < catch_time_s(traj) < 20.0

    def test_target_moves_on_its_circle_at_its_speed(self, traj):
        # 0.3 m/s for 0.02 s is 6 mm a step; the circle has a 5 m radius about (8, 8).
        steps_m = np.linalg.norm(np.diff(traj["target_xy_m"], axis=0), axis=1)
        np.testing.assert_allclose(steps_m, SPEED_MPS * 0.02, rtol=0.02)
        radius_m = np.linalg.norm(traj["target_xy_m"] - 8.0, axis=1)
        np.testing.assert_allclose(radius_m, 5.0, atol=0.05)
        np.testing.assert_allclose(np.linalg.norm(traj["pred_vel_mps"], axis=1), SPEED_MPS,
                                   rtol=1e-5)  # fmt: skip

    def test_max_steps_keeps_every_row_of_an_unfinished_episode(self, traj):
        short = record_episode(POLICY, jax.random.PRNGKey(0), CFG, max_steps=5)
        assert len(short["time_s"]) == 6
        assert not short["done"].any()
        # Same key, same start: the first rows agree with the full episode.
        np.testing.assert_allclose(short["robot_xy_m"], traj["robot_xy_m"][:6], atol=1e-6)

    def test_extra_fn_may_not_shadow_built_in_keys(self):
        with pytest.raises(ValueError, match="time_s"):
            record_episode(POLICY, jax.random.PRNGKey(0), CFG, max_steps=2,
                           extra_fn=lambda s, o: {"time_s": s.step})  # fmt: skip


class TestRenderFrames:
    def test_frame_rows_keep_the_last_row(self):
        assert frame_rows(7, 3) == [0, 3, 6]
        assert frame_rows(8, 3) == [0, 3, 6, 7]
        with pytest.raises(ValueError):
            frame_rows(8, 0)

    def test_frames_have_the_requested_size_and_count(self, traj, frames):
        assert len(frames) == len(frame_rows(len(traj["time_s"]), 10))
        for frame in frames:
            assert frame.shape == (SIZE_PX, SIZE_PX, 3)
            assert frame.dtype == np.uint8
            assert frame.std() > 10.0
        assert np.abs(frames[0].astype(int) - frames[-1].astype(int)).sum() > 0

    def test_target_colour_is_drawn_where_the_target_is(self, traj, frames):
        rgb = np.array(to_rgb(TARGET_COLOR)) * 255
        # Only inside the arena: the key below it has a target marker too.
        size = CFG.arena.size_m
        (left, top), (right, bottom) = pixel_of(np.array([[0.0, size], [size, 0.0]]), CFG, SIZE_PX)
        for row, frame in zip(frame_rows(len(traj["time_s"]), 10), frames, strict=True):
            match = np.abs(frame.astype(float) - rgb).max(axis=-1) <= 12
            match[: int(top)] = match[int(bottom) + 1 :] = False
            match[:, : int(left)] = match[:, int(right) + 1 :] = False
            assert match.sum() >= 4, f"no target pixels in the frame of row {row}"
            rows, cols = np.nonzero(match)
            expected = pixel_of(traj["target_xy_m"][row], CFG, SIZE_PX)
            # The fading trail shares the hue but not the exact colour: the solid disc wins.
            np.testing.assert_allclose([cols.mean(), rows.mean()], expected, atol=3.0)

    def test_cone_is_green_while_the_target_is_seen(self, traj, frames):
        # The cone is FOV_SEEN_COLOR at alpha 0.16 over the floor while the camera sees it.
        floor, green = np.array(to_rgb(FLOOR_COLOR)), np.array(to_rgb(FOV_SEEN_COLOR))
        tint = 255 * (0.84 * floor + 0.16 * green)
        rows = frame_rows(len(traj["time_s"]), 10)
        seen = [f for r, f in zip(rows, frames, strict=True) if traj["visible"][r]]
        assert seen, "the camera never saw the target"
        for frame in seen:
            assert (np.abs(frame.astype(float) - tint).max(axis=-1) <= 2).sum() > 100


OPEN = WorldCfg().with_scene("open_plane").with_behavior("reactive").with_speed(1.8)


def _colour_pixels(frame: np.ndarray, colour: str, tol: float = 12) -> np.ndarray:
    return np.abs(frame.astype(float) - 255 * np.array(to_rgb(colour))).max(axis=-1) <= tol


@pytest.fixture(scope="module")
def chase():
    traj = record_episode(pursuit_policy(OPEN), jax.random.PRNGKey(3), OPEN)
    return traj, render_frames(traj, OPEN, every=50, size_px=SIZE_PX)


class TestOpenPlaneView:
    """On the open plane the view follows the robot; the virtual square is dashed, no wall."""

    def test_only_unwalled_scenes_follow(self):
        assert follows_robot(OPEN) and not follows_robot(CFG)
        with pytest.raises(ValueError, match="robot_xy_m"):
            pixel_of(np.zeros(2), OPEN, SIZE_PX)

    def test_robot_stays_at_the_centre_and_the_target_where_it_is(self, chase):
        traj, frames = chase
        assert np.ptp(traj["robot_xy_m"], axis=0).max() > 8.0  # the robot went somewhere
        centre = pixel_of(traj["robot_xy_m"][0], OPEN, SIZE_PX, traj["robot_xy_m"][0])
        for row, frame in zip(frame_rows(len(traj["time_s"]), 50), frames, strict=True):
            robot = pixel_of(traj["robot_xy_m"][row], OPEN, SIZE_PX, traj["robot_xy_m"][row])
            np.testing.assert_allclose(robot, centre)
            # The body: ROBOT_COLOR at alpha 0.9 over the floor (or the cone's faint tint).
            tint = 255 * (0.9 * np.array(to_rgb(ROBOT_COLOR)) + 0.1 * np.array(to_rgb(FLOOR_COLOR)))
            body = np.abs(frame.astype(float) - tint).max(axis=-1) <= 12
            rows, cols = np.nonzero(body)
            assert rows.size > 0
            # The footprint (0.65 m long) lies around the centre.
            assert np.abs([cols.mean() - centre[0], rows.mean() - centre[1]]).max() < 4
            target = pixel_of(traj["target_xy_m"][row], OPEN, SIZE_PX, traj["robot_xy_m"][row])
            inside = (target > 0.1 * SIZE_PX).all() and (target < 0.9 * SIZE_PX).all()
            if not inside:
                continue
            match = _colour_pixels(frame, TARGET_COLOR)
            match[int(0.9 * SIZE_PX) :] = False  # not the key's marker below
            # At 1.8 m/s the trail behind the disc shares its hue: look around the disc.
            c, r = np.round(target).astype(int)
            assert match[r - 3 : r + 4, c - 3 : c + 4].sum() >= 12, f"row {row}: no disc there"
            assert match.sum() < 4 * match[r - 6 : r + 7, c - 6 : c + 7].sum()

    def test_no_wall_is_drawn_and_the_virtual_square_is_where_it_is(self, chase):
        traj, frames = chase
        wall = np.array(to_rgb(WALL_COLOR)) * 255
        first = frames[0]
        assert (np.abs(first.astype(float) - wall).max(axis=-1) <= 6).sum() < 20
        # The episode starts inside the square: its dashed sides (grey, darker than the grid
        # drawn on the same world lines) show in the first frame where the corner puts them.
        (c, r) = np.round(pixel_of(np.zeros(2), OPEN, SIZE_PX, traj["robot_xy_m"][0])).astype(int)
        darker = 255 * (to_rgb(VIRTUAL_COLOR)[0] + to_rgb("#dddddd")[0]) / 2  # than the grid
        grey = (np.ptp(first.astype(int), axis=-1) <= 8) & (first.max(axis=-1) < darker)
        lo, hi = int(0.1 * SIZE_PX), int(0.9 * SIZE_PX)  # the floor, not the bands
        assert grey[lo:r, c - 1 : c + 2].any(axis=1).mean() > 0.25  # left (the cone tints some)
        assert grey[r - 1 : r + 2, c:hi].any(axis=0).mean() > 0.25  # the bottom side
        assert grey[lo:r, c + 8 : c + 11].any(axis=1).mean() < 0.1  # and nothing beside it


class TestWriteVideo:
    def test_gif_reads_back_with_every_frame(self, frames, tmp_path):
        path = write_video(frames, tmp_path / "sub" / "catch.gif", fps=25)
        assert path == tmp_path / "sub" / "catch.gif"
        back = iio.imread(path, index=None)
        assert back.shape[:3] == (len(frames), SIZE_PX, SIZE_PX)
        # No temporary file is left beside it.
        assert [p.name for p in path.parent.iterdir()] == ["catch.gif"]

    def test_mp4_is_written(self, frames, tmp_path):
        import imageio_ffmpeg

        path = write_video(frames[:5], tmp_path / "catch.mp4", fps=10)
        n_frames, secs = imageio_ffmpeg.count_frames_and_secs(str(path))
        assert n_frames == 5
        assert secs == pytest.approx(0.5, abs=0.05)

    def test_other_suffixes_are_refused(self, frames, tmp_path):
        with pytest.raises(ValueError, match=r"\.gif, \.mp4"):
            write_video(frames, tmp_path / "catch.avi", fps=25)
        assert not list(tmp_path.iterdir())


class TestRenderCmd:
    @pytest.mark.parametrize(
        ("field", "value", "named"),
        [("policy", "nope", "pursuit"), ("world", WorldCfg().with_behavior("nope"), "reactive"),
         ("out", Path("x.avi"), ".gif")],
    )  # fmt: skip
    def test_bad_choices_raise_naming_the_choices(self, field, value, named):
        with pytest.raises(ValueError, match=named):
            resolve(dataclasses.replace(RenderCmd(), **{field: value}))

    def test_bad_world_is_refused(self):
        world = WorldCfg().replace(sensor=WorldCfg().sensor.replace(range_m=-1.0))
        with pytest.raises(ValueError, match="sensor.range_m"):
            resolve(RenderCmd(world=world))

    def test_run_render_writes_the_gif_and_reports_it(self, tmp_path, capsys):
        cmd = RenderCmd(world=WorldCfg().with_behavior("circle"), speed_mps=SPEED_MPS,
                        out=tmp_path / "c.gif", every=5, size_px=128)  # fmt: skip
        path = run_render(cmd)
        line = capsys.readouterr().out.strip()
        n_frames = len(iio.imread(path, index=None))
        assert line.startswith(f"{path}: {n_frames} frames")
        assert "caught at" in line


class TestSceneDrawing:
    """Obstacles, the scan, an occluded target and the blend inset, from a hand-made row."""

    world = WorldCfg().for_scene("room_4")

    def _row(self, occluded: bool) -> dict:
        return {
            "time_s": np.float64(1.0),
            "robot_xy_m": np.array([4.0, 8.0]),
            "robot_yaw_rad": np.float32(0.0),
            "robot_speed_mps": np.float32(1.0),
            "gripper_xyz_m": np.array([4.3, 8.0, 0.5]),
            "target_xy_m": np.array([12.0, 8.0]),
            "target_speed_mps": np.float32(1.0),
            "obs_xy_m": np.array([12.0, 8.0]),
            "visible": np.bool_(False),
            "ever_seen": np.bool_(False),
            "success": np.bool_(False),
            # A 2 m box between the robot and the target, a cylinder below them.
            "obstacle_xy_m": np.array([[8.0, 8.0], [8.0, 3.0]]),
            "obstacle_half_m": np.array([[1.0, 1.0], [0.0, 0.0]]),
            "obstacle_radius_m": np.array([0.0, 0.5]),
            "scan_m": np.full(32, 3.0),
            "occluded": np.bool_(occluded),
        }

    def _draw(self, occluded: bool) -> np.ndarray:
        from dyncatch.viz.render import TopDownDrawer

        drawer = TopDownDrawer(self.world, SIZE_PX, with_scan=True, with_blend=True)
        history = (np.array([0.0, 0.5, 1.0]), np.array([0.0, 0.4, 0.9]))
        return drawer.draw(self._row(occluded), blend_history=history)

    def test_obstacles_scan_occlusion_and_blend_are_drawn(self):
        from dyncatch.viz.render import BLEND_COLOR, OBSTACLE_COLOR, OCCLUDED_COLOR, SCAN_COLOR

        frame = self._draw(occluded=True)

        def near(xy, rgb, radius=2):
            c, r = np.round(pixel_of(np.asarray(xy), self.world, SIZE_PX)).astype(int)
            patch = frame[r - radius : r + radius + 1, c - radius : c + radius + 1]
            target = np.array(to_rgb(rgb)) * 255
            return np.any(np.all(np.abs(patch.astype(float) - target) < 40, axis=-1))

        assert near([8.0, 8.0], OBSTACLE_COLOR)  # the box's centre
        assert near([8.0, 3.0], OBSTACLE_COLOR)  # the cylinder's
        assert near([12.0, 8.0], OCCLUDED_COLOR)  # the hidden target, grey
        # A ray straight down, hitting at 3 m: a thin cyan line (SCAN_COLOR at alpha 0.6,
        # antialiased) on the grey floor, where nothing else is cyan.
        c, r = np.round(pixel_of(np.array([4.0, 6.5]), self.world, SIZE_PX)).astype(int)
        patch = frame[r - 3 : r + 4, c - 3 : c + 4].astype(int)
        assert SCAN_COLOR == "#17becf" and np.any(patch[..., 1] - patch[..., 0] > 40)
        blend = np.array(to_rgb(BLEND_COLOR)) * 255
        assert np.any(np.all(np.abs(frame.astype(float) - blend) < 40, axis=-1))
        seen = self._draw(occluded=False)
        c, r = np.round(pixel_of(np.array([12.0, 8.0]), self.world, SIZE_PX)).astype(int)
        assert np.allclose(seen[r, c], np.array(to_rgb(TARGET_COLOR)) * 255, atol=40)
