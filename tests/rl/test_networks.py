"""The networks' ELU is ``jax.nn.elu`` bit for bit, in values, gradients and training."""

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import dyncatch.rl.networks as networks
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.train import make_train, minibatch_loss
from dyncatch.sim.config import WorldCfg

EDGES = [0.0, -0.0, 1e-30, -1e-30, 1e-7, -1e-7, 0.5, -0.5, 20.0, -20.0, -200.0, 3e38, -3e38]


def _inputs():
    scales = jnp.array([1e-4, 1e-2, 1.0, 10.0])[:, None]
    x = jax.random.normal(jax.random.key(0), (4, 4096)) * scales
    return jnp.concatenate([x.ravel(), jnp.array(EDGES + [np.inf, -np.inf])])


def _grad(f, x):
    # A cotangent that is not all ones, so the multiply by the derivative is exercised.
    g = jnp.cos(jnp.arange(x.size, dtype=jnp.float32))
    return jax.vjp(f, x)[1](g)[0]


def test_elu_values_and_gradients_equal_jax_nn_elu_bit_for_bit():
    x = _inputs()
    np.testing.assert_array_equal(jax.jit(networks.elu)(x), jax.jit(jax.nn.elu)(x))
    fast = jax.jit(lambda x: _grad(networks.elu, x))(x)
    ref = jax.jit(lambda x: _grad(jax.nn.elu, x))(x)
    np.testing.assert_array_equal(fast, ref)
    # Hand-worked: elu(-1) = e^-1 - 1, elu'(-1) = e^-1, elu'(2) = 1, elu'(0) = exp(0) = 1.
    pts = jnp.array([-1.0, 2.0, 0.0])
    np.testing.assert_allclose(networks.elu(pts), [np.exp(-1) - 1, 2.0, 0.0], rtol=1e-6)
    d = jax.vmap(jax.grad(networks.elu))(pts)
    np.testing.assert_allclose(d, [np.exp(-1), 1.0, 1.0], rtol=1e-6)


def test_elu_of_nan_is_nan():
    assert jnp.isnan(networks.elu(jnp.array(jnp.nan)))


def _minibatch(rows: int, obs_dim: int, key: jax.Array) -> dict[str, jax.Array]:
    k = jax.random.split(key, 5)
    return {
        "obs": jax.random.normal(k[0], (rows, obs_dim)),
        "actions": jax.random.normal(k[1], (rows, 3)),
        "log_probs": jax.random.normal(k[2], (rows,)),
        "advantages": jax.random.normal(k[3], (rows,)),
        "returns": jax.random.normal(k[4], (rows,)),
        "values": jnp.zeros(rows),
        "means": jnp.zeros((rows, 3)),
        "log_stds": jnp.zeros((rows, 3)),
    }


def test_ppo_gradient_with_the_fast_elu_is_bit_identical(monkeypatch):
    ppo = PPOCfg(hidden_sizes=(64, 64, 32))
    net = networks.ActorCritic(3, ppo.hidden_sizes)
    mb = _minibatch(512, 15, jax.random.key(1))
    params = net.init(jax.random.key(2), mb["obs"][:1])

    def grad():
        f = jax.jit(jax.grad(lambda p: minibatch_loss(p, net, ppo, mb), has_aux=True))
        return jax.device_get(f(params)[0])

    fast = grad()
    with monkeypatch.context() as m:
        m.setattr(networks, "elu", jax.nn.elu)
        ref = grad()
    for a, b in zip(jax.tree.leaves(fast), jax.tree.leaves(ref), strict=True):
        np.testing.assert_array_equal(a, b)


# Two training programs compiled (about 19 s on 2 idle cores, the suite's sixth slowest):
# the PPO loss and gradient with the fast ELU are checked bit for bit above, and every
# training test trains with it.
@pytest.mark.extended
def test_training_with_the_fast_elu_matches_jax_nn_elu(monkeypatch):
    """Parameters after 2 PPO iterations with ``jax.nn.elu`` in the networks and with
    ``networks.elu``. With the library's XLA settings they are equal bit for bit (measured
    at 256-256-128 and here); the tests' settings (LLVM -O0 and the older fusion emitters,
    Makefile ``TEST_ENV``) may order the bias reductions differently in the two programs, so
    here they agree to float32 rounding, amplified by 4 Adam steps."""
    ppo = PPOCfg(
        num_envs=32, num_steps=8, num_minibatches=2, update_epochs=2, hidden_sizes=(32, 16)
    )
    world = WorldCfg().with_behavior("circle")

    def run():
        init, iterate, _ = make_train(world, ppo)
        ts = jax.jit(init)(jax.random.key(3))
        step = jax.jit(iterate)
        for _ in range(2):
            ts, _ = step(ts)
        return jax.device_get(ts.params)

    fast = run()
    with monkeypatch.context() as m:
        m.setattr(networks, "elu", jax.nn.elu)
        ref = run()
    for a, b in zip(jax.tree.leaves(fast), jax.tree.leaves(ref), strict=True):
        np.testing.assert_allclose(a, b, rtol=1e-3, atol=1e-6)
