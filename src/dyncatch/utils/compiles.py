"""Count XLA compilations: which jitted programs a block of code compiled, and their seconds."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

from jax import monitoring

_COMPILE_EVENT = "/jax/core/compile/backend_compile_duration"
"""JAX's event around each XLA compilation (a load from the persistent cache included)."""


@dataclass
class CompileLog:
    """(program name, seconds) of each compilation, in order. A name is JAX's module name
    of the jitted function (``jit(_run_impl)`` for ``_run_impl``)."""

    entries: list[tuple[str, float]] = field(default_factory=list)

    def of(self, name: str) -> list[float]:
        """Seconds of each compilation of the jitted function ``name`` (``jit(<name>)``)."""
        return [s for n, s in self.entries if n == f"jit({name})"]

    @property
    def seconds(self) -> float:
        return sum(s for _, s in self.entries)


@contextmanager
def compile_log() -> Iterator[CompileLog]:
    """``with compile_log() as log:`` records every XLA compilation in the block (eager
    operations' small ones too; ``log.of(name)`` picks one function's)."""
    log = CompileLog()

    def listen(event: str, duration: float, **kwargs) -> None:
        if event == _COMPILE_EVENT:
            log.entries.append((str(kwargs.get("fun_name", "")), duration))

    monitoring.register_event_duration_secs_listener(listen)
    try:
        yield log
    finally:
        monitoring.unregister_event_duration_listener(listen)
