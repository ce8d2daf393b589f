"""The base calibration: its read-offs on hand-built responses, and its grid fit recovers the
constants of responses the reduced base itself produced (no MuJoCo needed)."""

import numpy as np
import pytest

from dyncatch.fullbody.calibration import (
    CalibrationCfg,
    Response,
    calibration_commands,
    fit_dynamics,
    grid,
    read_limits,
    reduced_response,
    step_commands,
)
from dyncatch.sim.config import BaseCfg

HZ = 200.0
CFG = CalibrationCfg(
    forward_mps=(1.0, 2.0),
    backward_mps=(1.0,),
    lateral_mps=(1.0,),
    yaw_rps=(1.0, 2.0),
    turns=((1.0, 1.0),),
    diagonals=((1.0, 0.5), (2.0, 1.0)),
    hold_s=1.0,
    stop_s=0.5,
    measure_s=0.5,
    lag_grid_s=(0.1, 0.3, 0.05),
    lin_accel_grid_mps2=(2.0, 4.0, 0.5),
    yaw_accel_grid_rps2=(4.0, 8.0, 1.0),
)


def test_grid_spans_first_to_last():
    np.testing.assert_allclose(grid((0.02, 0.40, 0.01)), np.arange(2, 41) / 100)


def test_a_response_holds_then_stops():
    cmds = step_commands((1.0, 0.0, 0.5), CFG, HZ)
    assert cmds.shape == (300, 3)
    np.testing.assert_array_equal(cmds[199], (1.0, 0.0, 0.5))
    np.testing.assert_array_equal(cmds[200], (0.0, 0.0, 0.0))


def _flat(kind, cmd, value, fell=False):
    """A response whose velocity is ``value`` (3,) throughout."""
    cmds = step_commands(cmd, CFG, HZ)
    return Response(kind, cmd, cmds, np.tile(value, (len(cmds), 1)), fell)


def test_limits_are_the_largest_tracked_settled_values():
    responses = [
        _flat("forward", (1.0, 0, 0), (0.98, 0, 0)),
        _flat("forward", (2.0, 0, 0), (1.70, 0, 0)),  # 15 % short: not tracked
        _flat("backward", (-1.0, 0, 0), (-0.95, 0, 0)),
        _flat("lateral", (0, 1.0, 0), (0, 1.05, 0)),
        _flat("yaw", (0, 0, 1.0), (0, 0, 1.0)),
        _flat("yaw", (0, 0, 2.0), (0, 0, 1.9), fell=True),  # fell: not tracked
        # Turning at 0.8 m/s forward, 0.6 m/s outward (|v| = 1.0) and 1.5 rad/s: 1.5 m/s^2.
        _flat("turn", (1.0, 0, 2.0), (0.8, -0.6, 1.5)),
        # On the diagonal: the largest settled ground speed, hypot(1.6, 1.2) = 2.0 m/s.
        _flat("diagonal", (1.0, 0.5, 0), (0.9, 0.5, 0)),
        _flat("diagonal", (2.0, 1.0, 0), (1.6, 1.2, 0)),
        _flat("diagonal", (3.0, 1.0, 0), (2.5, 1.0, 0), fell=True),  # fell: left out
    ]
    limits = read_limits(responses, CFG, HZ)
    assert limits["max_forward_mps"] == (0.98, False)
    assert limits["max_backward_mps"] == (0.95, True)  # the only backward step: grid max
    assert limits["max_lateral_mps"] == (1.05, True)
    assert limits["max_yaw_rate_rps"] == (1.0, False)
    assert limits["max_lateral_accel_mps2"][0] == pytest.approx(1.5)
    assert limits["max_speed_mps"][0] == pytest.approx(2.0)


def test_the_fit_recovers_the_reduced_base_that_made_the_responses():
    truth = BaseCfg(lag_s=0.2, max_lin_accel_mps2=3.0, max_yaw_accel_rps2=6.0)
    responses = []
    for kind, cmd in calibration_commands(CFG):
        if kind in ("turn", "diagonal"):
            continue
        cmds = step_commands(cmd, CFG, HZ)
        vel = np.asarray(reduced_response(cmds, truth, 1 / HZ))
        responses.append(Response(kind, cmd, cmds, vel, False))
    lag, lin, yaw, cost, table = fit_dynamics(responses, BaseCfg(), CFG, 1 / HZ)
    assert (lag, lin, yaw) == pytest.approx((0.2, 3.0, 6.0))
    assert cost < 1e-8
    assert len(table["lag_s"]) == 5 and min(np.add(table["linear_cost"], table["yaw_cost"])) < 1e-8
