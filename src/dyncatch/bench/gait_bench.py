"""Step responses and fall rate of the full-body gait (``dyncatch bench gait``).

Every number comes from simulating ``FullBodyEnv`` (``dyncatch.fullbody``) under commands:

* ``max_forward_mps``: the largest forward command, on ``forward_grid_mps``, whose step
  response settles (mean over the last ``measure_s`` of ``step_s``) within ``tolerance`` of
  the command without a fall; the value is that response's measured mean speed.
* ``max_yaw_rate_rps``: the same on ``yaw_grid_rps`` for pure yaw-rate commands.
* ``yaw_rate_at_max_forward_rps``: commanding that forward speed and each yaw rate of the
  grid together, the largest measured mean yaw rate tracked within ``tolerance`` (the
  forward speed is not judged: turning at speed, the base slows down, see docs/fullbody.md).
* ``lag_s``: from standing, a ``lag_step_mps`` forward step; the time until the forward
  speed first reaches 63.2 % of its settled mean (a first-order model's time constant).
* ``fall_rate``: the fraction of ``episodes`` of ``episode_s`` under random piecewise-constant
  commands, uniform over the reduced base's command box (``BaseCfg``: forward up to
  ``max_forward_mps``, backward ``max_backward_mps``, sideways ``max_lateral_mps``, yaw rate
  ``max_yaw_rate_rps``; what a catch policy may send), each held U(``hold_min_s``,
  ``hold_max_s``), in which the robot falls (``FullBodyEnv.fallen``).
"""

from __future__ import annotations

import dataclasses
import time

import numpy as np

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.sim.config import BaseCfg


@dataclasses.dataclass(frozen=True)
class GaitBenchCfg:
    """What the gait benchmark commands and how it judges tracking."""

    forward_grid_mps: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 2.5)
    """Forward step commands tried for ``max_forward_mps``."""
    yaw_grid_rps: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0, 2.5)
    """Yaw-rate step commands tried for ``max_yaw_rate_rps`` and the turn at speed."""
    step_s: float = 5.0
    """Duration of one step response."""
    measure_s: float = 2.5
    """The settled value is the mean over the step response's last this many seconds."""
    tolerance: float = 0.10
    """A response tracks its command when the settled value is within this fraction of it."""
    lag_step_mps: float = 1.0
    """Forward step (from standing) whose rise gives ``lag_s``."""
    episodes: int = 20
    """Random-command episodes for ``fall_rate``."""
    episode_s: float = 20.0
    """Length of one episode (the catch task's episode length)."""
    hold_min_s: float = 1.0
    """Shortest time one random command is held."""
    hold_max_s: float = 3.0
    """Longest time one random command is held."""
    seed: int = 0
    """Seed of the random commands."""


def validate_gait_bench(cfg: GaitBenchCfg) -> GaitBenchCfg:
    if cfg.measure_s <= 0 or cfg.measure_s >= cfg.step_s:
        raise ValueError(f"measure_s={cfg.measure_s} must lie in (0, step_s={cfg.step_s})")
    if cfg.episodes < 0:
        raise ValueError(f"episodes={cfg.episodes} must be >= 0")
    if not 0 < cfg.hold_min_s <= cfg.hold_max_s:
        raise ValueError("need 0 < hold_min_s <= hold_max_s")
    if not cfg.forward_grid_mps or not cfg.yaw_grid_rps:
        raise ValueError("forward_grid_mps and yaw_grid_rps need at least one value each")
    return cfg


def step_response(env, cmd: np.ndarray, duration_s: float) -> tuple[np.ndarray, bool]:
    """From standing, hold ``cmd`` (3,) for ``duration_s``: ``(velocities (T, 3), fell)``.

    Velocities are (forward, left, yaw rate) in the heading frame, one row per control step;
    the run stops at a fall.
    """
    env.reset()
    rows = []
    for _ in range(round(duration_s * env.cfg.control_hz)):
        env.step(cmd)
        rows.append(env.base_velocity_heading())
        if env.fallen():
            return np.array(rows), True
    return np.array(rows), False


def _settled(env, vel: np.ndarray, cfg: GaitBenchCfg) -> np.ndarray:
    return vel[-round(cfg.measure_s * env.cfg.control_hz) :].mean(axis=0)


def _tracks(value: float, command: float, tol: float) -> bool:
    return abs(value - command) <= tol * abs(command)


def largest_tracked(env, cmds: list[np.ndarray], axis: int, cfg: GaitBenchCfg) -> tuple[float, int]:
    """Largest settled value on ``axis`` over ``cmds`` tracked within tolerance without a
    fall: ``(value, index of its command)``; ``(0.0, -1)`` if none is."""
    best, best_i = 0.0, -1
    for i, cmd in enumerate(cmds):
        vel, fell = step_response(env, cmd, cfg.step_s)
        if fell:
            continue
        value = float(_settled(env, vel, cfg)[axis])
        if _tracks(value, float(cmd[axis]), cfg.tolerance) and abs(value) > abs(best):
            best, best_i = value, i
    return best, best_i


def lag_time_s(env, cfg: GaitBenchCfg) -> float:
    """63.2 % rise time of the forward speed after a ``lag_step_mps`` step from standing."""
    vel, fell = step_response(env, np.array([cfg.lag_step_mps, 0.0, 0.0]), cfg.step_s)
    if fell:
        return float("nan")
    final = _settled(env, vel, cfg)[0]
    above = np.flatnonzero(vel[:, 0] >= 0.632 * final)
    return float((above[0] + 1) / env.cfg.control_hz) if len(above) else float("nan")


def random_commands(
    rng: np.random.Generator, cfg: GaitBenchCfg, base: BaseCfg, control_hz: float
) -> np.ndarray:
    """(T, 3) piecewise-constant commands for one episode, uniform in ``base``'s box."""
    steps = round(cfg.episode_s * control_hz)
    out = np.zeros((steps, 3))
    t = 0
    while t < steps:
        hold = round(rng.uniform(cfg.hold_min_s, cfg.hold_max_s) * control_hz)
        out[t : t + hold] = (
            rng.uniform(-base.max_backward_mps, base.max_forward_mps),
            rng.uniform(-base.max_lateral_mps, base.max_lateral_mps),
            rng.uniform(-base.max_yaw_rate_rps, base.max_yaw_rate_rps),
        )
        t += hold
    return out


def fall_rate(env, cfg: GaitBenchCfg) -> float:
    """Fraction of random-command episodes that end in a fall (nan for zero episodes)."""
    if cfg.episodes == 0:
        return float("nan")
    rng = np.random.default_rng(cfg.seed)
    falls = 0
    for _ in range(cfg.episodes):
        env.reset(yaw_rad=float(rng.uniform(-np.pi, np.pi)))
        for cmd in random_commands(rng, cfg, env.cfg.base, env.cfg.control_hz):
            env.step(cmd)
            if env.fallen():
                falls += 1
                break
    return falls / cfg.episodes


def run_gait_benchmark(cfg: GaitBenchCfg, world: FullBodyCfg | None = None) -> dict:
    """Every figure of the module docstring, plus the wall time, as one JSON-able dict."""
    # Imported here: fullbody.env needs MuJoCo, an optional dependency (the fullbody extra).
    from dyncatch.fullbody.env import FullBodyEnv

    world = FullBodyCfg() if world is None else world

    validate_gait_bench(cfg)
    t0 = time.perf_counter()
    env = FullBodyEnv(world)
    fwd_cmds = [np.array([v, 0.0, 0.0]) for v in cfg.forward_grid_mps]
    max_fwd, i_fwd = largest_tracked(env, fwd_cmds, 0, cfg)
    max_yaw, _ = largest_tracked(env, [np.array([0.0, 0.0, w]) for w in cfg.yaw_grid_rps], 2, cfg)
    fwd_cmd = cfg.forward_grid_mps[i_fwd] if i_fwd >= 0 else 0.0
    turn_cmds = [np.array([fwd_cmd, 0.0, w]) for w in cfg.yaw_grid_rps]
    yaw_at_fwd, _ = largest_tracked(env, turn_cmds, 2, cfg)
    return {
        "max_forward_mps": round(max_fwd, 3),
        "max_yaw_rate_rps": round(max_yaw, 3),
        "yaw_rate_at_max_forward_rps": round(yaw_at_fwd, 3),
        "lag_s": round(lag_time_s(env, cfg), 3),
        "fall_rate": fall_rate(env, cfg),
        "episodes": cfg.episodes,
        "wall_s": round(time.perf_counter() - t0, 1),
    }
