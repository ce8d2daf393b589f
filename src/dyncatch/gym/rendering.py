"""``render_mode="rgb_array"`` of the Gymnasium adapters: the top-down drawing of the
current state (``viz.render.TopDownDrawer``), one frame per control step.

Every step is drawable, so ``metadata["render_fps"]`` is the control rate (50 Hz by
default) and a video of one frame per step plays in real time; there is no frame skip.
"""

from __future__ import annotations

from collections import deque

import jax
import numpy as np

from dyncatch.policies.blend import reads_nothing
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import observe
from dyncatch.viz.trajectory import scene_extras, state_row

RENDER_MODES = ["rgb_array"]
"""The render modes both adapters offer."""

_state_row = jax.jit(state_row)


def check_render_mode(render_mode: str | None) -> None:
    """Raise ValueError naming the supported modes for any other than None or those."""
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise ValueError(
            f"render_mode {render_mode!r} is not supported; use None or one of {RENDER_MODES}"
        )


def render_metadata(world: WorldCfg) -> dict:
    """``render_modes`` and ``render_fps`` (frames per second = the control rate, Hz)."""
    return {"render_modes": list(RENDER_MODES), "render_fps": world.episode.control_hz}


def _row_fns(world: WorldCfg):
    """(one state -> row, batched state -> rows): the drawn values; in a scene whose scan
    can read something, also the range scan and occluded sightings (``scene_extras``), as
    the reproduction's videos draw them."""

    if reads_nothing(world):
        return _state_row, _state_row

    extras = scene_extras(world)

    def row(state):
        return {**state_row(state), **extras(state, observe(state, world))}

    return jax.jit(row), jax.jit(jax.vmap(row))


class StateFrames:
    """Draws an adapter's current state, one environment or a batch.

    Remembers the target's positions since the episode began (at most the trail's span),
    so the trail is right however rarely ``render`` is called; ``reset`` and ``step`` of the
    adapter call ``start`` and ``push``. matplotlib is imported at the first frame.

    Args:
        world: the world drawn (arena, base, arm, camera); ``set_world`` changes it.
        size_px: width and height of each frame in pixels.
    """

    def __init__(self, world: WorldCfg, size_px: int):
        if size_px < 64:
            raise ValueError(f"render_size_px must be at least 64, got {size_px}")
        self.size_px = size_px
        self.world: WorldCfg | None = None
        self._drawer = None
        self.set_world(world)

    def set_world(self, world: WorldCfg) -> None:
        """Draw ``world`` from now on (the figure is rebuilt at the next frame if it changed)."""
        # Imported here (and in _draw): viz.render loads matplotlib, which an env that is
        # never rendered does not need.
        from dyncatch.viz.render import trail_rows

        if world != self.world:
            self._drawer = None
            self._row, self._rows = _row_fns(world)
        self.world = world
        self.span = trail_rows(world)
        self._trail: deque[tuple[jax.Array, jax.Array]] = deque(maxlen=self.span + 1)

    def start(self, state) -> None:
        """A new episode (every environment of a batch) begins with ``state``."""
        self._trail.clear()
        self.push(state)

    def push(self, state) -> None:
        """Remember the target position of ``state``: (2,), or (num_envs, 2) for a batch."""
        # References to the device arrays only: no computation and no transfer to the host
        # until a frame is drawn, so a step with rendering on costs what one without does.
        self._trail.append((state.target.xy_m, state.origin_xy_m))

    def _trail_xy(self) -> np.ndarray:
        """(K, 2) or (K, num_envs, 2) float64: the remembered target positions in the scene
        frame, as the drawn rows are (stored positions are relative to the robot,
        ``sim.frame.to_scene``); the float32 sum is the one the device would round."""
        pairs = jax.device_get(list(self._trail))
        return np.stack([(xy + origin).astype(np.float64) for xy, origin in pairs])

    def _draw(self, row: dict, trail: np.ndarray) -> np.ndarray:
        if self._drawer is None:
            from dyncatch.viz.render import TopDownDrawer  # matplotlib: see set_world

            with_scan = self._row is not _state_row  # the row carries the scan
            self._drawer = TopDownDrawer(self.world, self.size_px, with_scan=with_scan)
        row["time_s"] = float(row["step"]) * self.world.episode.dt_s
        # The positions of this episode only: after an auto-reset the older ones are another's.
        keep = min(int(row["step"]), self.span) + 1
        return self._drawer.draw(row, trail[-keep:])

    def frame(self, state) -> np.ndarray:
        """(size_px, size_px, 3) uint8 of one environment's state."""
        row = jax.device_get(self._row(state))
        return self._draw(row, self._trail_xy())

    def frames(self, state) -> tuple[np.ndarray, ...]:
        """One (size_px, size_px, 3) uint8 frame per environment of a batched state."""
        rows = jax.device_get(self._rows(state))
        trail = self._trail_xy()  # (K, num_envs, 2)
        num_envs = len(rows["step"])
        return tuple(
            self._draw({k: v[i] for k, v in rows.items()}, trail[:, i]) for i in range(num_envs)
        )
