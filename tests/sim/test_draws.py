"""A step's random draws (``sim.draws``): one split, normals as ``jax.random.normal`` makes them."""

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim.draws import GAIT_NORMALS, SENSE_NORMALS, _normals, step_draws


def test_words_become_normals_exactly_as_jax_random_normal_maps_them():
    for seed in range(4):
        key = jax.random.key(seed)
        words = jax.random.bits(key, (1000,), jnp.uint32)
        np.testing.assert_array_equal(_normals(words), jax.random.normal(key, (1000,)))


def test_extreme_words_give_finite_normals():
    words = jnp.array([0, 1, 511, 512, 2**31, 2**32 - 512, 2**32 - 1], jnp.uint32)
    z = np.asarray(_normals(words))
    assert np.all(np.isfinite(z))
    assert z[0] < -5.0 and z[-1] > 5.0 and abs(z[4]) < 1e-6


def test_the_draws_are_standard_normal_and_independent_across_keys_and_steps():
    keys = jax.random.split(jax.random.key(0), 20_000)
    d = jax.vmap(step_draws)(keys)
    z = np.concatenate([np.asarray(d.gait_noise), np.asarray(d.sense_noise)], axis=1)
    assert z.shape == (20_000, GAIT_NORMALS + SENSE_NORMALS)
    # Mean 0 and variance 1 within 5 standard errors; no correlation between the columns.
    assert np.all(np.abs(z.mean(0)) < 5 / np.sqrt(20_000))
    assert np.all(np.abs(z.var(0) - 1.0) < 5 * np.sqrt(2 / 20_000))
    corr = np.corrcoef(z.T) - np.eye(z.shape[1])
    assert np.abs(corr).max() < 5 / np.sqrt(20_000)
    # The next step's draws are fresh: uncorrelated with this step's.
    z_next = np.asarray(jax.vmap(step_draws)(d.next_key).gait_noise)
    assert abs(np.corrcoef(z[:, 0], z_next[:, 0])[0, 1]) < 5 / np.sqrt(20_000)


def test_the_keys_are_distinct_and_the_draws_deterministic():
    d = step_draws(jax.random.key(3))
    data = [jax.random.key_data(k) for k in (jax.random.key(3), d.next_key, d.behavior_key)]
    assert len({tuple(np.asarray(x).tolist()) for x in data}) == 3
    again = step_draws(jax.random.key(3))
    for a, b in zip(jax.tree.leaves(d), jax.tree.leaves(again), strict=True):
        if jax.dtypes.issubdtype(a.dtype, jax.dtypes.prng_key):
            a, b = jax.random.key_data(a), jax.random.key_data(b)
        np.testing.assert_array_equal(a, b)


def test_other_key_implementations_work_too():
    d = step_draws(jax.random.key(0, impl="rbg"))
    assert jax.random.key_impl(d.next_key) == jax.random.key_impl(jax.random.key(0, impl="rbg"))
    assert np.all(np.isfinite(np.asarray(d.gait_noise)))
