"""Top-down frames of one state or a recorded episode, and writing them as a GIF or MP4.

``TopDownDrawer`` owns one Agg figure (no pyplot, no global state) and draws one state from
its values (a row of ``viz.trajectory.STATE_KEYS``). In a walled scene the view is the whole
arena; where nothing bounds the chase (``Scene.walls`` false, the open plane) the view
follows the robot: a window of ``arena.size_m`` centred on it, the 2 m grid and the bounce
target's virtual square (dashed) sliding underneath; ``render_frames`` draws a recorded
trajectory with it, and the Gymnasium adapters draw their current state with it. Each frame
only moves the artists and redraws. Colours are fixed module constants so that tests can
look for them in the pixels. ``write_video`` (from ``viz.video``) is re-exported here, where
its callers have always found it.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import LineCollection, PatchCollection
from matplotlib.colors import to_rgb
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Polygon, Rectangle, Wedge

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import get_scene
from dyncatch.viz.video import VIDEO_SUFFIXES, write_video

__all__ = [
    "VIDEO_SUFFIXES",
    "TopDownDrawer",
    "follows_robot",
    "frame_rows",
    "pixel_of",
    "render_frames",
    "trail_rows",
    "view_extent_m",
    "write_video",
]

TARGET_COLOR = "#d62728"
ROBOT_COLOR = "#1f5fbf"
GRIPPER_COLOR = "#111111"
SEEN_COLOR = "#ff7f0e"
PRED_COLOR = "#9467bd"
FLOOR_COLOR = "#f4f4f0"
WALL_COLOR = "#333333"
VIRTUAL_COLOR = "#999999"
"""The open plane's virtual square (only the bounce target reflects off it), dashed."""
FOV_SEEN_COLOR = "#2ca02c"
FOV_BLIND_COLOR = "#bcbd22"
CAUGHT_COLOR = "#1a7f1a"
OBSTACLE_COLOR = "#8c6d46"
"""Boxes and cylinders (rooms), tree trunks (woods)."""
SCAN_COLOR = "#17becf"
"""The range scan's rays: bright where a ray hits, faint where it reads its cap."""
OCCLUDED_COLOR = "#7f7f7f"
"""The target while an obstacle hides it from the camera (inside the cone and range), and
the blocked line of sight, dotted."""
BLEND_COLOR = "#e377c2"
"""Eq. 10's pi_collid weight w_c over time (the inset)."""
TRAIL_S = 2.0
"""Length of the target's fading trail."""

_DPI = 100
_MARGIN_M = 0.15
_BAND_M = 0.75
_HEADING_LEN_M = 0.8
"""The heading arrow sticks out this far ahead of the footprint."""


def _arrow(start: np.ndarray, vec: np.ndarray, width: float, head_len: float) -> np.ndarray:
    """Corners (7, 2) of a flat arrow from ``start`` along ``vec`` (all in metres)."""
    length = float(np.hypot(*vec))
    if length < 1e-6:
        return np.repeat(np.asarray(start, float)[None], 7, axis=0)
    u = vec / length
    n = np.array([-u[1], u[0]])
    head = min(head_len, length)
    neck = start + (length - head) * u
    w = 0.5 * width
    return np.array([start + w * n, neck + w * n, neck + 2.5 * w * n, start + vec,
                     neck - 2.5 * w * n, neck - w * n, start - w * n])  # fmt: skip


def follows_robot(cfg: WorldCfg) -> bool:
    """The view follows the robot: nothing bounds the chase in this scene (no walls)."""
    return not get_scene(cfg.scene.name).walls


def floor_lo_m(cfg: WorldCfg) -> float:
    """Lower edge, on both axes, of the floor square drawn (in view coordinates: world ones
    in a walled scene, world minus the robot's position when the view follows it)."""
    return -0.5 * cfg.arena.size_m if follows_robot(cfg) else 0.0


def view_extent_m(cfg: WorldCfg) -> tuple[float, float]:
    """Lower and upper view coordinate shown on both axes: the floor square (the arena, or
    the window around the robot) plus the text bands."""
    lo = floor_lo_m(cfg)
    return lo - _MARGIN_M - _BAND_M, lo + cfg.arena.size_m + _MARGIN_M + _BAND_M


def pixel_of(
    xy_m: np.ndarray, cfg: WorldCfg, size_px: int, robot_xy_m: np.ndarray | None = None
) -> np.ndarray:
    """(column, row) pixel of world points (..., 2) in a frame of ``size_px``, row 0 on top.

    ``robot_xy_m`` (2,) is the robot's world position in that frame; it is needed (and only
    used) when the view follows the robot (``follows_robot``)."""
    xy = np.asarray(xy_m, float)
    if follows_robot(cfg):
        if robot_xy_m is None:
            raise ValueError(
                f"the {cfg.scene.name} view follows the robot: pass robot_xy_m, the robot's "
                "world position in that frame"
            )
        xy = xy - np.asarray(robot_xy_m, float)
    lo, hi = view_extent_m(cfg)
    frac = (xy - lo) / (hi - lo)
    return np.stack([frac[..., 0] * size_px, (1.0 - frac[..., 1]) * size_px], axis=-1)


def _grid_segments(lo: float, size: float, offset: np.ndarray, spacing: float) -> np.ndarray:
    """Segments (K, 2, 2) of the world-aligned grid lines inside the floor square
    ``[lo, lo + size]^2`` of view coordinates, where view = world - ``offset``."""
    segs = []
    for axis in (0, 1):
        first = np.ceil((lo + offset[axis]) / spacing) * spacing - offset[axis]
        for v in np.arange(first, lo + size, spacing):
            if v <= lo + 1e-9:
                continue
            a, b = np.array([v, lo]), np.array([v, lo + size])
            segs.append([a, b] if axis == 0 else [a[::-1], b[::-1]])
    return np.asarray(segs, float).reshape(-1, 2, 2)


def _footprint(xy: np.ndarray, yaw: float, length: float, width: float) -> np.ndarray:
    """Corners (4, 2) of the base rectangle centred on ``xy`` and rotated by ``yaw``."""
    half = 0.5 * np.array([[length, width], [-length, width], [-length, -width], [length, -width]])
    c, s = np.cos(yaw), np.sin(yaw)
    return xy + half @ np.array([[c, s], [-s, c]])


def trail_rows(cfg: WorldCfg) -> int:
    """Control steps the target's trail spans (``TRAIL_S`` at the control rate)."""
    return max(1, round(TRAIL_S / cfg.episode.dt_s))


class TopDownDrawer:
    """The figure and its moving artists for one world; ``draw`` renders one state.

    Args:
        cfg: the world (scene, arena, base and arm sizes, camera cone, control rate).
        size_px: width and height of each frame in pixels (at least 64).
        with_pred: draw ``pred_vel_mps`` (and its key entry); rows must then carry it.
        with_scan: draw the rays of ``scan_m`` (rows carry it, and ``occluded``:
            ``viz.trajectory.scene_extras``).
        with_blend: draw eq. 10's weight ``blend_w_c`` over time in an inset (``draw``
            then takes its history).

    Obstacles (``obstacle_*`` of a row) are drawn whenever a row has any.

    Where the view follows the robot (``follows_robot(cfg)``) every world point is drawn at
    its offset from the robot, so the static layer stays fixed and only the grid and the
    virtual square move with the other artists.
    """

    def __init__(
        self,
        cfg: WorldCfg,
        size_px: int = 480,
        with_pred: bool = False,
        with_scan: bool = False,
        with_blend: bool = False,
    ):
        if size_px < 64:
            raise ValueError(f"size_px must be at least 64, got {size_px}")
        self.size_px = size_px
        self.with_pred = with_pred
        self.fig = Figure(figsize=(size_px / _DPI, size_px / _DPI), dpi=_DPI)
        self.canvas = FigureCanvasAgg(self.fig)
        self.mount_x = cfg.arm.mount_x_m
        self.base_dims = (cfg.base.length_m, cfg.base.width_m)
        self.half_fov_deg = np.degrees(0.5 * cfg.sensor.fov_rad)
        self.trail_rgb = np.array(to_rgb(TARGET_COLOR))
        self.follow = follows_robot(cfg)
        self.floor_lo = floor_lo_m(cfg)
        self.size_m = cfg.arena.size_m
        pt = size_px / 480.0  # markers and fonts scale with the frame
        ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0))
        arena = self._add_static(ax, cfg, pt, with_pred=with_pred)
        lo, hi = view_extent_m(cfg)
        # On the open plane the grid and the virtual square slide under the robot.
        self.grid = ax.add_collection(
            LineCollection([], color="#dddddd", lw=0.6 * pt, zorder=0.5, visible=self.follow)
        )
        self.grid.set_clip_path(arena)
        self.virtual = ax.add_patch(
            Rectangle((0, 0), self.size_m, self.size_m, fill=False, ec=VIRTUAL_COLOR,
                      ls="--", lw=1.2 * pt, zorder=0.6, visible=self.follow)
        )  # fmt: skip
        self.virtual.set_clip_path(arena)

        self.fov = ax.add_patch(Wedge((0, 0), cfg.sensor.range_m, 0, 0, lw=0, zorder=1))
        self.fov.set_clip_path(arena)  # the camera sees no farther than the walls
        self.reach = ax.add_patch(
            Circle(
                (0, 0),
                cfg.arm.activation_distance_m,
                fill=False,
                ls="--",
                lw=pt,
                ec=ROBOT_COLOR,
                alpha=0.7,
                zorder=2,
            )
        )
        self.trail = ax.add_collection(LineCollection([], lw=2.5 * pt, capstyle="round", zorder=3))
        self.heading = ax.add_patch(Polygon(np.zeros((7, 2)), fc=ROBOT_COLOR, lw=0, zorder=3.5))
        self.body = ax.add_patch(
            Polygon(np.zeros((4, 2)), fc=ROBOT_COLOR, ec="black", lw=0.8 * pt, alpha=0.9, zorder=4)
        )
        (self.arm_line,) = ax.plot([], [], color=GRIPPER_COLOR, lw=1.5 * pt, zorder=5)
        (self.gripper,) = ax.plot([], [], "o", color=GRIPPER_COLOR, ms=4 * pt, zorder=6)
        (self.seen,) = ax.plot(
            [], [], "o", mfc="none", mec=SEEN_COLOR, mew=2 * pt, ms=12 * pt, zorder=6
        )
        self.pred = ax.add_patch(
            Polygon(
                np.zeros((7, 2)),
                fc=PRED_COLOR,
                lw=0,
                alpha=0.9,
                zorder=6,
                visible=with_pred,
            )
        )
        target_ms = max(8 * pt, 2 * cfg.target.radius_m * size_px / (hi - lo))
        (self.target,) = ax.plot(
            [], [], "o", color=TARGET_COLOR, mec="black", mew=0.6 * pt, ms=target_ms, zorder=7
        )
        self.obstacles = ax.add_collection(
            PatchCollection([], fc=OBSTACLE_COLOR, ec="black", lw=0.6 * pt, zorder=2.5)
        )
        self.obstacles.set_clip_path(arena)
        self.scan_cap = cfg.scene.scan_range_m
        self.scan = ax.add_collection(
            LineCollection([], color=SCAN_COLOR, lw=0.8 * pt, zorder=1.5, visible=with_scan)
        )
        self.scan.set_clip_path(arena)
        (self.sightline,) = ax.plot([], [], ":", color=OCCLUDED_COLOR, lw=1.5 * pt, zorder=6.5)
        self.duration_s = float(cfg.episode.duration_s)
        self.blend_ax = self.blend = None
        if with_blend:
            self.blend_ax = self.fig.add_axes((0.68, 0.79, 0.28, 0.09))
            self.blend_ax.set_xlim(0.0, self.duration_s)
            self.blend_ax.set_ylim(0.0, 1.0)
            self.blend_ax.tick_params(labelsize=6 * pt, length=2)
            self.blend_ax.set_title("blend w_c (eq. 10)", fontsize=6.5 * pt, pad=1.5)
            (self.blend,) = self.blend_ax.plot([], [], color=BLEND_COLOR, lw=1.2 * pt)
        self.text = ax.text(
            self.floor_lo,
            self.floor_lo + cfg.arena.size_m + _MARGIN_M + 0.5 * _BAND_M,
            "",
            va="center",
            family="monospace",
            fontsize=8.5 * pt,
            zorder=8,
        )
        # Blitting: the static layer (floor, walls, grid, key) is drawn once and restored
        # before each frame; only the moving artists are drawn again on top of it.
        self.moving = sorted(
            [self.grid, self.virtual, self.fov, self.reach, self.trail, self.heading,
             self.body, self.arm_line, self.gripper, self.seen, self.pred, self.target,
             self.text, self.obstacles, self.scan, self.sightline],
            key=lambda a: a.get_zorder(),
        )  # fmt: skip
        if self.blend is not None:
            self.moving.append(self.blend)
        for artist in self.moving:
            artist.set_animated(True)
        self.canvas.draw()
        self.background = self.canvas.copy_from_bbox(self.fig.bbox)

    @staticmethod
    def _add_static(ax, cfg: WorldCfg, pt: float, with_pred: bool) -> Rectangle:
        """Floor, walls (if the scene has them), a fixed 2 m grid (if the view is fixed) and
        the key; returns the floor patch (for clipping)."""
        size = cfg.arena.size_m
        follow = follows_robot(cfg)
        f0 = floor_lo_m(cfg)
        # A square view: the floor, a band above it for the status line, one below for the key.
        lo, hi = view_extent_m(cfg)
        ax.set_xlim(lo, hi)
        ax.set_ylim(lo, hi)
        ax.set_aspect("equal")
        ax.set_axis_off()
        edge = {"ec": "none", "lw": 0} if follow else {"ec": WALL_COLOR, "lw": 3 * pt}
        arena = ax.add_patch(Rectangle((f0, f0), size, size, fc=FLOOR_COLOR, zorder=0, **edge))
        if not follow:
            for v in np.arange(2.0, size, 2.0):
                ax.plot([v, v], [0, size], color="#dddddd", lw=0.6 * pt, zorder=0.5)
                ax.plot([0, size], [v, v], color="#dddddd", lw=0.6 * pt, zorder=0.5)
        key = [
            Line2D([], [], marker="s", ls="", color=ROBOT_COLOR, label="robot"),
            Line2D([], [], marker="o", ls="", color=TARGET_COLOR, mec="black", label="target"),
            Line2D([], [], marker="o", ls="", mfc="none", mec=SEEN_COLOR, mew=2, label="last seen"),
            Line2D([], [], ls="--", color=ROBOT_COLOR, label="arm reach"),
            Line2D([], [], marker="o", ls="", color=GRIPPER_COLOR, ms=4, label="gripper"),
        ]
        if with_pred:
            key.append(Line2D([], [], color=PRED_COLOR, lw=2, label="pred. vel (1 s)"))
        ax.legend(handles=key, loc="center", bbox_to_anchor=(f0 + 0.5 * size, lo + 0.5 * _BAND_M),
                  bbox_transform=ax.transData, ncol=len(key), frameon=False,
                  fontsize=7.5 * pt, handlelength=1.2, handletextpad=0.4, columnspacing=1.0,
                  borderaxespad=0.0)  # fmt: skip
        return arena

    def _draw_scene(self, row, offset: np.ndarray, xy: np.ndarray, yaw: float, t_xy) -> None:
        """Obstacles, the scan's rays and an occluded target's blocked line of sight."""
        centres = np.asarray(row.get("obstacle_xy_m", np.zeros((0, 2))), float) - offset
        patches = []
        for c, h, r in zip(
            centres, row.get("obstacle_half_m", ()), row.get("obstacle_radius_m", ()), strict=True
        ):
            if np.any(np.asarray(h) > 0):
                patches.append(Rectangle(c - h, 2 * h[0], 2 * h[1]))
            else:
                patches.append(Circle(c, float(r)))
        self.obstacles.set_paths(patches)
        if "scan_m" in row:
            scan = np.asarray(row["scan_m"], float)
            ang = yaw + 2.0 * np.pi * np.arange(scan.size) / scan.size
            ends = xy + scan[:, None] * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
            self.scan.set_segments(np.stack([np.broadcast_to(xy, ends.shape), ends], axis=1))
            hit = scan < self.scan_cap - 1e-6
            self.scan.set_alpha(None)
            rgba = np.tile([*to_rgb(SCAN_COLOR), 0.0], (scan.size, 1))
            rgba[:, 3] = np.where(hit, 0.6, 0.08)
            self.scan.set_color(rgba)
        occluded = bool(row.get("occluded", False))
        self.target.set_markerfacecolor(OCCLUDED_COLOR if occluded else TARGET_COLOR)
        if occluded:
            self.sightline.set_data([xy[0], t_xy[0]], [xy[1], t_xy[1]])
        else:
            self.sightline.set_data([], [])

    def draw(
        self,
        row: Mapping[str, np.ndarray],
        trail_xy_m: np.ndarray | None = None,
        blend_history: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """Render one state; returns (size_px, size_px, 3) uint8.

        Args:
            row: one state's values, keyed as ``viz.trajectory.STATE_KEYS`` (``time_s`` ()
                in s, ``robot_xy_m`` (2,), ``robot_yaw_rad`` (), ``robot_speed_mps`` (),
                ``gripper_xyz_m`` (3,), ``target_xy_m`` (2,), ``target_speed_mps`` (),
                ``obs_xy_m`` (2,), ``visible``, ``ever_seen``, ``success`` () bool), plus
                ``pred_vel_mps`` (2,) in m/s if the drawer was built ``with_pred``.
            trail_xy_m: the target's recent positions (K, 2), oldest first, ending with this
                state's; at most ``trail_rows(cfg) + 1`` are meant to be given. None: no trail.
            blend_history: (times (T,) s, w_c (T,)) up to this state, drawn in the inset of
                a drawer built ``with_blend``.
        """
        robot_world = np.asarray(row["robot_xy_m"], float)
        # View coordinates: world ones, or offsets from the robot where the view follows it.
        offset = robot_world if self.follow else np.zeros(2)
        xy = robot_world - offset
        yaw = float(row["robot_yaw_rad"])
        if self.follow:
            self.grid.set_segments(_grid_segments(self.floor_lo, self.size_m, offset, 2.0))
            self.virtual.set_xy(-offset)
        heading = np.array([np.cos(yaw), np.sin(yaw)])
        yaw_deg = np.degrees(yaw)
        visible = bool(row["visible"])

        self.fov.set_center(xy)
        self.fov.set_theta1(yaw_deg - self.half_fov_deg)
        self.fov.set_theta2(yaw_deg + self.half_fov_deg)
        self.fov.set_facecolor(FOV_SEEN_COLOR if visible else FOV_BLIND_COLOR)
        self.fov.set_alpha(0.16 if visible else 0.12)
        self.reach.set_center(xy)
        self.body.set_xy(_footprint(xy, yaw, *self.base_dims))
        nose = xy + 0.5 * self.base_dims[0] * heading
        self.heading.set_xy(_arrow(nose, _HEADING_LEN_M * heading, 0.05, 0.22))
        grip = np.asarray(row["gripper_xyz_m"], float)[:2] - offset
        mount = xy + self.mount_x * heading
        self.arm_line.set_data([mount[0], grip[0]], [mount[1], grip[1]])
        self.gripper.set_data([grip[0]], [grip[1]])

        t_xy = np.asarray(row["target_xy_m"], float) - offset
        self.target.set_data([t_xy[0]], [t_xy[1]])
        pts = np.zeros((0, 2)) if trail_xy_m is None else np.asarray(trail_xy_m, float) - offset
        segments = np.stack([pts[:-1], pts[1:]], axis=1) if len(pts) > 1 else np.zeros((0, 2, 2))
        alpha = np.linspace(0.05, 0.8, len(segments))
        self.trail.set_segments(segments)
        self.trail.set_color(np.column_stack([np.tile(self.trail_rgb, (len(segments), 1)), alpha]))
        if row["ever_seen"]:
            seen = np.asarray(row["obs_xy_m"], float) - offset
            self.seen.set_data([seen[0]], [seen[1]])
        else:
            self.seen.set_data([], [])
        if self.with_pred:  # drawn as the displacement over one second
            self.pred.set_xy(_arrow(t_xy, np.asarray(row["pred_vel_mps"], float), 0.06, 0.22))

        self._draw_scene(row, offset, xy, yaw, t_xy)
        if self.blend is not None and blend_history is not None:
            self.blend.set_data(*blend_history)

        caught = bool(row["success"])
        occluded = bool(row.get("occluded", False))
        status = "CAUGHT" if caught else ("in view" if visible else "out of view")
        status = "occluded" if occluded and not caught and not visible else status
        self.text.set_color(CAUGHT_COLOR if caught else "black")
        self.text.set_text(
            f"t {float(row['time_s']):5.2f} s | target {float(row['target_speed_mps']):.2f} m/s | "
            f"robot {float(row['robot_speed_mps']):.2f} m/s | {status}"
        )
        self.canvas.restore_region(self.background)
        for artist in self.moving:
            self.fig.draw_artist(artist)
        frame = np.asarray(self.canvas.buffer_rgba())[..., :3].copy()
        if frame.shape[:2] != (self.size_px, self.size_px):
            raise RuntimeError(f"Agg drew {frame.shape[:2]} pixels, expected {self.size_px}")
        return frame


def frame_rows(num_rows: int, every: int) -> list[int]:
    """Row indices drawn: every ``every``-th row, always including the last one."""
    if every < 1:
        raise ValueError(f"every must be at least 1, got {every}")
    rows = list(range(0, num_rows, every))
    if rows and rows[-1] != num_rows - 1:
        rows.append(num_rows - 1)
    return rows


def render_frames(
    traj: dict[str, np.ndarray], cfg: WorldCfg, every: int = 2, size_px: int = 480
) -> list[np.ndarray]:
    """Top-down frames of a trajectory from ``record_episode``.

    Draws every ``every``-th row (and the last). Each frame is ``(size_px, size_px, 3)``
    uint8 showing the arena (or, where the view follows the robot, a window of the arena's
    size around it with the virtual square dashed), the robot footprint and heading, the
    camera cone (green while the last frame saw the target), the arm's activation circle,
    the gripper, the target and its last 2 s, the held sighting (hollow ring),
    ``pred_vel_mps`` if recorded (an arrow of one second of motion) and a status line;
    in a scene with obstacles (``record_episode(..., extra_fn=scene_extras(...))``) also
    the obstacles, the range scan's rays, the occluded target in grey with its blocked line
    of sight dotted, and eq. 10's weight w_c over time in an inset.
    """
    blend = "blend_w_c" in traj
    drawer = TopDownDrawer(
        cfg, size_px, with_pred="pred_vel_mps" in traj, with_scan="scan_m" in traj, with_blend=blend
    )
    span = trail_rows(cfg)
    frames = []
    for i in frame_rows(len(traj["time_s"]), every):
        row = {name: values[i] for name, values in traj.items()}
        history = (traj["time_s"][: i + 1], traj["blend_w_c"][: i + 1]) if blend else None
        frames.append(drawer.draw(row, traj["target_xy_m"][max(0, i - span) : i + 1], history))
    return frames
