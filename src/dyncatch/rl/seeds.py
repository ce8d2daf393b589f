"""Several seeds of one training config as one ``vmap``-ped computation.

``SeedGroupRunner(cfgs).learn(progress)`` trains runs that differ only in seed and run
folder: ``iterate`` of ``make_train`` is ``vmap``-ped over a leading seed axis and jitted
once, so S seeds cost one compilation and one dispatch per iteration, and the small
per-seed matrix products become batched ones (``init`` runs once per seed:
``stacked_init``). Each seed still writes what a ``TrainRunner`` writes (checkpoint with
the one-seed header, metrics.csv, tb/), so either runner resumes the other's runs, and a
seed's results equal its separate run's to float tolerance: the random streams are the
same keys, only the batched products may sum in another order (``tests/rl/test_seeds.py``
measures it).

Seeds whose checkpoints stand at different iterations (a group interrupted mid-way cannot
do that, serial runs can) are trained as one group per starting iteration.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from itertools import groupby

import jax
import jax.numpy as jnp
from jax.sharding import Mesh

from dyncatch.rl.guard import non_finite_parts_by_seed, raise_non_finite
from dyncatch.rl.logging import MetricLog
from dyncatch.rl.runner import TrainRunCfg, TrainRunner, eval_due, seed_cfgs
from dyncatch.rl.sharding import state_shardings
from dyncatch.rl.train import TrainState
from dyncatch.sim.api import Environment
from dyncatch.utils.progress import NoProgress, Progress


def stacked_init(init):
    """``init`` for a leading axis of keys, one jitted call per key, stacked.

    Not ``vmap(init)``: the networks' orthogonal initialiser is a QR factorisation, and a
    batched QR is one LAPACK call that jaxlib (0.10) splits over XLA:CPU's intra-op thread
    pool and waits for. XLA runs independent calls side by side (the stacks of a hung run
    showed a ``geqrf`` and an ``orgqr``), each holding a pool thread while waiting for tasks
    queued behind the other; with as many threads as calls (2 on 2 cores) nothing runs and
    the program never returns
    (measured: every ``--seeds 2`` run with the default networks hung here, ``--seeds 1``
    did not; docs/scaling.md). Per key this is the one-seed run's own ``init``, so a seed's
    starting state equals its separate run's bit for bit.
    """
    one = jax.jit(init)

    def run(keys: jax.Array):
        return jax.tree.map(lambda *xs: jnp.stack(xs), *(one(k) for k in keys))

    return run


_PER_SEED = ("seed", "out", "resume")
"""The fields in which the runs of one group may differ."""


def _check_group(cfgs: Sequence[TrainRunCfg]) -> None:
    if not cfgs:
        raise ValueError("a seed group needs at least one run")
    shared = [dataclasses.replace(c, **{k: getattr(cfgs[0], k) for k in _PER_SEED}) for c in cfgs]
    if any(c != shared[0] for c in shared):
        raise ValueError(
            f"the runs of a seed group may differ only in {', '.join(_PER_SEED)}; "
            "train other configs separately"
        )
    if len({c.seed for c in cfgs}) < len(cfgs) or len({c.out for c in cfgs}) < len(cfgs):
        raise ValueError("the runs of a seed group need distinct seeds and --out folders")


@jax.jit
def _seed_slice(ts: TrainState, i: jax.Array) -> TrainState:
    return jax.tree.map(lambda x: x[i], ts)


def seed_slice(ts: TrainState, i: int) -> TrainState:
    """Seed ``i``'s state out of a group's (every leaf's leading axis): one program for
        every leaf (sliced one by one, a state's 105 leaves took 38 ms a seed under cProfile on a
    2-core AMD EPYC)."""
    return _seed_slice(ts, jnp.asarray(i, jnp.int32))


class SeedGroupRunner:
    """Train ``cfgs`` (one-seed configs differing only in seed, out and resume) together.

    ``learn`` returns each run's last metrics, in the order of ``cfgs``.
    """

    def __init__(
        self,
        cfgs: Sequence[TrainRunCfg],
        env: Environment | None = None,
        mesh: Mesh | None = None,
    ):
        _check_group(cfgs)
        self.runners = [TrainRunner(c, env, mesh) for c in cfgs]
        first = self.runners[0]
        self.cfg, self.ppo, self.mesh = first.cfg, first.ppo, first.mesh
        init, iterate, _ = first.learner.make_train(first.env, first.ppo, first.obs_fn, self.mesh)
        self._init, self._viterate = init, jax.vmap(iterate)

    def _compiled(self, n: int):
        """The jitted group ``init`` and ``iterate`` for ``n`` seeds, and the state's
        shardings (the seed axis whole, the environment axis split)."""
        keys = jax.eval_shape(lambda: jax.random.split(jax.random.key(0), n))
        sh = state_shardings(jax.eval_shape(jax.vmap(self._init), keys), self.mesh, env_axis=1)
        whole = jax.sharding.NamedSharding(self.mesh, jax.sharding.PartitionSpec())
        group_init = stacked_init(self._init)

        def init(keys):
            return jax.device_put(group_init(keys), sh)

        return init, jax.jit(self._viterate, out_shardings=(sh, whole)), sh

    def _starts(self) -> list[tuple[int, TrainState | None]]:
        """Each run's starting iteration and loaded state (None: a fresh run)."""
        starts = []
        for r in self.runners:
            if r.cfg.resume:
                ts = r.load()
                starts.append((int(ts.iteration), ts))
            elif r.checkpoint.exists():
                raise ValueError(
                    f"{r.checkpoint} exists: pass --resume to continue it or choose another --out"
                )
            else:
                starts.append((0, None))
        return starts

    def learn(self, progress: Progress | None = None) -> list[dict[str, float]]:
        """Train every run to ``total_steps``; each run's last metrics."""
        starts = self._starts()
        finals: list[dict[str, float]] = [{} for _ in self.runners]
        order = sorted(range(len(self.runners)), key=lambda i: starts[i][0])
        for start, members in groupby(order, key=lambda i: starts[i][0]):
            idx = list(members)
            init, iterate, sh = self._compiled(len(idx))
            if start == 0:
                seeds = jnp.array([self.runners[i].cfg.seed for i in idx])
                ts = init(jax.vmap(jax.random.key)(seeds))
            else:
                loaded = [starts[i][1] for i in idx]
                ts = jax.device_put(jax.tree.map(lambda *x: jnp.stack(x), *loaded), sh)
            runners = [self.runners[i] for i in idx]
            for r in runners:
                r.cfg.out.mkdir(parents=True, exist_ok=True)
            logs = [MetricLog(r.cfg.out, start, r.cfg.logger, r.header) for r in runners]
            try:
                last = self._loop(runners, iterate, ts, start, logs, progress)
            finally:
                for log in logs:
                    log.close()
            for i, m in zip(idx, last, strict=True):
                finals[i] = m
        return finals

    def _loop(self, runners, iterate, ts, start, logs, progress) -> list[dict[str, float]]:
        cfg, ppo = self.cfg, self.ppo
        total_iters = -(-cfg.total_steps // ppo.batch_size)
        seeds = [r.cfg.seed for r in runners]
        update = (progress or NoProgress()).task(
            f"{cfg.method} vs {cfg.world.target.behavior}, seeds {', '.join(map(str, seeds))}",
            total_iters,
            start,
        )
        update(start, "compiling")
        # Runs resumed at their end train nothing: their final metrics are the last logged.
        done = start >= total_iters
        metrics: list[dict[str, float]] = [log.last_row() if done else {} for log in logs]
        # Each run's wall clock (compilation included, evaluations excluded), continued
        # across resumes: the group's clock, so every seed counts the whole group's time.
        clock0 = [time.perf_counter() - log.last("time_s") for log in logs]
        t0 = None
        saved = start if start else None  # the iteration of the checkpoints on disk
        for it in range(start, total_iters):
            ts, m = iterate(ts)
            m = jax.device_get(m)
            now = time.perf_counter()
            metrics = [
                {**{k: float(v[i]) for k, v in m.items()}, "time_s": now - clock0[i]}
                for i in range(len(runners))
            ]
            bad = non_finite_parts_by_seed(ts.params, ts.norm, metrics)
            for r, bad_i in zip(runners, bad, strict=True):
                raise_non_finite(bad_i, it + 1, r.checkpoint, saved)
            if eval_due(cfg, it, start, total_iters):
                t_eval = time.perf_counter()
                for i, r in enumerate(runners):
                    metrics[i].update(r.evaluate(seed_slice(ts, i)))
                clock0 = [c + time.perf_counter() - t_eval for c in clock0]
            else:
                for mi in metrics:
                    mi.update({"eval/success_rate": "", "eval/catch_time_s": ""})
            env_steps = jax.device_get(ts.env_steps)
            for log, mi, n in zip(logs, metrics, env_steps, strict=True):
                log.write(it + 1, int(n), mi)
            if t0 is None:
                t0, done0 = time.perf_counter(), it + 1
            elapsed = time.perf_counter() - t0
            rate = (it + 1 - done0) * ppo.batch_size * len(runners) / elapsed if elapsed else 0.0
            success = " ".join(f"{mi['success_rate']:.2f}" for mi in metrics)
            update(it + 1, f"{rate:,.0f} samples/s  success {success}")
            if (it + 1) % cfg.checkpoint_every == 0 or it + 1 == total_iters:
                for i, r in enumerate(runners):
                    r.save(seed_slice(ts, i))
                saved = it + 1
        return metrics


def make_runner(cfg: TrainRunCfg, env: Environment | None = None) -> TrainRunner | SeedGroupRunner:
    """A ``TrainRunner`` for one seed, a ``SeedGroupRunner`` for ``--seeds`` > 1."""
    if cfg.seeds == 1:
        return TrainRunner(cfg, env)
    return SeedGroupRunner(seed_cfgs(cfg), env)
