"""PPO throughput: samples/s of whole iterations, and how close the maths runs to the GEMM
peak XLA reaches on this machine for the network's largest layer.

FLOPs are counted from the layer shapes (2 per multiply-add, bias and activations left
out): per sample, the rollout's actor+critic forward, the critic forward on the episode's
final observation (time-out bootstrap), and ``update_epochs`` forward+backward passes of
actor and critic (backward = 2x forward, gradients for inputs and weights, except the
first layer, which needs no input gradient). A predictor method adds its predictor's
forward per rollout sample. The peak is the best rate over several row counts of the
largest layer's product, so a geometry cannot raise its own yardstick by choosing an
unlucky minibatch size.
"""

from __future__ import annotations

import time
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.seeds import stacked_init
from dyncatch.rl.sharding import batch_mesh, state_shardings, validate_mesh
from dyncatch.rl.train import make_train

PEAK_ROWS = (512, 1024, 2048, 4096, 8192)
"""Row counts (batch sizes) at which the GEMM peak is measured."""


def mlp_flops(sizes: list[int]) -> int:
    """Forward FLOPs of one sample through dense layers ``sizes[0] -> ... -> sizes[-1]``."""
    return 2 * sum(a * b for a, b in zip(sizes[:-1], sizes[1:], strict=False))


def ppo_flops_per_sample(obs_dim: int, ppo: PPOCfg, predictor_flops: int = 0) -> dict:
    hidden = list(ppo.hidden_sizes)
    actor = mlp_flops([obs_dim, *hidden, 3])
    critic = mlp_flops([obs_dim, *hidden, 1])
    rollout = actor + critic + critic + predictor_flops
    first = 2 * obs_dim * hidden[0]  # first-layer input gradients are not computed
    update = ppo.update_epochs * (3 * (actor + critic) - 2 * first)
    return {"rollout": rollout, "update": update, "total": rollout + update}


@partial(jax.jit, static_argnames=("reps",))
def _gemm_chain(a: jax.Array, w: jax.Array, reps: int) -> jax.Array:
    def body(_, x):
        return jnp.dot(x, w) * 0.5  # keeps values bounded; the chain stops XLA skipping work

    return jax.lax.fori_loop(0, reps, body, a)


def gemm_peak_gflops(m: int, k: int, repeats: int = 5, min_seconds: float = 0.5) -> float:
    """Best fp32 GFLOP/s of jitted (m, k) @ (k, k) products in a chain (square layer)."""
    a = jax.random.normal(jax.random.key(0), (m, k), jnp.float32)
    w = jax.random.normal(jax.random.key(1), (k, k), jnp.float32) / np.sqrt(k)
    flops = 2 * m * k * k
    reps = 8
    jax.block_until_ready(_gemm_chain(a, w, reps))
    while True:  # grow the chain until one call takes min_seconds
        t0 = time.perf_counter()
        jax.block_until_ready(_gemm_chain(a, w, reps))
        dt = time.perf_counter() - t0
        if dt >= min_seconds or reps >= 1 << 16:
            break
        reps *= 2
        jax.block_until_ready(_gemm_chain(a, w, reps))
    best = dt
    for _ in range(repeats - 1):
        t0 = time.perf_counter()
        jax.block_until_ready(_gemm_chain(a, w, reps))
        best = min(best, time.perf_counter() - t0)
    return flops * reps / best / 1e9


def largest_layer(obs_dim: int, ppo: PPOCfg) -> tuple[int, int]:
    """(fan_in, fan_out) of the layer with the most weights."""
    sizes = [obs_dim, *ppo.hidden_sizes]
    return max(zip(sizes[:-1], sizes[1:], strict=False), key=lambda s: s[0] * s[1])


def ppo_samples_per_s(
    init, iterate, ppo: PPOCfg, iterations: int, repeats: int = 3, seeds: int = 1
) -> float:
    """Best of ``repeats`` timings of ``iterations`` compiled PPO iterations; with
    ``seeds`` > 1, ``init``/``iterate`` are a seed group's (``vmap``-ped) and each iteration
    counts ``seeds`` batches."""
    key = jax.random.key(0)
    ts = init(jax.random.split(key, seeds) if seeds > 1 else key)
    ts, m = iterate(ts)  # compile
    jax.block_until_ready(m)
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(iterations):
            ts, m = iterate(ts)
        jax.block_until_ready((ts, m))
        best = min(best, time.perf_counter() - t0)
    return iterations * ppo.batch_size * seeds / best


def compiled_train(env, ppo: PPOCfg, obs_fn, seeds: int = 1):
    """The jitted ``init`` and ``iterate`` the runners use: the batch split over every local
    device, and with ``seeds`` > 1 ``vmap``-ped over a leading seed axis."""

    mesh = batch_mesh()
    validate_mesh(ppo, mesh.size)
    init, iterate, _ = make_train(env, ppo, obs_fn, mesh)
    key = jax.random.key(0)
    whole = jax.sharding.NamedSharding(mesh, jax.sharding.PartitionSpec())
    if seeds == 1:
        sh = state_shardings(jax.eval_shape(init, key), mesh, env_axis=0)
        return jax.jit(init, out_shardings=sh), jax.jit(iterate, out_shardings=(sh, whole))
    keys = jax.random.split(key, seeds)
    sh = state_shardings(jax.eval_shape(jax.vmap(init), keys), mesh, env_axis=1)
    group_init = stacked_init(init)  # not vmap(init): see rl.seeds.stacked_init
    return (
        lambda keys: jax.device_put(group_init(keys), sh),
        jax.jit(jax.vmap(iterate), out_shardings=(sh, whole)),
    )


def run_ppo_benchmark(
    env,
    ppo: PPOCfg,
    obs_fn,
    obs_dim: int,
    iterations: int,
    predictor_flops: int = 0,
    peak_rows: tuple[int, ...] = PEAK_ROWS,
    seeds: int = 1,
):
    """``env``: an environment (``dyncatch.sim.api``) or a world; the GEMM peak is the best
    over ``peak_rows``. ``seeds`` > 1 times a seed group (``dyncatch.rl.seeds``): samples/s
    of all its seeds together."""
    init, iterate = compiled_train(env, ppo, obs_fn, seeds)
    samples = ppo_samples_per_s(init, iterate, ppo, iterations, seeds=seeds)
    flops = ppo_flops_per_sample(obs_dim, ppo, predictor_flops)
    k_in, k_out = largest_layer(obs_dim, ppo)
    # The largest layer, square in its widest dimension (the chain needs k_in == k_out).
    k = max(k_in, k_out)
    rates = {m: gemm_peak_gflops(m, k) for m in peak_rows}
    m_best = max(rates, key=rates.get)
    peak = rates[m_best]
    achieved = samples * flops["total"] / 1e9
    return {
        "samples_per_s": samples,
        "flops_per_sample": flops,
        "achieved_gflops": achieved,
        "gemm_peak_gflops": peak,
        "gemm_shape": [m_best, k, k],
        "gemm_gflops_by_rows": {str(m): r for m, r in rates.items()},
        "fraction_of_peak": achieved / peak,
        "seeds": seeds,
        "devices": jax.device_count(),
    }
