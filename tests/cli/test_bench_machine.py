"""``dyncatch bench machine``: the probe's factors are its times over the reference's, every
compilation it times is a real one (none served from memory or the persistent cache), and
bad input is refused naming the flag."""

import json
from pathlib import Path

import jax

from dyncatch.bench import speed_probe
from dyncatch.cli.main import main


def _probe_entries() -> set[str]:
    """The probe's files in the persistent compilation cache (tests/conftest.py turns it on;
    the other test worker writes its own programs there meanwhile)."""
    path = Path(jax.config.jax_compilation_cache_dir)
    return {p.name for p in path.glob("jit_probe-*")} if path.exists() else set()


def test_bench_machine_gives_the_factors_of_fresh_compilations(capsys):
    """The printed factors are the times over the reference's; a second probe in the same
    process still compiles (a program JAX kept in memory would take microseconds), and
    neither leaves a persistent-cache entry that would let a later probe skip compiling,
    although the cache here keeps every program however fast it compiles."""
    assert main(["bench", "machine", "--json", "--repeats", "1"]) == 0  # sets JAX up
    r = json.loads(capsys.readouterr().out)
    name = "jax_persistent_cache_min_compile_time_secs"
    before = getattr(jax.config, name)
    jax.config.update(name, 0.0)
    try:
        again = speed_probe.probe_times(repeats=1)
        assert _probe_entries() == set()
        assert getattr(jax.config, name) == 0.0  # restored after the probe
        # The control: the same program compiled outside the probe is kept, under the name
        # looked for above (then removed, so the next run's check starts clean).
        params, x = speed_probe._inputs()
        speed_probe._program().lower(params, x).compile()
        kept = _probe_entries()
        assert kept
        for entry in kept:
            (Path(jax.config.jax_compilation_cache_dir) / entry).unlink()
    finally:
        jax.config.update(name, before)
    assert r["compute_s"] > 0 and r["compile_s"] > 0 and r["probe_wall_s"] >= r["compute_s"]
    assert r["compute_factor"] == r["compute_s"] / speed_probe.REF_COMPUTE_S
    assert r["compile_factor"] == r["compile_s"] / speed_probe.REF_COMPILE_S
    assert r["reference"] == {
        "compute_s": speed_probe.REF_COMPUTE_S,
        "compile_s": speed_probe.REF_COMPILE_S,
    }
    assert r["machine"]["cores"] >= 1
    assert again["compile_s"] > 0.2 * r["compile_s"] > 1e-3


def test_bad_repeats_are_refused_naming_the_flag(capsys):
    assert main(["bench", "machine", "--repeats", "0"]) == 2
    assert "--repeats must be at least 1" in capsys.readouterr().err
