"""Fit ``BaseCfg`` to the full-body gait's step responses (``dyncatch.fullbody.calibration``).

``python benchmarks/calibrate_base.py [--out benchmarks/calibrate_base.json]
[--img-dir docs/img/fullbody]``: simulates the full body (a few minutes), fits, writes the
JSON (the full config that made it, the read-off limits, the fit, both costs, and every
response at 50 Hz: full body, reduced base with the defaults and with the fit) and draws the
overlays from that JSON. ``--plot-only`` redraws from an existing JSON, refusing one made
by another config.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from pathlib import Path

import numpy as np
import tyro

from dyncatch.fullbody.calibration import (
    CalibrationCfg,
    fit_dynamics,
    fullbody_responses,
    read_limits,
    reduced_response,
    response_cost,
    settled,
)
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.utils.config_io import config_diff, to_json
from dyncatch.utils.jax_setup import setup_jax

SAMPLE_HZ = 25
"""Rate of the traces kept in the JSON and drawn (well above the trot's 3.3 Hz ripple; the
fit itself uses every 200 Hz sample)."""


@dataclasses.dataclass(frozen=True)
class CalibrateCmd:
    calibration: CalibrationCfg = CalibrationCfg()
    """The step responses and fit grids."""
    fullbody: FullBodyCfg = FullBodyCfg()
    """The full-body model and gait; its ``base`` gives the defaults compared against."""
    out: Path = Path("benchmarks/calibrate_base.json")
    """The results JSON."""
    img_dir: Path = Path("docs/img/fullbody")
    """Where the overlay plots go."""
    plot_only: bool = False
    """Redraw the plots from ``out`` without simulating."""


def _config(cmd: CalibrateCmd) -> dict:
    return to_json({"calibration": cmd.calibration, "fullbody": cmd.fullbody})


def calibrate(cmd: CalibrateCmd) -> dict:
    from dyncatch.fullbody.env import FullBodyEnv

    t0 = time.perf_counter()
    env = FullBodyEnv(cmd.fullbody)
    hz = cmd.fullbody.control_hz
    responses = fullbody_responses(env, cmd.calibration)
    sim_s = time.perf_counter() - t0
    limits = read_limits(responses, cmd.calibration, hz)
    default = cmd.fullbody.base
    # A limit with no tracked command (0) or no turn (nan) keeps its default. The ground speed
    # on the diagonal is reported, not fitted: the trot runs faster straight ahead (2.3 m/s)
    # than on the diagonal, so a norm limit in the fit would cut the straight responses.
    envelope = limits.pop("max_speed_mps", (math.nan, False))[0]
    found = {k: v for k, (v, _) in limits.items() if np.isfinite(v) and v > 0}
    with_limits = default.replace(**found)
    lag, lin, yaw, cost, table = fit_dynamics(responses, with_limits, cmd.calibration, 1 / hz)
    fitted = with_limits.replace(
        lag_s=round(lag, 4), max_lin_accel_mps2=round(lin, 4), max_yaw_accel_rps2=round(yaw, 4)
    )
    # Each axis group's own best lag, to show how well one shared lag fits both.
    lags = np.asarray(table["lag_s"])
    every = round(hz / SAMPLE_HZ)

    def trace(a):
        return np.round(np.asarray(a)[every - 1 :: every], 3).tolist()

    rows = []
    for r in responses:
        rows.append(
            {
                "kind": r.kind,
                "command": list(r.command),
                "fell": r.fell,
                "settled": np.round(settled(r, cmd.calibration, hz), 4).tolist(),
                "fullbody": trace(r.velocity),
                "reduced_default": trace(reduced_response(r.commands, default, 1 / hz)),
                "reduced_fitted": trace(reduced_response(r.commands, fitted, 1 / hz)),
            }
        )
    fields = [*limits, "lag_s", "max_lin_accel_mps2", "max_yaw_accel_rps2"]
    return {
        "config": _config(cmd),
        "fitted": {k: getattr(fitted, k) for k in fields},
        "default": {k: getattr(default, k) for k in fields},
        "limit_at_grid_max": {k: at for k, (_, at) in limits.items()},
        "max_speed_mps_read_off": envelope,
        "cost_fitted": round(cost, 5),
        "cost_default_dynamics_fitted_limits": round(
            response_cost(responses, with_limits, 1 / hz), 5
        ),
        "cost_default": round(response_cost(responses, default, 1 / hz), 5),
        "lag_linear_only_s": float(lags[np.argmin(table["linear_cost"])]),
        "lag_yaw_only_s": float(lags[np.argmin(table["yaw_cost"])]),
        "lag_table": table,
        "sample_hz": SAMPLE_HZ,
        "responses": rows,
        "fullbody_sim_wall_s": round(sim_s, 1),
        "wall_s": round(time.perf_counter() - t0, 1),
    }


def plot(result: dict, img_dir: Path) -> list[Path]:
    """One figure per kind of response: full body solid, reduced base fitted dashed and
    default dotted; forward, left and yaw rate in three rows."""
    import matplotlib.pyplot as plt

    img_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    kinds = dict.fromkeys(r["kind"] for r in result["responses"])
    labels = ("forward (m/s)", "left (m/s)", "yaw rate (rad/s)")
    for kind in kinds:
        rows = [r for r in result["responses"] if r["kind"] == kind]
        fig, axes = plt.subplots(3, 1, figsize=(6, 5.5), sharex=True)
        for j, r in enumerate(rows):
            colour = f"C{j}"
            t = (np.arange(len(r["fullbody"])) + 1) / result["sample_hz"]
            for ax, i in zip(axes, range(3), strict=True):
                ax.plot(t, np.asarray(r["fullbody"])[:, i], color=colour, lw=1.2)
                ax.plot(t, np.asarray(r["reduced_fitted"])[:, i], color=colour, ls="--", lw=1)
                ax.plot(t, np.asarray(r["reduced_default"])[:, i], color=colour, ls=":", lw=1)
            axes[0].plot([], [], color=colour, label=str(tuple(r["command"])))
        for ax, label in zip(axes, labels, strict=True):
            ax.set_ylabel(label)
            ax.grid(alpha=0.3)
        axes[0].plot([], [], "k-", label="full body")
        axes[0].plot([], [], "k--", label="reduced, fitted")
        axes[0].plot([], [], "k:", label="reduced, default")
        axes[0].legend(fontsize=7, ncol=2)
        axes[0].set_title(f"{kind} steps: command held, then zero")
        axes[-1].set_xlabel("time (s)")
        fig.tight_layout()
        path = img_dir / f"calibrate_{kind}.png"
        fig.savefig(path, dpi=60)
        plt.close(fig)
        paths.append(path)
    return paths


def main(cmd: CalibrateCmd) -> None:
    if cmd.plot_only:
        result = json.loads(cmd.out.read_text())
        diff = config_diff(result["config"], _config(cmd))
        if diff:
            raise SystemExit(
                f"{cmd.out} was made by another config ({diff}); run without --plot-only"
            )
    else:
        result = calibrate(cmd)
        cmd.out.write_text(json.dumps(result, separators=(",", ":")) + "\n")
    summary = {k: v for k, v in result.items() if k not in ("responses", "lag_table", "config")}
    print(json.dumps(summary, indent=1))
    for p in plot(result, cmd.img_dir):
        print("wrote", p)


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(CalibrateCmd))
