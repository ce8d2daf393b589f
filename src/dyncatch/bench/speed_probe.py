"""How fast this machine computes and compiles, against the machine the reproduction's
estimate was fit on (``dyncatch.reproduce.estimate``): a probe of a few seconds.

The estimate's constants are seconds on one machine, the idle 2-core Intel Xeon of the docs;
on another the same work takes another time, and the two ways differ: a machine's speed at
compiling drifts more than its speed at computing (docs/performance.md). So the probe times
two things apart:

* **compute**: one jitted program that does what a training iteration does most, a
  128-128-64 ELU network's forward and backward pass over a 4,096-sample minibatch and a
  parameter step (the update's products), then an element-wise chain over the batch (the
  simulator's and the normaliser's kind of work): the best of ``repeats`` runs;
* **compile**: XLA's compilation of that program, from its lowered form, the best of
  ``repeats`` compilations, none written to the persistent cache (its minimum compile time
  is raised while the probe compiles), so a warm cache cannot hide the machine's speed.

Each time over its reference (``REF_*``) is the machine's factor (``MachineSpeed``: 1.3 =
30 % slower than the reference). ``dyncatch bench machine`` prints them.
"""

from __future__ import annotations

import time
from contextlib import contextmanager
from dataclasses import dataclass

import jax
import jax.numpy as jnp


@dataclass(frozen=True)
class MachineSpeed:
    """A machine's time for the same work over the reference machine's (the idle 2-core Xeon
    the estimate's constants were fit on): 1.3 is 30 % slower, 0.5 twice as fast."""

    compute: float = 1.0
    """For work that runs compiled programs (training, evaluation, predictors)."""
    compile: float = 1.0
    """For XLA's compilations of them."""


REFERENCE = MachineSpeed()
"""The reference machine itself: the estimate's constants as they are."""

PROBE_SIZES = (13, 128, 128, 64, 4)
"""The probe network's layers: the standard actor's input width and hidden sizes."""
PROBE_ROWS = 4096
"""Samples per pass: a standard minibatch (512 x 32 / 4)."""
PROBE_PASSES = 24
"""Forward-backward passes per run: about 0.1 s on the reference machine."""

REF_COMPUTE_S = 0.109
"""The probe's compute seconds on the reference machine, read through a machine measured
against the estimate: on the idle 2-core AMD EPYC of 2026-12-07 the probe took 0.123 and
0.131 s (mean 0.127), and the same machine ran at 1.165x the estimate's compute time: a 4 M
step ``dyncatch train --method rl --eval-every 0`` spent 56.6 and 57.1 s in its iterations
against the estimate's 48.9 s (1.158x, 1.167x), and the quick profile's stages fit 1.173x
(``benchmarks/reproduce_stages.py``; the next line). 0.127 / 1.165."""
REF_COMPILE_S = 0.205
"""The probe's compile seconds on the reference machine, read the same way: 0.240 and
0.251 s (mean 0.246) on that EPYC, whose compilations took 1.201x the estimate's: the least
squares of the quick profile's seven stages (an empty compilation cache; 284 s against the
estimate's 236 s) on their work and compilation parts gave 1.173x and 1.201x. 0.246 /
1.201."""


def _elu(x: jax.Array) -> jax.Array:
    return jnp.where(x > 0.0, x, jnp.expm1(jnp.minimum(x, 0.0)))


def _loss(params, x: jax.Array) -> jax.Array:
    h = x
    for i, (w, b) in enumerate(params):
        h = h @ w + b
        if i < len(params) - 1:
            h = _elu(h)
    return jnp.mean(h * h)


def _program():
    """The probe as a new jitted function: JAX keeps compiled programs in memory per Python
    function, so a new one compiles again (the persistent cache aside, ``_no_cache_writes``)."""

    def probe(params, x: jax.Array):
        def one(_, carry):
            params, x = carry
            g = jax.grad(_loss)(params, x)
            params = jax.tree.map(lambda p, d: p - 1e-3 * d, params, g)
            # Element-wise work of the simulator's kind: angles, norms, a clip and a select.
            y = jnp.sin(x) * jnp.cos(0.5 * x) + jnp.sqrt(x * x + 1.0)
            x = jnp.where(y > 1.0, jnp.clip(0.5 * y, -3.0, 3.0), x - 1e-2 * y)
            return params, x

        return jax.lax.fori_loop(0, PROBE_PASSES, one, (params, x))

    return jax.jit(probe)


def _inputs():
    keys = jax.random.split(jax.random.key(0), len(PROBE_SIZES))
    params = [
        (jax.random.normal(k, (a, b), jnp.float32) / jnp.sqrt(a), jnp.zeros((b,), jnp.float32))
        for k, a, b in zip(keys[:-1], PROBE_SIZES[:-1], PROBE_SIZES[1:], strict=True)
    ]
    x = jax.random.normal(keys[-1], (PROBE_ROWS, PROBE_SIZES[0]), jnp.float32)
    return params, x


@contextmanager
def _no_cache_writes():
    """No persistent-cache entry written while inside (so the next probe compiles again)."""
    name = "jax_persistent_cache_min_compile_time_secs"
    before = getattr(jax.config, name)
    jax.config.update(name, 1e9)
    try:
        yield
    finally:
        jax.config.update(name, before)


def probe_times(repeats: int = 3) -> dict:
    """Seconds of the probe's best compilation and best run on this machine."""
    params, x = _inputs()
    compile_s = []
    with _no_cache_writes():
        for _ in range(repeats):
            lowered = _program().lower(params, x)
            t0 = time.perf_counter()
            compiled = lowered.compile()
            compile_s.append(time.perf_counter() - t0)
    jax.block_until_ready(compiled(params, x))  # first run: memory, threads
    compute_s = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(compiled(params, x))
        compute_s.append(time.perf_counter() - t0)
    return {"compute_s": min(compute_s), "compile_s": min(compile_s)}


def speed_of(times: dict) -> MachineSpeed:
    """The factors of probe ``times`` against the reference machine's."""
    return MachineSpeed(
        compute=times["compute_s"] / REF_COMPUTE_S, compile=times["compile_s"] / REF_COMPILE_S
    )


def probe_speed(repeats: int = 3) -> tuple[MachineSpeed, dict]:
    """This machine's ``MachineSpeed`` and the probe's times (with its own wall seconds)."""
    t0 = time.perf_counter()
    times = probe_times(repeats)
    times["probe_wall_s"] = time.perf_counter() - t0
    return speed_of(times), times
