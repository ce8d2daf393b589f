"""The scene pictures of docs/scenes.md: one frame per scene, the pursuit baseline with
eq. 10's blend chasing a reactive target (seed 0), at the catch or 8 s in.

    python benchmarks/scene_pictures.py      # writes docs/img/scenes/<scene>.png
"""

from pathlib import Path

import jax
import matplotlib.image

from dyncatch.policies.blend import blended
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SCENES
from dyncatch.viz.render import render_frames
from dyncatch.viz.trajectory import record_episode, scene_extras

OUT = Path(__file__).resolve().parents[1] / "docs" / "img" / "scenes"
AT_S = 8.0


def main() -> None:
    for name, scene in SCENES.items():
        if scene.layout is None and name != "room_0":
            continue
        world = WorldCfg().for_scene(name).with_behavior("reactive")
        policy = blended(pursuit_policy(world), world)
        steps = round(AT_S * world.episode.control_hz)
        traj = record_episode(
            policy,
            jax.random.key(0),
            world,
            max_steps=steps,
            extra_fn=scene_extras(world, policy.cfg),
        )
        frame = render_frames(traj, world, every=len(traj["time_s"]), size_px=360)[-1]
        matplotlib.image.imsave(OUT / f"{name}.png", frame)
        print(name, OUT / f"{name}.png")


if __name__ == "__main__":
    main()
