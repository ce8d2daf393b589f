"""GAE against hand-worked values and a plain loop; time-out bootstrapping."""

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.rl.gae import bootstrap_timeouts, gae


def test_two_steps_worked_by_hand():
    # gamma = 0.5, lambda = 0.5, one env, no episode end:
    # delta1 = 1 + 0.5*4 - 3 = 0;   A1 = 0
    # delta0 = 1 + 0.5*3 - 2 = 0.5; A0 = 0.5 + 0.25*0 = 0.5
    adv, ret = gae(
        jnp.array([[1.0], [1.0]]),
        jnp.array([[2.0], [3.0]]),
        jnp.array([[False], [False]]),
        jnp.array([4.0]),
        0.5,
        0.5,
    )
    np.testing.assert_allclose(adv[:, 0], [0.5, 0.0], atol=1e-6)
    np.testing.assert_allclose(ret[:, 0], [2.5, 3.0], atol=1e-6)


def test_episode_end_cuts_the_chain():
    # done at step 0: delta0 = 1 - 2 = -1 and A0 ignores step 1 entirely.
    adv, _ = gae(
        jnp.array([[1.0], [1.0]]),
        jnp.array([[2.0], [3.0]]),
        jnp.array([[True], [False]]),
        jnp.array([4.0]),
        0.5,
        0.5,
    )
    np.testing.assert_allclose(adv[:, 0], [-1.0, 0.0], atol=1e-6)


def test_scan_equals_a_plain_loop():
    k = jax.random.split(jax.random.key(0), 4)
    T, B, g, lam = 17, 5, 0.97, 0.9
    r = jax.random.normal(k[0], (T, B))
    v = jax.random.normal(k[1], (T, B))
    d = jax.random.bernoulli(k[2], 0.15, (T, B))
    last = jax.random.normal(k[3], (B,))
    adv, _ = gae(r, v, d, last, g, lam)
    r, v, d, last = map(np.asarray, (r, v, d, last))
    expected = np.zeros((T, B))
    for b in range(B):
        running = 0.0
        for t in reversed(range(T)):
            nv = last[b] if t == T - 1 else v[t + 1, b]
            nd = 0.0 if d[t, b] else 1.0
            delta = r[t, b] + g * nv * nd - v[t, b]
            running = delta + g * lam * nd * running
            expected[t, b] = running
    np.testing.assert_allclose(adv, expected, atol=1e-5)


def test_timeouts_credit_the_final_value_but_terminations_do_not():
    r = jnp.array([1.0, 1.0, 1.0])
    truncated = jnp.array([True, False, False])  # env 1 terminated, env 2 still running
    final_v = jnp.array([10.0, 10.0, 10.0])
    np.testing.assert_allclose(bootstrap_timeouts(r, truncated, final_v, 0.9), [10.0, 1.0, 1.0])
