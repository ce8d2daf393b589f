"""The training loop's guard against non-finite numbers: a NaN or an infinity in a loss or
a parameter stops the run at the iteration it appears in, before it is logged or saved, so
the checkpoint on disk stays the last good state."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np


class NonFiniteError(ValueError):
    """Training produced a NaN or an infinity; the message names the iteration and what
    the checkpoint on disk holds."""


@jax.jit
def _finite_leaves(tree) -> dict[str, jax.Array]:
    """Per top-level part of ``tree``, whether every value in it is finite."""
    return {
        name: jnp.stack([jnp.isfinite(x).all() for x in jax.tree.leaves(part)]).all()
        for name, part in tree.items()
    }


def non_finite_parts(params, norm, metrics: Mapping[str, float]) -> list[str]:
    """The names of what is not finite: metric names (``loss``, ...), ``parameters``, or
    ``observation normaliser``; [] when all is well. ``params``/``norm`` of one run."""
    flags = jax.device_get(_finite_leaves({"parameters": params, "observation normaliser": norm}))
    bad = [name for name, ok in flags.items() if not bool(ok)]
    return bad + [k for k, v in metrics.items() if v != "" and not np.isfinite(float(v))]


def check_finite(
    params,
    norm,
    metrics: Mapping[str, float],
    iteration: int,
    checkpoint: Path,
    saved_iteration: int | None,
) -> None:
    """Raise ``NonFiniteError`` if ``iteration`` (1-based) produced a non-finite number.

    ``saved_iteration`` is the iteration of the checkpoint on disk (None: none written)."""
    bad = non_finite_parts(params, norm, metrics)
    if not bad:
        return
    kept = (
        f"{checkpoint} keeps the last good state (iteration {saved_iteration})"
        if saved_iteration is not None
        else "no checkpoint was written"
    )
    raise NonFiniteError(
        f"training stopped at iteration {iteration}: non-finite {', '.join(bad[:4])}; "
        f"{kept}; lower --ppo.learning-rate or check the --ppo coefficients"
    )
