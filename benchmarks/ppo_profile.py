"""Where a PPO update epoch's time goes, by an ablation ladder on one minibatch.

Each rung is one jitted function on the default minibatch (4096 samples of the world's
observation, actor and critic 256-256-128), timed best of ``--repeats`` chains of
``--reps`` calls in one process (the rungs interleaved round by round), beside the same-run
GEMM peak of ``dyncatch bench ppo`` (``bench.ppo_bench.gemm_peak_gflops``). Every rung adds
one thing to the one before:

1. ``gemms``: only the matrix products a forward + backward pass of both networks does
   (X W, dY W^T and X^T dY per layer; no first-layer input gradient), chained;
2. ``grad_linear``: ``jax.grad`` of the two MLPs without activations (the same products,
   as XLA emits them for a real backward pass, plus biases);
3. ``grad_elu``: with ``jax.nn.elu`` and its derivative between the products;
3b. ``grad_fast_elu``: the same with ``rl.networks.elu`` (the networks' ELU: the same numbers,
   the derivative read from the output), so the two rungs differ only in the activation's cost;
4. ``grad_ppo``: the PPO loss (clipped surrogate, clipped value, entropy, KL) through
   ``rl.networks.ActorCritic``;
5. ``step``: plus gradient clipping and Adam (``rl.train``'s optimiser), one minibatch step;
6. ``epoch``: ``rl.train``'s minibatch scan over a shuffled 16,384-sample batch (4 minibatch
   steps, with the gather), divided by 4.

FLOPs are counted from the layer shapes as in ``bench.ppo_bench`` (the backward is 2x the
forward less the first layer's input gradient), so every rung is rated against the same
useful work. The difference between two rungs is what the added piece costs.

Run: ``python benchmarks/ppo_profile.py [--json]`` (about a minute on 2 idle cores).
"""

from __future__ import annotations

import argparse
import json
import time

import jax
import jax.numpy as jnp
import numpy as np
import optax

from dyncatch.bench.ppo_bench import gemm_peak_gflops, mlp_flops
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.networks import ActorCritic, elu
from dyncatch.rl.train import minibatch_loss
from dyncatch.sim.api import as_env
from dyncatch.sim.config import WorldCfg

ACTION_DIM = 3


def _time_all(ladder: dict, reps: int, repeats: int) -> dict[str, float]:
    """Best seconds per call of each rung's jitted function over ``repeats`` chains of
    ``reps`` calls, the rungs interleaved (one chain of each per round), so that a load
    from other processes falls on every rung alike."""
    for fn, args, _ in ladder.values():
        jax.block_until_ready(fn(*args))
    best = dict.fromkeys(ladder, float("inf"))
    for _ in range(repeats):
        for name, (fn, args, _) in ladder.items():
            t0 = time.perf_counter()
            for _ in range(reps):
                out = fn(*args)
            jax.block_until_ready(out)
            best[name] = min(best[name], (time.perf_counter() - t0) / reps)
    return best


def _dense_params(key, sizes):
    keys = jax.random.split(key, len(sizes) - 1)
    return [
        (
            jax.random.normal(k, (a, b), jnp.float32) / np.sqrt(a),
            jnp.zeros((b,), jnp.float32),
        )
        for k, a, b in zip(keys, sizes[:-1], sizes[1:], strict=True)
    ]


def _mlp(params, x, act):
    for i, (w, b) in enumerate(params):
        x = x @ w + b
        if i < len(params) - 1:
            x = act(x)
    return x


def rungs(obs_dim: int, ppo: PPOCfg, rows: int) -> dict:
    """name -> (jitted fn, args, calls per timed call): the ladder's functions."""
    hidden = list(ppo.hidden_sizes)
    actor_sizes = [obs_dim, *hidden, ACTION_DIM]
    critic_sizes = [obs_dim, *hidden, 1]
    key = jax.random.key(0)
    k_x, k_a, k_c, k_net = jax.random.split(key, 4)
    x = jax.random.normal(k_x, (rows, obs_dim), jnp.float32)
    actor, critic = _dense_params(k_a, actor_sizes), _dense_params(k_c, critic_sizes)

    @jax.jit
    def gemms(x, actor, critic):
        total = 0.0
        for params in (actor, critic):
            acts, h = [x], x
            for w, _ in params:  # forward
                h = h @ w
                acts.append(h)
            dy = jnp.ones_like(h)
            for i in range(len(params) - 1, -1, -1):  # backward
                w = params[i][0]
                total = total + jnp.sum(acts[i].T @ dy)  # weight gradient
                if i > 0:  # no input gradient for the first layer
                    dy = (dy @ w.T) * 0.5
        return total

    def two_mlps(act):
        def loss(p, x):
            return jnp.sum(_mlp(p[0], x, act)) + jnp.sum(_mlp(p[1], x, act))

        return jax.jit(jax.grad(loss))

    net = ActorCritic(ACTION_DIM, tuple(hidden), ppo.init_log_std)
    params = net.init(k_net, x[:1])
    mb = {
        "obs": x,
        "actions": jax.random.normal(key, (rows, ACTION_DIM)),
        "log_probs": jnp.zeros(rows),
        "advantages": jax.random.normal(key, (rows,)),
        "returns": jax.random.normal(key, (rows,)),
        "values": jnp.zeros(rows),
        "means": jnp.zeros((rows, ACTION_DIM)),
        "log_stds": jnp.zeros((rows, ACTION_DIM)),
    }

    def loss_fn(p, mb):
        return minibatch_loss(p, net, ppo, mb)

    grad_ppo = jax.jit(jax.grad(loss_fn, has_aux=True))
    optimizer = optax.chain(
        optax.clip_by_global_norm(ppo.max_grad_norm),
        optax.inject_hyperparams(optax.adam)(learning_rate=ppo.learning_rate),
    )
    opt_state = optimizer.init(params)

    def one_step(carry, mb):
        p, s = carry
        grads, _ = jax.grad(loss_fn, has_aux=True)(p, mb)
        updates, s = optimizer.update(grads, s, p)
        return (optax.apply_updates(p, updates), s), None

    step = jax.jit(lambda p, s, mb: one_step((p, s), mb)[0])

    n_mb = ppo.num_minibatches
    batch = {k: jnp.concatenate([v] * n_mb) for k, v in mb.items()}

    @jax.jit
    def epoch(p, s, batch, key):
        perm = jax.random.permutation(key, rows * n_mb)
        shuffled = jax.tree.map(lambda v: v[perm].reshape(n_mb, rows, *v.shape[1:]), batch)
        return jax.lax.scan(one_step, (p, s), shuffled)[0]

    flops = 3 * (mlp_flops(actor_sizes) + mlp_flops(critic_sizes)) - 2 * 2 * obs_dim * hidden[0]
    return {
        "flops_per_minibatch": flops * rows,
        "gemms": (gemms, (x, actor, critic), 1),
        "grad_linear": (two_mlps(lambda h: h), ((actor, critic), x), 1),
        "grad_elu": (two_mlps(jax.nn.elu), ((actor, critic), x), 1),
        "grad_fast_elu": (two_mlps(elu), ((actor, critic), x), 1),
        "grad_ppo": (grad_ppo, (params, mb), 1),
        "step": (step, (params, opt_state, mb), 1),
        "epoch": (epoch, (params, opt_state, batch, key), n_mb),
    }


def run(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    ppo = PPOCfg()
    obs_dim = as_env(WorldCfg()).observation_spec.shape[0]
    rows = ppo.batch_size // ppo.num_minibatches
    ladder = rungs(obs_dim, ppo, rows)
    flops = ladder.pop("flops_per_minibatch")
    hidden = max(ppo.hidden_sizes)
    peak = max(gemm_peak_gflops(m, hidden) for m in (1024, 4096))
    out = {"rows": rows, "obs_dim": obs_dim, "gemm_peak_gflops": peak, "rungs": []}
    times = _time_all(ladder, args.reps, args.repeats)
    for name, (_, _, calls) in ladder.items():
        dt = times[name] / calls
        rate = flops / dt / 1e9
        out["rungs"].append(
            {"rung": name, "ms_per_minibatch": 1e3 * dt, "gflops": rate, "of_peak": rate / peak}
        )
    if args.json:
        print(json.dumps(out))
    else:
        print(f"minibatch {rows} x {obs_dim}, GEMM peak {peak:.0f} GFLOP/s")
        print("| rung | ms per minibatch | GFLOP/s | of peak |\n|---|---:|---:|---:|")
        for r in out["rungs"]:
            print(
                f"| {r['rung']} | {r['ms_per_minibatch']:.1f} | {r['gflops']:.0f} | "
                f"{r['of_peak']:.2f} |"
            )
    return out


if __name__ == "__main__":
    from dyncatch.utils.jax_setup import setup_jax

    setup_jax()
    run()
