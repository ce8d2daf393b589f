"""The full bodies of one evaluation, held in this process: ``Bodies``.

``fullbody.catch.FullBodies`` plays the catch task's episodes on them, here or split over
worker processes (``fullbody.workers``), each holding a ``Bodies`` of its own: a body is
stepped by the same code wherever it lives, so an episode's outcome does not depend on how
many processes played the set. Positions here are in the world frame; ``FullBodies`` moves
them to and from each state's frame.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

import numpy as np

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv
from dyncatch.fullbody.gait import yaw_of
from dyncatch.fullbody.model import build_model

ROW_SIZE = 15
"""A body's measurement after a step, one float64 row: trunk xy (2), yaw, heading-frame
velocity (2), yaw rate, arm joints (6), gripper xyz (3)."""


class Reach(NamedTuple):
    """The world's constants the bodies' side reads, as Python floats."""

    target_height_m: float
    catch_offset_m: float
    activation_distance_m: float


class StepOut(NamedTuple):
    """What ``Bodies.step`` returns for k bodies."""

    rows: np.ndarray
    """(k, ROW_SIZE) float64 measurements (``ROW_SIZE``), world frame."""
    best_m: np.ndarray
    """(k,) smallest catch-point error over the step (inf for a body that did not move)."""
    fell: np.ndarray
    """(k,) bool: the body has fallen."""
    over_limit: np.ndarray
    """(k,) bool: an arm joint has left a physics step above its speed or torque limit
    since the body's reset."""
    stepped: int
    """How many of the k bodies were simulated (neither ended nor fallen)."""


class Bodies:
    """Bodies by index, sharing one compiled ``MjModel``; ``reset`` adds one, ``step`` moves
    some. ``record``: a body whose ``qpos`` and target are kept at every step it moves or
    ends on; ``probe(i, env, goal)``: called after every 200 Hz control period of body i."""

    def __init__(
        self, fullbody: FullBodyCfg, record: int | None = None, probe: Callable | None = None
    ):
        self.fullbody, self.record, self.probe = fullbody, record, probe
        self.envs: dict[int, FullBodyEnv] = {}
        self.fallen: dict[int, bool] = {}
        self._built = None
        self._qpos, self._target_m = [], []

    def reset(self, i: int, xy_m: np.ndarray, yaw_rad: float) -> None:
        """A new body ``i`` standing at ``xy_m`` (2,) (world) facing ``yaw_rad``."""
        if self._built is None:
            self._built = build_model(self.fullbody)
        body = FullBodyEnv(self.fullbody, self._built)
        body.reset(xy_m=(float(xy_m[0]), float(xy_m[1])), yaw_rad=float(yaw_rad))
        self.envs[i] = body
        self.fallen[i] = False

    def step(
        self,
        reach: Reach,
        ids: np.ndarray,
        ended: np.ndarray,
        commands: np.ndarray,
        targets_xy_m: np.ndarray,
    ) -> StepOut:
        """One 50 Hz step of bodies ``ids`` (k,) while their targets pass ``targets_xy_m``
        (k, n_sub + 1, 2) (world), under ``commands`` (k, 3), unless ``ended`` (k,)."""
        k = len(ids)
        rows, best = np.zeros((k, ROW_SIZE)), np.full(k, np.inf)
        fell, over = np.zeros(k, bool), np.zeros(k, bool)
        stepped = 0
        for j, (i, done) in enumerate(zip(ids.tolist(), ended.tolist(), strict=True)):
            env = self.envs[i]
            if not (done or self.fallen[i]):
                best[j] = _physics(env, i, commands[j], targets_xy_m[j], reach, self.probe)
                self.fallen[i] = env.fallen()
                stepped += 1
            if i == self.record and not done:
                self._qpos.append(env.data.qpos.copy())
                self._target_m.append(env.data.mocap_pos[env.idx.target_mocap].copy())
            rows[j] = measure(env)
            fell[j] = self.fallen[i]
            over[j] = over_limit(env)
        return StepOut(rows, best, fell, over, stepped)

    def peaks(self, ids: np.ndarray) -> np.ndarray:
        """(k, 2): each body's largest arm joint speed over the limit and torque over the
        limit, over every physics step since its reset."""
        out = np.zeros((len(ids), 2))
        for j, i in enumerate(ids.tolist()):
            d = self.envs[i].arm_driver
            out[j] = d.peak_speed_rps / d.limit_rps, d.peak_torque_ratio
        return out

    def recorded(self) -> dict[str, np.ndarray]:
        """The recorded body as ``qpos`` (T, nq) and ``target_m`` (T, 3); empty if none."""
        if not self._qpos:
            return {}
        return {"qpos": np.array(self._qpos), "target_m": np.array(self._target_m)}


def measure(env: FullBodyEnv) -> np.ndarray:
    """(ROW_SIZE,) the body's measurement (world frame)."""
    d, idx = env.data, env.idx
    vel = env.base_velocity_heading()
    return np.concatenate(
        [
            d.qpos[:2],
            [yaw_of(d.xmat[idx.base_body].reshape(3, 3))],
            vel,
            d.qpos[idx.arm_qpos],
            env.gripper_m(),
        ]
    )


def over_limit(env: FullBodyEnv) -> bool:
    """An arm joint has left a physics step above the Z1's speed or torque limit."""
    d = env.arm_driver
    return d.peak_speed_rps > d.limit_rps or d.peak_torque_ratio > 1.0


def _catch_error_m(gripper_m: np.ndarray, target_xyz_m: np.ndarray, reach: Reach) -> float:
    """``sim.env.catch_error_m`` in numpy (world frame)."""
    catch_point = gripper_m - np.array([0.0, 0.0, reach.catch_offset_m])
    return float(np.linalg.norm(target_xyz_m - catch_point))


def _physics(env: FullBodyEnv, i: int, command, target_xy_m: np.ndarray, reach: Reach, probe):
    """One control step of a full body through the sub-steps while the target passes
    ``target_xy_m`` (n_sub + 1, 2) (world frame). Returns the smallest catch-point error."""
    height = reach.target_height_m
    best = np.inf
    for xy, xy_next in zip(target_xy_m[:-1], target_xy_m[1:], strict=True):
        target = np.array([xy[0], xy[1], height])
        best = min(best, _catch_error_m(env.gripper_m(), target, reach))
        near = np.sum((xy - env.data.qpos[:2]) ** 2) <= reach.activation_distance_m**2
        goal = target + np.array([0.0, 0.0, reach.catch_offset_m]) if near else None
        # The target's velocity over this period (the arm aims at the true target).
        goal_vel = np.array([*((xy_next - xy) / env.dt_s), 0.0])
        env.set_target(target)
        env.step(command, goal, goal_vel if near else None)
        if probe is not None:
            probe(i, env, goal)
    last = np.array([*target_xy_m[-1], height])
    env.set_target(last)
    return min(best, _catch_error_m(env.gripper_m(), last, reach))
