"""Simulator throughput for docs/performance.md: ``python benchmarks/env_throughput.py``.

Same as ``dyncatch bench env`` (which ``make bench`` runs); kept here so the benchmark
scripts of the project live in one folder.
"""

from dyncatch.cli.bench import EnvBenchCmd, run_env_bench
from dyncatch.utils.jax_setup import setup_jax

if __name__ == "__main__":
    setup_jax()
    run_env_bench(EnvBenchCmd())
