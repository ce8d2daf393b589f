"""Issue 15's sim-to-sim cells, one ``dyncatch eval --json`` command each, one at a time.

``python benchmarks/sim_to_sim.py --out DIR [--run RUN --predictor CKPT] [--episodes 200]``
plays, for the trained run (with its predictor) and for the pursuit baseline, the reactive
target at each speed on the JAX world and on the full body, one command per cell, with the
same seed. One speed per command on both backends: ``dyncatch eval`` keys a speed by its
position in ``--speeds``, so a speed is the same episodes on both backends only at the same
position. Each command's JSON is written to ``DIR/<method>_<backend>_<speed>.json`` with its
wall time and command line added; a cell already there is kept (the runner resumes). Then
the table (``sim_to_sim_table.py``) is printed. Speeds run in the order of ``--speeds``, so
the issue's figure (1.2 m/s) comes first.
"""

from __future__ import annotations

import dataclasses
import json
import subprocess
import sys
import time
from pathlib import Path

import tyro
from sim_to_sim_table import markdown, table  # benchmarks/ is the script's path


@dataclasses.dataclass(frozen=True)
class SimToSimCmd:
    out: Path
    """Folder for the cells' JSON."""
    run: str | None = None
    """A trained run folder (its predictor from --predictor); None plays pursuit only."""
    predictor: str | None = None
    """Predictor checkpoint for the run."""
    speeds: tuple[float, ...] = (1.2, 0.8, 1.6)
    """Target speeds (m/s), in the order the full-body cells run."""
    episodes: int = 200
    seed: int = 0
    baselines: tuple[str, ...] = ("pursuit",)
    fullbody: tuple[str, ...] = ()
    """``dyncatch eval``'s ``--fullbody.*`` flags for the full-body cells, as FIELD=VALUE
    (``--fullbody gait.mpc.leg-torque-share=0.9`` for ``--fullbody.gait.mpc.leg-torque-share
    0.9``)."""


def fullbody_argv(settings: tuple[str, ...]) -> list[str]:
    """``--fullbody.FIELD VALUE`` for each FIELD=VALUE of ``settings``."""
    argv = []
    for item in settings:
        field, sep, value = item.partition("=")
        if not sep or not field or field.startswith("-"):
            raise SystemExit(f"--fullbody {item!r}: write FIELD=VALUE, e.g. gait.period-s=0.3")
        argv += [f"--fullbody.{field}", *value.split()]
    return argv


def _cell(cmd: SimToSimCmd, method: str, backend: str, speeds, extra: list[str]) -> Path:
    name = Path(method).name if method == cmd.run else method
    tag = "run" if method == cmd.run else name
    suffix = "_" + "_".join(f"{v:g}" for v in speeds)
    path = cmd.out / f"{tag}_{backend}{suffix}.json"
    if path.exists():
        return path
    argv = [
        sys.executable,
        "-m",
        "dyncatch.cli.main",
        "eval",
        method,
        *extra,
        "--speeds",
        *[f"{v:g}" for v in speeds],
        "--episodes",
        str(cmd.episodes),
        "--seed",
        str(cmd.seed),
        "--backend",
        backend,
        "--json",
        *(fullbody_argv(cmd.fullbody) if backend == "mujoco" else ()),
    ]
    t0 = time.perf_counter()
    done = subprocess.run(argv, check=True, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    out = json.loads(done.stdout.strip().splitlines()[-1])
    out["wall_s"] = round(wall, 1)
    out["command"] = " ".join(argv[1:])
    path.write_text(json.dumps(out))
    print(f"{path.name}: {wall:.0f} s", flush=True)
    return path


def main(cmd: SimToSimCmd) -> None:
    cmd.out.mkdir(parents=True, exist_ok=True)
    methods = [(m, []) for m in cmd.baselines]
    if cmd.run is not None:
        extra = [] if cmd.predictor is None else ["--predictor", cmd.predictor]
        methods.insert(0, (cmd.run, extra))
    paths = []
    for v in cmd.speeds:
        for m, extra in methods:
            paths.append(_cell(cmd, m, "jax", (v,), extra))
            paths.append(_cell(cmd, m, "mujoco", (v,), extra))
    print(markdown(table([str(p) for p in paths])))


if __name__ == "__main__":
    main(tyro.cli(SimToSimCmd))
