"""``dyncatch bench env``: simulator throughput, printed as a table or JSON."""

from __future__ import annotations

import dataclasses
import json

from dyncatch.sim.config import WorldCfg


@dataclasses.dataclass(frozen=True)
class EnvBenchCmd:
    """Env steps/s with random actions, batched JAX vs the Gymnasium single-env loop."""

    num_envs: tuple[int, ...] = (1, 64, 1024, 4096, 16384)
    """Batch sizes to measure."""
    json: bool = False
    """Print one JSON object instead of a table."""
    world: WorldCfg = WorldCfg()
    """The simulated world (arm IK and sensing are always on)."""


def run_env_bench(cmd: EnvBenchCmd) -> dict:
    from dyncatch.bench.env_bench import run_env_benchmark
    from dyncatch.bench.machine import machine_info
    from dyncatch.sim.validate import validate_world

    validate_world(cmd.world)
    if any(n < 1 for n in cmd.num_envs):
        raise ValueError(f"--num-envs must be positive integers, got {cmd.num_envs}")
    rows = run_env_benchmark(cmd.world, cmd.num_envs)
    result = {"machine": machine_info(), "rows": rows}
    if cmd.json:
        print(json.dumps(result))
    else:
        print(format_env_table(result))
    return result


def format_env_table(result: dict) -> str:
    gym = next(r["steps_per_s"] for r in result["rows"] if r["backend"] == "gym_loop")
    lines = ["| backend | num_envs | env steps/s | x gym loop |", "|---|---:|---:|---:|"]
    for r in result["rows"]:
        lines.append(
            f"| {r['backend']} | {r['num_envs']} | {r['steps_per_s']:,.0f} | "
            f"{r['steps_per_s'] / gym:,.1f} |"
        )
    m = result["machine"]
    lines.append(f"\nmachine: {m['cpu']}, {m['cores']} cores, jax {m['jax']} ({m['backend']})")
    return "\n".join(lines)
