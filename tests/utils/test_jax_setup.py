"""XLA's flags from ``setup_jax``, and that nothing starts a JAX backend before they are set."""

import os
import subprocess
import sys

from dyncatch.utils.jax_setup import CPU_XLA_FLAGS, with_cpu_flags

YNN = "--xla_cpu_experimental_ynn_fusion_type"


def test_the_flags_are_appended_to_what_the_user_set():
    assert with_cpu_flags("") == " ".join(CPU_XLA_FLAGS)
    flags = with_cpu_flags("--xla_force_host_platform_device_count=2").split()
    assert flags[0] == "--xla_force_host_platform_device_count=2"
    assert f"{YNN}=" in flags


def test_a_flag_the_user_set_is_kept_as_set():
    mine = f"{YNN}=dot --xla_cpu_use_fusion_emitters=false"
    assert with_cpu_flags(mine) == mine
    assert with_cpu_flags(with_cpu_flags("")) == with_cpu_flags("")


def test_importing_dyncatch_and_parsing_a_command_start_no_backend():
    # XLA reads its flags when the first backend starts: an array made at import time (a
    # module-level jnp constant) would start it before the CLI calls setup_jax.
    code = (
        "import pkgutil, importlib, dyncatch\n"
        "import jax._src.xla_bridge as xb\n"
        "from dyncatch.cli.main import parse\n"
        "for m in pkgutil.walk_packages(dyncatch.__path__, 'dyncatch.'):\n"
        "    importlib.import_module(m.name)\n"
        "    assert not xb._backends, m.name\n"
        "for argv in (['bench', 'env'], ['bench', 'ppo'], ['train'], ['reproduce']):\n"
        "    parse(argv)\n"
        "    assert not xb._backends, argv\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr[-2000:]


def test_the_simulator_step_compiles_without_library_reductions():
    # conftest.py ran setup_jax before any test: a norm over (3,) is XLA's own loop.
    import jax
    import jax.numpy as jnp

    text = (
        jax.jit(lambda x: jnp.linalg.norm(x, axis=-1))
        .lower(jnp.ones((4096, 3)))
        .compile()
        .as_text()
    )
    assert "__ynn_fusion" not in text


def test_the_compile_cache_lives_in_the_user_cache_folder(monkeypatch, tmp_path):
    from pathlib import Path

    from dyncatch.utils.jax_setup import compilation_cache_dir

    monkeypatch.delenv("JAX_COMPILATION_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert compilation_cache_dir() == tmp_path / "xdg" / "dyncatch" / "jax"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert compilation_cache_dir() == Path(tmp_path / "home" / ".cache" / "dyncatch" / "jax")
    monkeypatch.setenv("JAX_COMPILATION_CACHE_DIR", str(tmp_path / "mine"))
    assert compilation_cache_dir() == tmp_path / "mine"
