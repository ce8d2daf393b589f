"""``dyncatch predictor train`` and ``dyncatch predictor table`` (Section III-B, Table II)."""

from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

from dyncatch.predictor.config import CollectCfg, Frame, Kind, PredictorCfg, TrainCfg
from dyncatch.predictor.table import PAPER_BUDGETS
from dyncatch.sim.config import WorldCfg


@dataclasses.dataclass(frozen=True)
class PredictorTrainCmd:
    """Collect interaction data, train one predictor, save it and report its held-out error."""

    behavior: str = "reactive"
    """Target behaviour (circle, bounce, reactive, random_reactive)."""
    kind: Kind = "self_aware"
    """vanilla (target observations only) or self_aware (plus the robot's states)."""
    steps: int = 2_000_000
    """Interaction budget in simulator (control) steps."""
    out: Path = Path("runs/predictor")
    """Folder for predictor.safetensors, loss.csv, tb/ (TensorBoard) and metrics.json."""
    frame: Frame = "egocentric"
    """Input frame (see docs/predictor.md)."""
    hidden: tuple[int, ...] = PredictorCfg.hidden
    """Hidden layer widths."""
    eval_steps: int = 200_000
    """Interaction steps of held-out episodes (another seed) for the reported error."""
    seed: int = 0
    """Seed of data collection and initialisation (held-out data use a different stream)."""
    train: TrainCfg = TrainCfg()
    """Optimisation."""
    collect: CollectCfg = CollectCfg()
    """Interaction data."""
    world: WorldCfg = WorldCfg()
    """The simulated world (the behaviour flag overrides world.target.behavior)."""


@dataclasses.dataclass(frozen=True)
class PredictorTableCmd:
    """Reproduce Table II: error ||v_hat - v||_2 (m/s) per behaviour, kind and budget."""

    json: bool = False
    """Print one JSON object {"rows": [...]} instead of the Markdown table."""
    out: Path = Path("results/predictor")
    """Folder for table_ii.md, table_ii.csv and table_ii.png."""
    budgets: tuple[int, ...] = PAPER_BUDGETS
    """Interaction budgets in simulator steps."""
    behaviors: tuple[str, ...] = ("circle", "bounce", "reactive", "random_reactive")
    """Target behaviours (rows)."""
    frame: Frame = "egocentric"
    """Input frame of both kinds."""
    eval_steps: int = 500_000
    """Interaction steps of the held-out episodes, per behaviour."""
    seed: int = 0
    """Seed of the whole grid."""
    train: TrainCfg = TrainCfg()
    """Optimisation (the same for every cell)."""
    collect: CollectCfg = CollectCfg()
    """Interaction data."""
    world: WorldCfg = WorldCfg()
    """The simulated world."""


def _check_world(world: WorldCfg, behaviors, budgets, collect: CollectCfg) -> None:
    from dyncatch.predictor.data import steps_per_env
    from dyncatch.sim.validate import validate_world

    for b in behaviors:
        validate_world(world.with_behavior(b))
    per_env = steps_per_env(collect.interaction_world(world))
    for n in budgets:
        if n < per_env:
            raise ValueError(f"budget {n} steps is below one episode ({per_env}): raise it")


def run_predictor_train(cmd: PredictorTrainCmd) -> dict:
    import jax
    from rich.progress import Progress
    from tensorboardX import SummaryWriter

    from dyncatch.predictor import checkpoint
    from dyncatch.predictor.config import validate
    from dyncatch.predictor.data import collect
    from dyncatch.predictor.model import Predictor
    from dyncatch.predictor.train import encode_samples, evaluate, fit

    cfg = PredictorCfg(kind=cmd.kind, frame=cmd.frame, hidden=cmd.hidden)
    validate(cfg, cmd.train, cmd.collect)
    _check_world(cmd.world, [cmd.behavior], [cmd.steps], cmd.collect)
    world = cmd.world.with_behavior(cmd.behavior)
    predictor = Predictor.for_world(cfg, world)
    k_data, k_eval, k_fit = jax.random.split(jax.random.key(cmd.seed), 3)
    cmd.out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    with Progress() as bar:
        task = bar.add_task("collecting", total=cmd.steps)
        data, used = collect(
            k_data, world, cmd.collect, cmd.steps, lambda n: bar.update(task, completed=n)
        )
        held_out, _ = collect(k_eval, world, cmd.collect, cmd.eval_steps)
        task = bar.add_task("training", total=cmd.train.updates)
        writer = SummaryWriter(str(cmd.out / "tb"))
        with (cmd.out / "loss.csv").open("w") as log:
            log.write("update,loss_mps\n")

            def on_log(update: int, loss: float) -> None:
                log.write(f"{update},{loss:.6f}\n")
                writer.add_scalar("loss/l2_mps", loss, update)
                bar.update(task, completed=update, description=f"training (loss {loss:.3f})")

            n = len(data.label_mps)
            params, _ = fit(
                predictor,
                cmd.train,
                encode_samples(predictor, data),
                data.label_mps,
                n,
                k_fit,
                on_log,
            )
        error = evaluate(predictor, params, encode_samples(predictor, held_out), held_out.label_mps)
        writer.add_scalar("eval/error_mps", error, cmd.train.updates)
        writer.close()
    metrics = {
        "behavior": cmd.behavior,
        "kind": cmd.kind,
        "budget_steps": used,
        "train_samples": n,
        "eval_samples": len(held_out.label_mps),
        "error_mps": error,
        "seconds": time.perf_counter() - t0,
    }
    checkpoint.save(cmd.out / "predictor.safetensors", predictor, params, info=metrics)
    (cmd.out / "metrics.json").write_text(json.dumps(metrics, indent=2))
    print(json.dumps(metrics))
    return metrics


def run_predictor_table(cmd: PredictorTableCmd) -> list[dict]:
    from rich.console import Console

    from dyncatch.predictor.config import validate
    from dyncatch.predictor.table import TableCfg, run_table, write

    cfg = PredictorCfg(frame=cmd.frame)
    validate(cfg, cmd.train, cmd.collect)
    _check_world(cmd.world, cmd.behaviors, cmd.budgets, cmd.collect)
    table = TableCfg(
        cmd.behaviors, ("vanilla", "self_aware"), cmd.budgets, cmd.eval_steps, cmd.seed
    )
    console = Console(stderr=cmd.json)
    t0 = time.perf_counter()
    with console.status("Table II") as status:

        def on_cell(r: dict) -> None:
            status.update(
                f"{r['behavior']} {r['kind']} {r['budget_steps'] / 1e6:g}M: "
                f"{r['error_mps']:.3f} m/s"
            )

        rows = run_table(table, cfg, cmd.train, cmd.collect, cmd.world, on_cell)
    wall_s = time.perf_counter() - t0
    header = f"Table II, regenerated in {wall_s:.0f} s (seed {cmd.seed})."
    paths = write(rows, cmd.out, header)
    if cmd.json:
        keys = ("behavior", "kind", "budget_steps", "error_mps")
        print(json.dumps({"rows": [{k: r[k] for k in keys} for r in rows]}))
    else:
        from dyncatch.predictor.table import markdown

        console.print(markdown(rows))
        console.print(f"{header} Wrote {', '.join(str(p) for p in paths)}")
    return rows
