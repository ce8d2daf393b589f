"""Fitting the tracker by Gaussian negative log-likelihood, and measuring it.

The loss per sample is the NLL of the true position under the position Gaussian plus
``vel_weight`` times that of the true velocity (constants dropped). Measured on held-out
samples: the mean position error of the mean, the same for the sample-and-hold estimate
(the newest sighting), the velocity error and the fraction of true positions inside the
95 % ellipse (coverage95), overall and per bin of time since the newest capture.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.predictor.tracker.config import CHI2_2D_95, TrackerTrainCfg
from dyncatch.predictor.tracker.data import TrackSamples
from dyncatch.predictor.tracker.model import Gaussian, Tracker
from dyncatch.predictor.train import adam_cosine, minibatch_steps


def gaussian_nll(mean: jax.Array, std: jax.Array, value: jax.Array) -> jax.Array:
    """Negative log-likelihood of ``value`` under a diagonal Gaussian, summed over the last
    axis, without the constant: sum(log std + (value - mean)^2 / (2 std^2))."""
    return jnp.sum(jnp.log(std) + 0.5 * ((value - mean) / std) ** 2, axis=-1)


def nll_loss(g: Gaussian, label: jax.Array, vel_weight: float) -> jax.Array:
    """(N,) position NLL + ``vel_weight`` x velocity NLL."""
    pos = gaussian_nll(g.pos_m, g.pos_std_m, label[..., :2])
    vel = gaussian_nll(g.vel_mps, g.vel_std_mps, label[..., 2:])
    return pos + vel_weight * vel


@partial(jax.jit, static_argnames=("tracker", "cfg"))
def _train_chunk(tracker: Tracker, cfg: TrackerTrainCfg, params, opt_state, data, n, key):
    x, base, label = data

    def loss_fn(p, idx):
        g = tracker.apply_encoded(p, x[idx], base[idx])
        return jnp.mean(nll_loss(g, label[idx], cfg.vel_weight))

    opt = adam_cosine(cfg)
    return minibatch_steps(loss_fn, opt, params, opt_state, n, key, cfg.batch_size, cfg.log_every)


def fit_tracker(
    tracker: Tracker,
    cfg: TrackerTrainCfg,
    samples: TrackSamples,
    n: int,
    key: jax.Array,
    on_log: Callable[[int, float], None] | None = None,
) -> tuple[dict, list[tuple[int, float]]]:
    """Train on the first ``n`` samples; returns (params, [(update, mean NLL), ...])."""
    if n < 1:
        raise ValueError("no training samples: raise the budget (--steps) or check the world")
    k_init, k_train = jax.random.split(key)
    params = tracker.init(k_init)
    params["in_mean"] = jnp.asarray(samples.x[:n].mean(0))
    params["in_std"] = jnp.asarray(samples.x[:n].std(0) + 1e-3)
    opt_state = adam_cosine(cfg).init(params)
    data = tuple(jnp.asarray(a) for a in (samples.x, samples.base, samples.label))
    log = []
    for chunk in range(max(cfg.updates // cfg.log_every, 1)):
        k = jax.random.fold_in(k_train, chunk)
        params, opt_state, loss = _train_chunk(
            tracker, cfg, params, opt_state, data, jnp.asarray(n), k
        )
        done = (chunk + 1) * cfg.log_every
        log.append((done, float(loss)))
        if on_log is not None:
            on_log(done, float(loss))
    return params, log


TAU_BINS_S = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
"""Edges of the time-since-capture bins of ``error_by_time_since_sighting``."""


def per_sample(tracker: Tracker, params: dict, samples: TrackSamples) -> dict[str, np.ndarray]:
    """Per held-out sample: ``position_error_m``, ``hold_position_error_m``,
    ``velocity_error_mps``, ``inside95`` (bool) and ``pos_std_m`` (RMS of the two axes)."""
    g = jax.jit(tracker.apply_encoded)(params, jnp.asarray(samples.x), jnp.asarray(samples.base))
    g = jax.device_get(g)
    true_p, true_v = samples.label[:, :2], samples.label[:, 2:]
    mahal2 = np.sum(((true_p - g.pos_m) / g.pos_std_m) ** 2, axis=-1)
    return {
        "position_error_m": np.linalg.norm(g.pos_m - true_p, axis=-1),
        "hold_position_error_m": np.linalg.norm(samples.hold_m - true_p, axis=-1),
        "velocity_error_mps": np.linalg.norm(g.vel_mps - true_v, axis=-1),
        "inside95": mahal2 <= CHI2_2D_95,
        "pos_std_m": np.sqrt(np.mean(g.pos_std_m**2, axis=-1)),
    }


def evaluate_tracker(tracker: Tracker, params: dict, samples: TrackSamples) -> dict[str, float]:
    """``position_error_m``, ``hold_position_error_m``, ``velocity_error_mps`` (means) and
    ``coverage95`` over the held-out samples."""
    s = per_sample(tracker, params, samples)
    return {
        "position_error_m": float(s["position_error_m"].mean()),
        "hold_position_error_m": float(s["hold_position_error_m"].mean()),
        "velocity_error_mps": float(s["velocity_error_mps"].mean()),
        "coverage95": float(s["inside95"].mean()),
    }


def error_by_time_since_sighting(
    tracker: Tracker, params: dict, samples: TrackSamples, edges_s=TAU_BINS_S
) -> list[dict]:
    """One row per non-empty bin of time since the newest capture: ``lo_s``, ``hi_s``,
    ``samples`` and the means of ``per_sample``'s quantities (``inside95`` as coverage95)."""
    s = per_sample(tracker, params, samples)
    tau = samples.since_sighting_s
    rows = []
    for lo, hi in zip(edges_s[:-1], edges_s[1:], strict=True):
        sel = (tau >= lo) & (tau < hi)
        if sel.any():
            rows.append(
                {
                    "lo_s": lo,
                    "hi_s": hi,
                    "samples": int(sel.sum()),
                    "position_error_m": float(s["position_error_m"][sel].mean()),
                    "hold_position_error_m": float(s["hold_position_error_m"][sel].mean()),
                    "pos_std_m": float(s["pos_std_m"][sel].mean()),
                    "coverage95": float(s["inside95"][sel].mean()),
                }
            )
    return rows
