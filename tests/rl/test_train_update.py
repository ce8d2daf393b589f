"""The update's minibatch order: the same permutations as one ``permutation`` per epoch."""

import jax
import numpy as np

from dyncatch.rl.train import epoch_permutations


def test_epoch_permutations_are_each_epochs_own_permutation():
    key = jax.random.key(7)
    perms = jax.jit(epoch_permutations, static_argnums=(1, 2))(key, 4, 1000)
    assert perms.shape == (4, 1000)
    for i, k in enumerate(jax.random.split(key, 4)):
        np.testing.assert_array_equal(perms[i], jax.random.permutation(k, 1000))
    np.testing.assert_array_equal(np.sort(perms, axis=1), np.tile(np.arange(1000), (4, 1)))
    assert len({tuple(p[:10]) for p in np.asarray(perms)}) == 4
