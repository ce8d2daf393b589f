"""Supervised fitting of the predictor with eq. 4's loss, ||v - v_hat||_2, and Adam.

The data are encoded once (``encode_samples``); training draws minibatches with replacement
from the first ``n`` rows, so every budget of Table II shares one compiled update.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import optax

from dyncatch.predictor.config import TrainCfg
from dyncatch.predictor.data import Samples
from dyncatch.predictor.model import Predictor

_EPS_M2PS2 = 1e-8
"""Keeps the gradient of the norm finite at a perfect prediction."""


def encode_samples(predictor: Predictor, samples: Samples) -> tuple[np.ndarray, np.ndarray]:
    """(inputs (N, D), output yaws (N,)) for every sample."""
    x, yaw = jax.jit(jax.vmap(predictor.encode))(samples.history)
    return np.asarray(x), np.asarray(yaw)


def l2_error(v_hat: jax.Array, v: jax.Array) -> jax.Array:
    """Eq. 4 per sample: ||v - v_hat||_2, (N,) m/s."""
    return jnp.sqrt(jnp.sum((v - v_hat) ** 2, axis=-1) + _EPS_M2PS2)


def squared_error(v_hat: jax.Array, v: jax.Array) -> jax.Array:
    """||v - v_hat||_2^2 per sample, (N,) (m/s)^2."""
    return jnp.sum((v - v_hat) ** 2, axis=-1)


LOSSES = {"norm": l2_error, "squared": squared_error}
"""Per-sample training losses by name; the reported error is always ``l2_error``."""


def adam_cosine(cfg) -> optax.GradientTransformation:
    """Adam under a cosine decay from ``cfg.lr`` over ``cfg.updates`` steps to
    ``cfg.final_lr_frac`` of it (the predictor's and the tracker's optimiser)."""
    lr = optax.cosine_decay_schedule(cfg.lr, cfg.updates, alpha=cfg.final_lr_frac)
    return optax.adam(lr)


def minibatch_steps(loss_fn, opt, params, opt_state, n, key, batch_size: int, steps: int):
    """``steps`` Adam steps of ``loss_fn(params, idx)`` on minibatches of ``batch_size``
    indices drawn with replacement from ``n`` samples, in one ``lax.scan`` (traced inside
    the caller's jit). The normalisation statistics ``in_mean``/``in_std`` are data, not
    weights: their gradients are zeroed. Returns (params, opt_state, mean loss)."""

    def update(carry, k):
        params, opt_state = carry
        idx = jax.random.randint(k, (batch_size,), 0, n)
        loss, grads = jax.value_and_grad(loss_fn)(params, idx)
        grads = {
            **grads,
            "in_mean": jnp.zeros_like(grads["in_mean"]),
            "in_std": jnp.zeros_like(grads["in_std"]),
        }
        updates, opt_state = opt.update(grads, opt_state, params)
        return (optax.apply_updates(params, updates), opt_state), loss

    keys = jax.random.split(key, steps)
    (params, opt_state), losses = jax.lax.scan(update, (params, opt_state), keys)
    return params, opt_state, jnp.mean(losses)


@partial(jax.jit, static_argnames=("predictor", "cfg"))
def _train_chunk(predictor: Predictor, cfg: TrainCfg, params, opt_state, data, n, key):
    x, yaw, v = data

    def loss_fn(p, idx):
        v_hat = predictor.apply_encoded(p, x[idx], yaw[idx])
        return jnp.mean(LOSSES[cfg.loss](v_hat, v[idx]))

    opt = adam_cosine(cfg)
    return minibatch_steps(loss_fn, opt, params, opt_state, n, key, cfg.batch_size, cfg.log_every)


def fit(
    predictor: Predictor,
    cfg: TrainCfg,
    encoded: tuple[np.ndarray, np.ndarray],
    labels_mps: np.ndarray,
    n: int,
    key: jax.Array,
    on_log: Callable[[int, float], None] | None = None,
) -> tuple[dict, list[tuple[int, float]]]:
    """Train on the first ``n`` samples; returns (params, [(update, mean loss m/s), ...]).

    ``encoded`` is ``encode_samples``' output for all rows; ``on_log(update, loss)`` is called
    every ``cfg.log_every`` updates.
    """
    if n < 1:
        raise ValueError("no training samples: raise the budget (--steps) or check the world")
    x, yaw = encoded
    k_init, k_train = jax.random.split(key)
    params = predictor.init(k_init)
    params["in_mean"] = jnp.asarray(x[:n].mean(0))
    params["in_std"] = jnp.asarray(x[:n].std(0) + 1e-3)
    opt_state = adam_cosine(cfg).init(params)
    data = (jnp.asarray(x), jnp.asarray(yaw), jnp.asarray(labels_mps))
    log = []
    for chunk in range(max(cfg.updates // cfg.log_every, 1)):
        k = jax.random.fold_in(k_train, chunk)
        params, opt_state, loss = _train_chunk(
            predictor, cfg, params, opt_state, data, jnp.asarray(n), k
        )
        done = (chunk + 1) * cfg.log_every
        log.append((done, float(loss)))
        if on_log is not None:
            on_log(done, float(loss))
    return params, log


def evaluate(predictor: Predictor, params: dict, encoded, labels_mps: np.ndarray) -> float:
    """Mean ||v_hat - v||_2 (m/s) over the given samples."""
    x, yaw = encoded
    v_hat = jax.jit(predictor.apply_encoded)(params, jnp.asarray(x), jnp.asarray(yaw))
    return float(jnp.mean(l2_error(v_hat, jnp.asarray(labels_mps))))
