"""``dyncatch bench env|ppo|gait|machine``: simulator and PPO throughput, the full-body
gait's step responses, and this machine's speed against the reproduction estimate's
reference; printed as a table or JSON."""

from __future__ import annotations

import dataclasses
import json

from dyncatch.bench.env_bench import run_env_benchmark
from dyncatch.bench.gait_bench import GaitBenchCfg, run_gait_benchmark
from dyncatch.bench.machine import machine_info
from dyncatch.bench.ppo_bench import PEAK_ROWS, mlp_flops, run_ppo_benchmark
from dyncatch.bench.speed_probe import REF_COMPILE_S, REF_COMPUTE_S, probe_speed
from dyncatch.fullbody.config import FullBodyCfg, validate_fullbody
from dyncatch.predictor.config import TRACKER, PredictorCfg
from dyncatch.predictor.model import Predictor
from dyncatch.predictor.tracker.config import TrackerCfg
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.methods import MethodName, get_method
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world


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
    lines = [
        "| backend | scene (rays) | num_envs | env steps/s | x gym loop |",
        "|---|---|---:|---:|---:|",
    ]
    for r in result["rows"]:
        lines.append(
            f"| {r['backend']} | {r['scene']} ({r['scan_rays']}) | {r['num_envs']} | "
            f"{r['steps_per_s']:,.0f} | {r['steps_per_s'] / gym:,.1f} |"
        )
    m = result["machine"]
    lines.append(f"\nmachine: {m['cpu']}, {m['cores']} cores, jax {m['jax']} ({m['backend']})")
    return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class PPOBenchCmd:
    """PPO samples/s of whole iterations and the achieved fraction of this machine's GEMM peak."""

    method: MethodName = "rl"
    """Method whose inputs the policy sees (predictor methods use a freshly initialised
    predictor: the same cost as a trained one)."""
    iterations: int = 5
    """Timed iterations per repeat (best of 3 repeats; compilation excluded)."""
    seeds: int = 1
    """Seeds trained together as one vmap-ped computation (dyncatch train --seeds): samples/s
    counts all of them, so the speed-up of a group is this over --seeds 1."""
    gemm_rows: tuple[int, ...] = PEAK_ROWS
    """Row counts at which the GEMM peak is measured (the peak is the best of them)."""
    json: bool = False
    """Print one JSON object instead of a table."""
    ppo: PPOCfg = PPOCfg()
    """PPO hyper-parameters and batch geometry (the thing being measured)."""
    world: WorldCfg = WorldCfg()
    """The simulated world, its target behaviour included (``--behavior``)."""


def run_ppo_bench(cmd: PPOBenchCmd) -> dict:
    import jax

    world = validate_world(cmd.world)
    ppo = validate_ppo(cmd.ppo)
    if cmd.iterations < 1 or cmd.seeds < 1:
        raise ValueError(
            f"--iterations and --seeds must be >= 1, got {cmd.iterations} and {cmd.seeds}"
        )
    if not cmd.gemm_rows or min(cmd.gemm_rows) < 1:
        raise ValueError(f"--gemm-rows must be positive row counts, got {cmd.gemm_rows}")
    method = get_method(cmd.method)
    if method.memory:
        raise ValueError(
            f"bench ppo measures the feed-forward PPO update; {cmd.method!r} trains by "
            f"recurrent PPO, which it does not model: time dyncatch train --method {cmd.method}"
        )
    kind = method.predictor_kind
    predictor = params = None
    pred_flops = 0
    if kind == TRACKER:
        predictor = Tracker.for_world(TrackerCfg(), world)
        params = predictor.init(jax.random.key(0))
        pred_flops = mlp_flops([predictor.input_dim, *predictor.cfg.hidden, 8])
    elif kind is not None:
        predictor = Predictor.for_world(PredictorCfg(kind=kind), world)
        params = predictor.init(jax.random.key(0))
        pred_flops = mlp_flops([predictor.input_dim, *predictor.cfg.hidden, 2])
    obs_fn = method.obs_fn(predictor, params)
    env = JaxCatchEnv(world)
    state = env.reset(jax.random.key(0))
    _, x = obs_fn.step(obs_fn.init_carry(state), state, env.observe(state))
    obs_dim = int(x.shape[0])
    result = run_ppo_benchmark(
        env, ppo, obs_fn, obs_dim, cmd.iterations, pred_flops, cmd.gemm_rows, cmd.seeds
    )
    result.update(
        {
            "method": cmd.method,
            "num_envs": ppo.num_envs,
            "num_steps": ppo.num_steps,
            "num_minibatches": ppo.num_minibatches,
            "update_epochs": ppo.update_epochs,
            "hidden_sizes": list(ppo.hidden_sizes),
            "machine": machine_info(),
        }
    )
    if cmd.json:
        print(json.dumps(result))
    else:
        print(format_ppo_table(result))
    return result


def format_ppo_table(r: dict) -> str:
    m = r["machine"]
    f = r["flops_per_sample"]
    return "\n".join(
        [
            "| quantity | value |",
            "|---|---:|",
            f"| method | {r['method']} |",
            f"| batch (envs x steps) | {r['num_envs']} x {r['num_steps']} |",
            f"| seeds in one jit, devices | {r['seeds']}, {r['devices']} |",
            f"| samples/s | {r['samples_per_s']:,.0f} |",
            f"| FLOPs/sample (rollout + update) | {f['rollout']:,} + {f['update']:,} |",
            f"| achieved GFLOP/s | {r['achieved_gflops']:.1f} |",
            f"| GEMM peak GFLOP/s {tuple(r['gemm_shape'])} | {r['gemm_peak_gflops']:.1f} |",
            f"| fraction of peak | {r['fraction_of_peak']:.2f} |",
            f"\nmachine: {m['cpu']}, {m['cores']} cores, jax {m['jax']} ({m['backend']})",
        ]
    )


@dataclasses.dataclass(frozen=True)
class GaitBenchCmd:
    """Step responses and fall rate of the full-body MuJoCo gait (needs the [fullbody] extra)."""

    json: bool = False
    """Print one JSON object instead of a table."""
    bench: GaitBenchCfg = GaitBenchCfg()
    """What is commanded and how tracking is judged."""
    fullbody: FullBodyCfg = FullBodyCfg()
    """The full-body model and its controllers."""


def run_gait_bench(cmd: GaitBenchCmd) -> dict:

    try:
        import mujoco  # noqa: F401
    except ModuleNotFoundError as e:
        raise SystemExit("bench gait needs MuJoCo: pip install -e '.[fullbody]'") from e
    result = run_gait_benchmark(cmd.bench, validate_fullbody(cmd.fullbody))
    if cmd.json:
        print(json.dumps(result))
    else:
        print(format_gait_table(result))
    return result


def format_gait_table(r: dict) -> str:
    rows = [
        ("max forward speed tracked (m/s)", r["max_forward_mps"]),
        ("max yaw rate tracked (rad/s)", r["max_yaw_rate_rps"]),
        ("yaw rate tracked at max forward (rad/s)", r["yaw_rate_at_max_forward_rps"]),
        ("63 % rise time of a forward step (s)", r["lag_s"]),
        (f"fall rate ({r['episodes']} random-command episodes)", r["fall_rate"]),
    ]
    lines = ["| quantity | value |", "|---|---:|"]
    lines += [f"| {name} | {value} |" for name, value in rows]
    lines.append(f"\nwall time: {r['wall_s']} s")
    return "\n".join(lines)


@dataclasses.dataclass(frozen=True)
class MachineBenchCmd:
    """This machine's time to compute and to compile against the machine the reproduction's
    estimate was fit on (``dyncatch.bench.speed_probe``; ``dyncatch reproduce`` runs it first)."""

    repeats: int = 3
    """Compilations and runs of the probe; the best of each is kept."""
    json: bool = False
    """Print one JSON object instead of a table."""


def run_machine_bench(cmd: MachineBenchCmd) -> dict:
    if cmd.repeats < 1:
        raise ValueError(f"--repeats must be at least 1, got {cmd.repeats}")
    speed, times = probe_speed(cmd.repeats)
    result = {
        "machine": machine_info(),
        "compute_factor": speed.compute,
        "compile_factor": speed.compile,
        "reference": {"compute_s": REF_COMPUTE_S, "compile_s": REF_COMPILE_S},
        **times,
    }
    if cmd.json:
        print(json.dumps(result))
    else:
        print(format_machine_table(result))
    return result


def format_machine_table(r: dict) -> str:
    ref = r["reference"]
    lines = [
        "| probe | here (s) | reference (s) | factor |",
        "|---|---:|---:|---:|",
        f"| compute | {r['compute_s']:.3f} | {ref['compute_s']:.3f} | {r['compute_factor']:.2f} |",
        f"| compile | {r['compile_s']:.3f} | {ref['compile_s']:.3f} | {r['compile_factor']:.2f} |",
    ]
    m = r["machine"]
    lines.append(f"\nmachine: {m['cpu']}, {m['cores']} cores, jax {m['jax']} ({m['backend']})")
    return "\n".join(lines)
