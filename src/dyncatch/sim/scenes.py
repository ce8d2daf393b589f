"""Scenes by name: where the chase happens. A new scene is one ``Scene`` and one line here.

Every scene has the square region of ``ArenaCfg`` (side ``size_m``, lower-left corner at the
world origin): episodes start inside it, the circle target circles its centre, and the bounce
target reflects off its sides. In ``arena`` and the rooms its sides are walls that also stop
the robot and the other targets; on the ``open_plane`` and in the woods (the paper's Table I
setting and its outdoor scenes) nothing but trees stops either body and the square is only
the bounce target's virtual boundary. The rooms and the woods draw an obstacle layout per
episode (``sim.layouts``); the woods' terrains act on the gait (``sim.terrain``).
docs/scenes.md gives every constant.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from operator import attrgetter
from typing import TYPE_CHECKING

import jax

from dyncatch.sim.layouts import room_checks, room_layout, woods_checks, woods_layout
from dyncatch.sim.obstacles import Obstacles
from dyncatch.sim.terrain import terrain_checks
from dyncatch.utils.cli_types import live_name

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg
    from dyncatch.sim.scene_cfg import TerrainCfg

LayoutFn = Callable[[jax.Array, "WorldCfg"], Obstacles]
"""(key, world) -> this episode's obstacles, in world coordinates."""
TerrainFn = Callable[["WorldCfg"], "TerrainCfg"]
"""world -> the terrain's constants (a field of ``WorldCfg``)."""
Check = tuple[bool, str, str]
"""(ok, dotted field name, what is wrong and what to do), as ``sim.validate`` reports it."""


CLUTTERED_DURATION_S = 40.0
"""The paper's episode length in the rooms and the woods (Fig. 9)."""
CLUTTERED_SCAN_RAYS = 32
"""The range scan's rays in the rooms and the woods (pi_collid's scan)."""


def _no_checks(world: WorldCfg) -> list[Check]:
    del world
    return []


@dataclass(frozen=True)
class Scene:
    name: str
    doc: str
    walls: bool
    """The square's sides are walls: they stop the robot and the target and the range scan
    sees them."""
    layout: LayoutFn | None = None
    """Draws the episode's obstacles (a fixed number per scene); None: no obstacles."""
    terrain: TerrainFn | None = None
    """The terrain's gait constants; None: flat ground (``BaseCfg`` as it is)."""
    duration_s: float = 20.0
    """The paper's episode length here (20 s on the open plane, ``CLUTTERED_DURATION_S`` in
    rooms and woods); ``WorldCfg.for_scene`` applies it, ``--scene`` alone does not
    (docs/scenes.md)."""
    scan_rays: int | None = None
    """Rays of the range scan suggested here (None: the world's default,
    ``SceneCfg.scan_rays``); applied as ``duration_s``."""
    validate: Callable[[WorldCfg], list[Check]] = _no_checks
    """Checks of the scene's own constants (layout, terrain); ``validate_world`` runs them
    for the active scene."""


def _woods_validate(terrain_field: str | None) -> Callable[[WorldCfg], list[Check]]:
    def checks(world: WorldCfg) -> list[Check]:

        out = woods_checks(world)
        if terrain_field is not None:
            out += terrain_checks(getattr(world, terrain_field), terrain_field)
        return out

    return checks


def _room(count: int, name: str) -> Scene:
    return Scene(
        name,
        f"a walled room (the 16 m square) with {count} box or cylinder obstacles placed at "
        "random each episode",
        walls=True,
        layout=partial(room_layout, count=count),
        duration_s=CLUTTERED_DURATION_S,
        scan_rays=CLUTTERED_SCAN_RAYS,
        validate=partial(room_checks, count=count),
    )


def _woods(terrain_field: str | None, name: str, ground: str) -> Scene:
    """Woods whose ground is the ``TerrainCfg`` field ``terrain_field`` of ``WorldCfg``
    (None: flat)."""
    return Scene(
        name,
        f"unbounded woods, tree trunks at 0.04 per m^2 on {ground}",
        walls=False,
        layout=woods_layout,
        terrain=None if terrain_field is None else attrgetter(terrain_field),
        duration_s=CLUTTERED_DURATION_S,
        scan_rays=CLUTTERED_SCAN_RAYS,
        validate=_woods_validate(terrain_field),
    )


SCENES: dict[str, Scene] = {
    s.name: s
    for s in (
        Scene(
            "arena",
            "a walled 16 m square: walls stop the robot and the target",
            walls=True,
        ),
        Scene(
            "open_plane",
            "the paper's open plane: nothing stops either body; the bounce target reflects off "
            "a virtual 16 m square",
            walls=False,
        ),
        _room(0, "room_0"),
        _room(4, "room_4"),
        _room(8, "room_8"),
        _woods(None, "woods_plane", "flat ground"),
        _woods("rough", "woods_rough", "rough ground (slower, noisier gait)"),
        _woods("stairs", "woods_stairs", "stairs climbing along world x"),
    )
}

SceneName = live_name(lambda: tuple(SCENES), "SCENE", aliases=("--scene",))
"""A key of ``SCENES``; ``--scene`` on the command line (an alias of ``--world.scene.name``
on every command holding one world)."""


def get_scene(name: str) -> Scene:
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}: choose one of {', '.join(SCENES)}")
    return SCENES[name]
