"""Scenes by name: where the chase happens. A new scene is one ``Scene`` and one line here.

Every scene has the square region of ``ArenaCfg`` (side ``size_m``, lower-left corner at the
world origin): episodes start inside it, the circle target circles its centre, and the bounce
target reflects off its sides. In ``arena`` its sides are walls that also stop the robot and
the other targets; on the ``open_plane`` (the paper's Table I setting) nothing stops either
body and the square is only the bounce target's virtual boundary.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Scene:
    name: str
    doc: str
    walls: bool
    """The square's sides are walls: they stop the robot and the target and the range scan
    sees them."""


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
    )
}


def get_scene(name: str) -> Scene:
    if name not in SCENES:
        raise ValueError(f"unknown scene {name!r}: choose one of {', '.join(SCENES)}")
    return SCENES[name]
