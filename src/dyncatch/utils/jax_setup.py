"""Process-wide JAX settings used by every entry point (CLI, tests, benchmarks)."""

from __future__ import annotations

import os
from pathlib import Path

CPU_XLA_FLAGS = ("--xla_cpu_experimental_ynn_fusion_type=",)
"""XLA flags added to ``XLA_FLAGS`` unless it already sets them. XLA:CPU hands some fusions
to the YNNPACK library by default, among them reductions; the simulator's reductions are
over tiny minor axes (a norm of 2 or 3 components per environment), where the library call
is far slower than XLA's own loop: the open plane's step at 4096 environments took 3.19 ms
with it and 2.31-2.51 ms without it (no fusion to the library), while PPO's samples/s did
not change (25,488 against 25,453), measured 2026-12-02 (docs/performance.md, "XLA:CPU's
library fusions"). The flag only concerns the CPU backend."""


def compilation_cache_dir() -> Path:
    """The persistent compilation cache: ``$JAX_COMPILATION_CACHE_DIR``, else the user's
    cache folder (``$XDG_CACHE_HOME/dyncatch/jax``, ``~/.cache/dyncatch/jax``). Never the
    current folder: JAX loads compiled native code from the cache, so a cache inside a
    folder someone else wrote would run their code."""
    explicit = os.environ.get("JAX_COMPILATION_CACHE_DIR")
    if explicit:
        return Path(explicit)
    base = os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache"
    return Path(base) / "dyncatch" / "jax"


def with_cpu_flags(xla_flags: str) -> str:
    """``xla_flags`` with each of ``CPU_XLA_FLAGS`` appended unless it already names it."""
    flags = xla_flags.split()
    for flag in CPU_XLA_FLAGS:
        name = flag.split("=", 1)[0]
        if not any(f.split("=", 1)[0] == name for f in flags):
            flags.append(flag)
    return " ".join(flags)


def setup_jax(cache_dir: str | os.PathLike | None = None) -> None:
    """Turn on JAX's persistent compilation cache (``compilation_cache_dir``) and add
    ``CPU_XLA_FLAGS`` to ``XLA_FLAGS``.

    XLA reads its flags when the first backend starts, so call this before anything runs
    on a device; called later, the flags wait for the next process (a worker, a subprocess),
    which inherits them. Either way results agree to float rounding: the flags change how
    XLA:CPU emits code, not what it computes."""
    os.environ["XLA_FLAGS"] = with_cpu_flags(os.environ.get("XLA_FLAGS", ""))
    import jax

    path = cache_dir or compilation_cache_dir()
    Path(path).mkdir(parents=True, exist_ok=True)
    jax.config.update("jax_compilation_cache_dir", str(path))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.5)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
