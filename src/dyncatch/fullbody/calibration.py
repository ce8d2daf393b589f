"""Calibrate the reduced-order base (``BaseCfg``) against the full-body gait's step responses.

The procedure (``benchmarks/calibrate_base.py`` runs it, ``docs/fullbody.md`` reports it):

1. **Step responses of the full body.** From standing, each command of ``CalibrationCfg``
   (forward, backward, sideways, yaw rate, and forward speed with a yaw rate: turning at
   speed) is held for ``hold_s`` and then set to zero for ``stop_s``; the heading-frame
   velocity (forward, left, yaw rate) is sampled every 200 Hz control step.
2. **Limits, read off.** Per axis, the largest command whose settled response (mean over the
   last ``measure_s`` of the hold) is within ``tolerance`` of it: its settled value is the
   limit (as ``dyncatch bench gait`` reads its top speeds). A limit at the grid's largest
   command is a lower bound (``at_grid_max``).
3. **Turning at speed, read off.** The largest settled centripetal acceleration
   |v| |yaw rate| over the turn responses is ``max_lateral_accel_mps2``; the largest settled
   ground speed over the diagonal responses (forward and left held together) is
   ``max_speed_mps``.
4. **Lag and accelerations, least squares on a grid.** With the limits of 2-3 set, the
   reduced base (``sim.base.base_substep``, the code the JAX world runs, without noise)
   replays every straight response's commands; the cost is the mean squared velocity
   error, each response's error divided by its command's size (so m/s and rad/s weigh
   alike). ``lag_s`` is shared by all axes (``BaseCfg`` has one), so for every lag of the
   grid the best linear and yaw accelerations are found apart and the lag with the least
   summed cost wins: an exhaustive grid, with no solver to trust and its optimum plain
   to see in the grid's resolution.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim.base import base_substep, clip_command
from dyncatch.sim.config import ArenaCfg, BaseCfg
from dyncatch.sim.state import RobotState


@dataclasses.dataclass(frozen=True)
class CalibrationCfg:
    """The step responses the calibration commands and the grids it fits over."""

    forward_mps: tuple[float, ...] = (1.0, 2.0, 2.5, 3.0)
    """Forward step commands (the largest tracked gives ``max_forward_mps``)."""
    backward_mps: tuple[float, ...] = (1.0, 1.5, 2.0)
    """Backward step commands, magnitudes (``max_backward_mps``)."""
    lateral_mps: tuple[float, ...] = (0.5, 1.0, 1.5, 2.0)
    """Leftward step commands (``max_lateral_mps``; the gait is left-right symmetric)."""
    yaw_rps: tuple[float, ...] = (1.0, 2.0, 2.5, 3.0)
    """Yaw-rate step commands (``max_yaw_rate_rps``)."""
    turns: tuple[tuple[float, float], ...] = ((1.0, 2.0), (1.5, 2.0), (2.0, 2.0))
    """(forward m/s, yaw rate rad/s) commands held together (``max_lateral_accel_mps2``)."""
    diagonals: tuple[tuple[float, float], ...] = ((1.0, 1.0), (1.5, 1.0), (1.75, 1.0), (2.0, 1.0))
    """(forward m/s, left m/s) commands held together (``max_speed_mps``, the ground speed
    on the diagonal; the last is the default box's corner)."""
    hold_s: float = 3.0
    """How long each command is held, from standing."""
    stop_s: float = 1.5
    """Then a zero command for this long (the braking response)."""
    measure_s: float = 1.5
    """The settled value is the mean over the hold's last this many seconds."""
    tolerance: float = 0.10
    """A response tracks its command when its settled value is within this fraction."""
    lag_grid_s: tuple[float, float, float] = (0.02, 0.40, 0.01)
    """(first, last, step) of the lags tried."""
    lin_accel_grid_mps2: tuple[float, float, float] = (1.0, 8.0, 0.25)
    """(first, last, step) of the linear accelerations tried."""
    yaw_accel_grid_rps2: tuple[float, float, float] = (2.0, 20.0, 0.5)
    """(first, last, step) of the yaw accelerations tried."""


def grid(spec: tuple[float, float, float]) -> np.ndarray:
    """The values ``first, first + step, ..., last`` of a ``(first, last, step)`` spec."""
    first, last, step = spec
    return first + step * np.arange(round((last - first) / step) + 1)


@dataclasses.dataclass(frozen=True)
class Response:
    """One step response: what was commanded and what the base did, both (T, 3) at 200 Hz
    (forward m/s, left m/s, yaw rate rad/s); ``kind`` is forward, backward, lateral, yaw,
    turn or diagonal."""

    kind: str
    command: tuple[float, float, float]
    commands: np.ndarray
    velocity: np.ndarray
    fell: bool


def step_commands(cmd: tuple[float, float, float], cfg: CalibrationCfg, hz: float) -> np.ndarray:
    """(T, 3) the command held for ``hold_s``, then zero for ``stop_s``."""
    hold, stop = round(cfg.hold_s * hz), round(cfg.stop_s * hz)
    return np.concatenate([np.tile(cmd, (hold, 1)), np.zeros((stop, 3))])


def calibration_commands(cfg: CalibrationCfg) -> list[tuple[str, tuple[float, float, float]]]:
    """``(kind, (forward, left, yaw rate))`` of every response the calibration runs."""
    out = [("forward", (v, 0.0, 0.0)) for v in cfg.forward_mps]
    out += [("backward", (-v, 0.0, 0.0)) for v in cfg.backward_mps]
    out += [("lateral", (0.0, v, 0.0)) for v in cfg.lateral_mps]
    out += [("yaw", (0.0, 0.0, w)) for w in cfg.yaw_rps]
    out += [("turn", (v, 0.0, w)) for v, w in cfg.turns]
    out += [("diagonal", (v, u, 0.0)) for v, u in cfg.diagonals]
    return out


def fullbody_responses(env, cfg: CalibrationCfg) -> list[Response]:
    """Every response of ``calibration_commands`` on a ``FullBodyEnv`` (from standing,
    heading 0); a response stops at a fall."""
    out = []
    for kind, cmd in calibration_commands(cfg):
        cmds = step_commands(cmd, cfg, env.cfg.control_hz)
        env.reset()
        vel, fell = [], False
        for c in cmds:
            env.step(c)
            vel.append(env.base_velocity_heading())
            if env.fallen():
                fell = True
                break
        out.append(Response(kind, cmd, cmds[: len(vel)], np.array(vel), fell))
    return out


_AXIS = {"forward": 0, "backward": 0, "lateral": 1, "yaw": 2}
_LIMIT_FIELD = {
    "forward": "max_forward_mps",
    "backward": "max_backward_mps",
    "lateral": "max_lateral_mps",
    "yaw": "max_yaw_rate_rps",
}


def settled(r: Response, cfg: CalibrationCfg, hz: float) -> np.ndarray:
    """(3,) mean velocity over the hold's last ``measure_s`` (nan after a fall)."""
    hold = round(cfg.hold_s * hz)
    if r.fell and len(r.velocity) < hold:
        return np.full(3, np.nan)
    return r.velocity[hold - round(cfg.measure_s * hz) : hold].mean(axis=0)


def read_limits(responses: list[Response], cfg: CalibrationCfg, hz: float) -> dict:
    """Step 2 and 3 of the procedure: ``{field: (value, at_grid_max)}`` for the four command
    limits, and the values of ``max_lateral_accel_mps2`` and ``max_speed_mps`` (the largest
    settled ground speed, the norm of forward and left, over the diagonal responses: the
    body's top speed where the box's corner drives it, saturated as the turns' is)."""
    limits = {}
    for kind, field in _LIMIT_FIELD.items():
        mine = [r for r in responses if r.kind == kind]
        best, at_max = 0.0, False
        for i, r in enumerate(mine):
            ax, c = _AXIS[kind], r.command[_AXIS[kind]]
            v = settled(r, cfg, hz)[ax]
            if not r.fell and abs(v - c) <= cfg.tolerance * abs(c) and abs(v) > best:
                best, at_max = abs(float(v)), i == len(mine) - 1
        limits[field] = (round(best, 3), at_max)
    turns = [settled(r, cfg, hz) for r in responses if r.kind == "turn" and not r.fell]
    accel = max((float(np.hypot(s[0], s[1]) * abs(s[2])) for s in turns), default=np.nan)
    limits["max_lateral_accel_mps2"] = (round(accel, 3), False)
    diagonals = [settled(r, cfg, hz) for r in responses if r.kind == "diagonal" and not r.fell]
    if any(r.kind == "diagonal" for r in responses):
        speed = max((float(np.hypot(s[0], s[1])) for s in diagonals), default=np.nan)
        limits["max_speed_mps"] = (round(speed, 3), False)
    return limits


def reduced_response(commands: jax.Array, base: BaseCfg, dt_s: float) -> jax.Array:
    """(T, 3) velocities of the reduced base from rest under ``commands`` (T, 3), clipped to
    ``base``'s limits as the JAX world clips actions; no gait noise, no walls."""

    robot = RobotState(
        xy_m=jnp.zeros(2),
        yaw_rad=jnp.zeros(()),
        vel_body_mps=jnp.zeros(2),
        yaw_rate_rps=jnp.zeros(()),
        arm_q_rad=jnp.zeros(6),
        gripper_xyz_m=jnp.zeros(3),
    )

    def body(robot, cmd):
        robot = base_substep(
            robot, clip_command(cmd, base), base, ArenaCfg(), jnp.zeros(2), dt_s, False
        )
        return robot, jnp.concatenate([robot.vel_body_mps, robot.yaw_rate_rps[None]])

    return jax.lax.scan(body, robot, commands)[1]


def _costs(base_grid: BaseCfg, commands: jax.Array, target: jax.Array, scale: jax.Array, dt_s):
    """(G,) summed normalised squared error of G configs over R responses (R, T, 3)."""

    def one(base):
        pred = jax.vmap(lambda c: reduced_response(c, base, dt_s))(commands)
        return jnp.sum(jnp.mean(((pred - target) / scale[:, None, None]) ** 2, axis=(1, 2)))

    return jax.lax.map(one, base_grid, batch_size=64)


def _stack(responses: list[Response]) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Commands, velocities (R, T, 3) padded to the longest with their last row, and each
    response's command size (R,)."""
    t = max(len(r.velocity) for r in responses)

    def pad(a):
        return np.concatenate([a, np.repeat(a[-1:], t - len(a), axis=0)])

    cmds = np.stack([pad(r.commands) for r in responses])
    vels = np.stack([pad(r.velocity) for r in responses])
    scale = np.array([max(np.abs(r.command).max(), 1e-6) for r in responses])
    return jnp.asarray(cmds, jnp.float32), jnp.asarray(vels, jnp.float32), jnp.asarray(scale)


def fit_dynamics(responses: list[Response], base: BaseCfg, cfg: CalibrationCfg, dt_s: float):
    """Step 4: ``(lag_s, max_lin_accel_mps2, max_yaw_accel_rps2, cost, per-lag table)`` by
    exhaustive grid over the straight responses that did not fall, ``base`` giving the
    limits. The table maps each lag to its best linear and yaw costs."""
    lin = [r for r in responses if r.kind in ("forward", "backward", "lateral") and not r.fell]
    yaw = [r for r in responses if r.kind == "yaw" and not r.fell]
    lags, lin_acc, yaw_acc = (
        grid(s) for s in (cfg.lag_grid_s, cfg.lin_accel_grid_mps2, cfg.yaw_accel_grid_rps2)
    )

    def costs(group, accel_field, accels):
        lag, acc = (a.ravel() for a in np.meshgrid(lags, accels, indexing="ij"))
        n = len(lag)
        bases = jax.tree.map(lambda x: jnp.full((n,), x, jnp.float32), base)
        bases = bases.replace(lag_s=jnp.asarray(lag, jnp.float32))
        bases = bases.replace(**{accel_field: jnp.asarray(acc, jnp.float32)})
        c = np.asarray(jax.jit(_costs, static_argnums=4)(bases, *_stack(group), dt_s))
        return c.reshape(len(lags), len(accels))

    c_lin = costs(lin, "max_lin_accel_mps2", lin_acc)
    c_yaw = costs(yaw, "max_yaw_accel_rps2", yaw_acc)
    best_lin, best_yaw = c_lin.min(axis=1), c_yaw.min(axis=1)
    i = int(np.argmin(best_lin + best_yaw))
    table = {
        "lag_s": lags.round(4).tolist(),
        "linear_cost": best_lin.tolist(),
        "yaw_cost": best_yaw.tolist(),
    }
    return (
        float(lags[i]),
        float(lin_acc[int(np.argmin(c_lin[i]))]),
        float(yaw_acc[int(np.argmin(c_yaw[i]))]),
        float(best_lin[i] + best_yaw[i]),
        table,
    )


def response_cost(responses: list[Response], base: BaseCfg, dt_s: float) -> float:
    """The fit's cost (step 4) of one config over the straight responses that did not fall."""
    straight = [r for r in responses if r.kind not in ("turn", "diagonal") and not r.fell]
    bases = jax.tree.map(lambda x: jnp.full((1,), x, jnp.float32), base)
    return float(_costs(bases, *_stack(straight), dt_s)[0])
