"""``dyncatch render``: play one episode and write it as a top-down GIF or MP4."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from dyncatch.policies.registry import BASELINES
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world
from dyncatch.viz.render import VIDEO_SUFFIXES, render_frames, write_video
from dyncatch.viz.trajectory import catch_time_s, record_episode

PolicyFactory = Callable[[WorldCfg], Callable]

POLICIES: dict[str, PolicyFactory] = dict(BASELINES)
"""Policy name -> ``factory(world) -> policy`` (see dyncatch.policies.api); later layers add
theirs."""


@dataclasses.dataclass(frozen=True)
class RenderCmd:
    """Play one episode of a policy against a target and write a top-down video of it."""

    policy: str = "pursuit"
    """Policy to run, a key of dyncatch.cli.render.POLICIES."""
    speed_mps: float = 1.2
    """Target speed, fixed for the episode; overrides world.target.speed_min/max_mps."""
    seed: int = 0
    """PRNG seed of the episode (initial placement, noise, policy sampling)."""
    out: Path = Path("catch.gif")
    """Output file, .gif or .mp4; its folder is created."""
    fps: int = 25
    """Frames per second of the video (25 with every=2 plays in real time at 50 Hz)."""
    every: int = 2
    """Draw every n-th control step."""
    size_px: int = 480
    """Width and height of the video in pixels."""
    world: WorldCfg = WorldCfg()
    """The simulated world, its target behaviour included (``--behavior``); any model
    constant can be overridden here."""


def resolve(cmd: RenderCmd) -> tuple[WorldCfg, Callable]:
    """The validated world and the policy a command asks for; ValueError names the choices."""

    if cmd.policy not in POLICIES:
        raise ValueError(f"unknown policy {cmd.policy!r}; choose one of {', '.join(POLICIES)}")
    if cmd.out.suffix.lower() not in VIDEO_SUFFIXES:
        raise ValueError(f"--out {cmd.out}: use one of the suffixes {', '.join(VIDEO_SUFFIXES)}")
    if cmd.fps < 1 or cmd.every < 1:
        raise ValueError(f"--fps and --every must be at least 1, got {cmd.fps} and {cmd.every}")
    world = validate_world(cmd.world.with_speed(cmd.speed_mps))
    return world, POLICIES[cmd.policy](world)


def run_render(cmd: RenderCmd) -> Path:
    """Record, draw and write one episode; prints a one-line summary and returns the path."""
    import jax

    world, policy = resolve(cmd)
    traj = record_episode(policy, jax.random.PRNGKey(cmd.seed), world)
    frames = render_frames(traj, world, every=cmd.every, size_px=cmd.size_px)
    path = write_video(frames, cmd.out, cmd.fps)
    caught = catch_time_s(traj)
    outcome = (
        f"caught at {caught:.2f} s"
        if caught is not None
        else f"not caught in {traj['time_s'][-1]:.2f} s"
    )
    print(
        f"{path}: {len(frames)} frames, {cmd.policy} vs {world.target.behavior} at "
        f"{cmd.speed_mps} m/s, {outcome}"
    )
    return path
