"""Shared test set-up: JAX's persistent compilation cache, so reruns skip compilation."""

from dyncatch.utils.jax_setup import setup_jax

setup_jax()
