"""Process-wide JAX settings used by every entry point (CLI, tests, benchmarks)."""

from __future__ import annotations

import os
from pathlib import Path


def compilation_cache_dir() -> Path:
    """The persistent compilation cache: ``$JAX_COMPILATION_CACHE_DIR`` or ``.cache/jax``."""
    return Path(os.environ.get("JAX_COMPILATION_CACHE_DIR") or Path(".cache") / "jax")


def setup_jax(cache_dir: str | os.PathLike | None = None) -> None:
    """Turn on JAX's persistent compilation cache (under ``.cache/jax`` by default)."""
    import jax

    path = cache_dir or compilation_cache_dir()
    Path(path).mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
