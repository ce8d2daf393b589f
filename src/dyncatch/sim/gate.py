"""A per-environment function paid for only where a flag is set, at the level of the batch.

``where_active(fn, fractions)(active, *args)`` is, per environment,
``where(active, fn(*args), 0)``. Under ``vmap`` a ``where`` computes ``fn`` for every
environment; this one gathers the active environments into a compact sub-batch, computes
``fn`` on those rows only, and scatters the results back (zeros elsewhere). The sub-batch
has ``K = ceil(f * B)`` rows for the smallest ``f`` in ``fractions`` whose ``K`` holds every
active environment; when more are active than the largest ``K``, the whole batch is computed
(``lax.switch``: one branch runs). Below ``MIN_COMPACT_BATCH`` environments there are no
sub-batches: ``fn`` runs on the whole batch when any environment is active; ``fractions``
``()`` is no gate (the reference ``where``). Nested ``vmap``s (seeds around environments) are
folded into one batch of all their environments, so the gate works at any depth; arguments
that are not batched (the config) are passed to ``fn`` as they are. Each environment's result is
bit-identical to the reference ``where`` under one ``vmap`` (the same element-wise ``fn`` of
the same inputs); under nested ``vmap``s it equals the flat reference bit for bit, which
XLA:CPU itself compiles to within float rounding of the nested one (``tests/sim/test_gate.py``).

The users: the arm's control step with its IK (``sim.env``), which reaches in a few percent
of environments, and the auto-reset (``sim.vec``), which starts few episodes per step
(``docs/performance.md``).
Not differentiable in reverse mode (``custom_vmap``); nothing differentiates the simulator.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from functools import partial

import jax
import jax.numpy as jnp
from jax.custom_batching import custom_vmap

MIN_COMPACT_BATCH = 64
"""Batches below this many environments get no compact sub-batches: the gate is then "nobody
active, or the whole batch". Each sub-batch is one more compiled copy of ``fn``; below 64
environments a rollout must run for tens to hundreds of thousands of batch steps before the
time they save per step pays back the compilation they add (``benchmarks/gate_small_batch.py``;
the table in docs/performance.md, "The test suite"). The library trains on 512-4,096
environments and evaluates 100-500 episodes at once; the tests run 2-32."""


def compact_sizes(batch: int, fractions: Sequence[float]) -> list[int]:
    """Rows of the compact sub-batches for a batch of ``batch`` environments: ascending,
    each >= 1 and below ``batch`` (a sub-batch as large as the batch is the batch); none
    below ``MIN_COMPACT_BATCH`` environments."""
    if batch < MIN_COMPACT_BATCH:
        return []
    return sorted({k for f in fractions if (k := max(1, math.ceil(f * batch))) < batch})


def reference_where(fn: Callable, active: jax.Array, *args):
    """The ungated reference: ``fn`` computed, kept where ``active``, zeros elsewhere."""
    return jax.tree.map(lambda o: jnp.where(active, o, jnp.zeros_like(o)), fn(*args))


def where_active(fn: Callable, fractions: Sequence[float]) -> Callable:
    """``fn`` gated by a () bool ``active``: ``gated(active, *args)`` (see the module doc).

    ``fn`` takes pytrees of arrays for one environment and returns a pytree of arrays.
    For one environment ``fn`` runs only when ``active`` (``lax.cond``).
    """
    fractions = tuple(fractions)
    # Traced once per argument types: every branch below (the unbatched ``cond``, the
    # whole batch, each compact sub-batch, the shapes of "nobody") reuses the one trace of
    # ``fn``, inlined where it is called, so the program is what calling ``fn`` gives.
    fn = jax.jit(fn, inline=True)

    @custom_vmap
    def gated(active, *args):
        shapes = jax.eval_shape(fn, *args)
        zeros = partial(jax.tree.map, lambda s: jnp.zeros(s.shape, s.dtype), shapes)
        return jax.lax.cond(active, lambda: fn(*args), zeros)

    @gated.def_vmap
    def gated_vmap(axis_size, in_batched, active, *args):
        active_b, *args_b = in_batched
        if not active_b:
            active = jnp.broadcast_to(active, (axis_size,))
        leaves, treedef = jax.tree.flatten(args)
        flags = tuple(jax.tree.leaves(args_b))
        out = _flat_gate(fn, treedef, flags, fractions)(active, *leaves)
        return out, jax.tree.map(lambda _: True, out)

    return gated


def _flat_gate(fn: Callable, treedef, batched: tuple[bool, ...], fractions) -> Callable:
    """The gate over one flat batch: ``active`` (B,), the leaves of ``fn``'s arguments with
    a leading B axis where ``batched`` says so (the others are shared by the batch)."""
    axes = tuple(0 if b else None for b in batched)

    def call(*leaves):
        return fn(*jax.tree.unflatten(treedef, leaves))

    def everyone(active, leaves):
        return jax.vmap(partial(reference_where, call), in_axes=(0, *axes))(active, *leaves)

    def compact(active, leaves, k):
        # Padding indices point past the batch: their rows are gathered clipped (computed,
        # harmless) and dropped by the scatter, so only active rows are written.
        batch = active.shape[0]
        (idx,) = jnp.nonzero(active, size=k, fill_value=batch)
        rows = [
            jnp.take(x, idx, axis=0, mode="clip") if b else x
            for x, b in zip(leaves, batched, strict=True)
        ]
        out = jax.vmap(call, in_axes=axes)(*rows)
        return jax.tree.map(
            lambda o: (
                jnp.zeros((batch, *o.shape[1:]), o.dtype)
                .at[idx]
                .set(o, mode="drop", unique_indices=True)
            ),
            out,
        )

    def nobody(active, leaves):
        # One environment's output shapes, from the trace the other branches share.
        one = [
            jax.ShapeDtypeStruct(x.shape[1:] if b else x.shape, x.dtype, weak_type=weak)
            for x, b in zip(leaves, batched, strict=True)
            for weak in [getattr(jax.typeof(x), "weak_type", False)]
        ]
        shapes = jax.eval_shape(call, *one)
        return jax.tree.map(lambda s: jnp.zeros((active.shape[0], *s.shape), s.dtype), shapes)

    @custom_vmap
    def gate(active, *leaves):
        if not fractions:  # no gate: the reference
            return everyone(active, leaves)
        sizes = compact_sizes(active.shape[0], fractions)
        # Nothing when no environment is active, else the smallest sub-batch that holds every
        # active one, else the whole batch.
        branches = [partial(nobody, active, leaves)]
        branches += [partial(compact, active, leaves, k) for k in sizes]
        branches.append(partial(everyone, active, leaves))
        count = jnp.sum(active, dtype=jnp.int32)
        tier = sum((count > k).astype(jnp.int32) for k in (0, *sizes))
        return jax.lax.switch(tier, branches)

    @gate.def_vmap
    def gate_vmap(axis_size, in_batched, active, *leaves):
        # An outer vmap (e.g. over seeds) of size S: fold it into the batch, so that all
        # S x B environments share one compact sub-batch and no switch turns into a select.
        active_b, *leaves_b = in_batched
        batch = active.shape[-1]

        def fold(x, inner, outer):
            if not inner:  # one value per outer row, (S, ...): repeated over the batch
                x = jnp.broadcast_to(x[:, None], (axis_size, batch, *x.shape[1:]))
            elif not outer:  # one batch, (B, ...), shared by the outer rows
                x = jnp.broadcast_to(x, (axis_size, *x.shape))
            return x.reshape(axis_size * batch, *x.shape[2:])

        active = fold(active, True, active_b)
        new_leaves, new_batched = [], []
        for x, inner, outer in zip(leaves, batched, leaves_b, strict=True):
            shared = not inner and not outer
            new_leaves.append(x if shared else fold(x, inner, outer))
            new_batched.append(not shared)
        out = _flat_gate(fn, treedef, tuple(new_batched), fractions)(active, *new_leaves)
        out = jax.tree.map(lambda o: o.reshape(axis_size, batch, *o.shape[1:]), out)
        return out, jax.tree.map(lambda _: True, out)

    return gate
