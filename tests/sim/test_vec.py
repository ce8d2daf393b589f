"""Auto-reset (``sim.vec``): fresh episodes computed only where one ended equal the ungated
reset computed everywhere."""

import functools

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.sim import vec
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg

ENV = JaxCatchEnv(WorldCfg())
N = 256


@functools.partial(jax.jit, static_argnums=0)
def _ending(count: int, key: jax.Array | None = None):
    """A batch of N fresh episodes of which ``count`` time out on the next step (one program
    per count: run eagerly, every operation of the reset compiled on its own)."""
    state = vec.batch_reset(jax.random.key(0) if key is None else key, ENV, N)
    last = ENV.world.episode.max_steps - 1
    ends = jnp.zeros(N, bool).at[jax.random.permutation(jax.random.key(1), N)[:count]].set(True)
    return state.replace(step=jnp.where(ends, last, 5)), ends


def _leaves(tree):
    return [
        jax.random.key_data(x) if jax.dtypes.issubdtype(x.dtype, jax.dtypes.prng_key) else x
        for x in jax.tree.leaves(tree)
    ]


PRODUCTION_CODEGEN = {"xla_cpu_use_fusion_emitters": True}
"""XLA:CPU's default fusion emitters, which the library runs with. ``make test`` compiles
with the older emitters (faster to compile, Makefile); under those the whole-batch branch of
the gate rounds differently from the same reset outside a branch (measured: this test fails
for 3, 20, 100 and 256 ending), so the bit-for-bit claim is checked on the library's code
generation."""


def _compiled_step(state, actions):
    # A fresh function each time, so the fractions are read when it is traced.
    fn = jax.jit(lambda s, a, e: vec.batch_step_with_final(s, a, e))
    return fn.lower(state, actions, ENV).compile(compiler_options=PRODUCTION_CODEGEN)


def _switches(state, actions) -> int:
    """Conds in the traced batched step: one per gate (the arm's control step, the reset)."""
    return str(jax.make_jaxpr(lambda s, a: vec.batch_step(s, a, ENV))(state, actions)).count(
        "cond["
    )


def _actions():
    return jax.random.uniform(jax.random.key(2), (N, 3), minval=-1.0, maxval=1.0)


@pytest.fixture(scope="module")
def steps():
    """The gated and the ungated batched step, each compiled once for every ``count`` below
    (the counts change the data, not the program)."""
    state, actions = _ending(0)[0], _actions()
    gated, switches = _compiled_step(state, actions), _switches(state, actions)
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(vec, "RESET_COMPACT_FRACTIONS", ())
        ungated, ungated_switches = _compiled_step(state, actions), _switches(state, actions)
    assert ungated_switches == switches - 1  # the reset's gate is gone
    return gated, ungated


# With 256 environments the sub-batches have 4 and 32 rows: 0 and 3 ending fit the first,
# 20 the second, 100 and all of them need the whole batch.
@pytest.mark.parametrize("count", [0, 3, 20, 100, N])
def test_gated_auto_reset_equals_the_ungated_one(steps, count):
    state, ends = _ending(count)
    gated_step, ungated_step = steps
    gated, ungated = gated_step(state, _actions(), ENV), ungated_step(state, _actions(), ENV)
    np.testing.assert_array_equal(gated[3], ends)
    for a, b in zip(_leaves(gated), _leaves(ungated), strict=True):
        np.testing.assert_array_equal(a, b)
    assert bool(jnp.all(jnp.where(ends, gated[0].step == 0, gated[0].step == 6)))


def test_nested_vmap_over_seeds(monkeypatch):
    # Two seeds of 256 environments fold into one batch of 512 (sub-batches of 8 and 64).
    states, ends = jax.vmap(lambda k: _ending(10, k))(jax.random.split(jax.random.key(3), 2))
    actions = jnp.zeros((2, N, 3))
    run = jax.vmap(vec.batch_step, in_axes=(0, 0, None))
    gated = jax.jit(lambda s, a, e: run(s, a, e))(states, actions, ENV)
    monkeypatch.setattr(vec, "RESET_COMPACT_FRACTIONS", ())
    ungated = jax.jit(lambda s, a, e: run(s, a, e))(states, actions, ENV)
    np.testing.assert_array_equal(gated[3], ends)
    for a, b in zip(_leaves(gated), _leaves(ungated), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-5, atol=1e-5)


@pytest.mark.parametrize("scene", ["open_plane", "woods_plane"])
def test_a_reset_state_has_the_types_of_a_stepped_one(scene):
    # A jitted function of states (PPO's iteration) compiles once for both: a weakly typed
    # leaf in the reset state alone made every training run compile its iteration twice.
    # The types a jit sees, weak types included, without running either (eval_shape traces).
    env = JaxCatchEnv(WorldCfg().for_scene(scene))
    reset = jax.eval_shape(lambda k: vec.batch_reset(k, env, 4), jax.random.key(0))
    stepped = jax.eval_shape(lambda s: vec.batch_step(s, jnp.zeros((4, 3)), env)[0], reset)
    assert jax.tree.structure(reset) == jax.tree.structure(stepped)
    flat_reset = jax.tree_util.tree_flatten_with_path(reset)[0]
    for (path, a), b in zip(flat_reset, jax.tree.leaves(stepped), strict=True):
        assert (a.shape, a.dtype, a.weak_type) == (b.shape, b.dtype, b.weak_type), (
            jax.tree_util.keystr(path)
        )
