"""The core library imports without its optional dependencies (pyproject's extras).

A machine with only the core dependencies (a GPU image, a cluster node) runs ``dyncatch
train``, ``eval``, ``bench`` and ``reproduce``: their modules may import an extra's package
only where it is used. Checked in a fresh interpreter whose import system refuses the extras'
packages, so an eager import anywhere in the command tree fails the test.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap

OPTIONAL = ("mujoco", "gym_quadruped", "proxsuite", "qpsolvers", "ray", "wandb", "onnxruntime")
"""Top-level packages of the extras (fullbody, ray, dev) that the core must not need."""

_PROBE = textwrap.dedent(
    """
    import sys

    BLOCKED = set(sys.argv[1].split(","))

    class Refuse:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in BLOCKED:
                raise ModuleNotFoundError(f"No module named {name!r} (blocked)", name=name)
            return None

    sys.meta_path.insert(0, Refuse())
    import dyncatch.cli.main  # noqa: F401  the whole command tree

    print("ok")
    """
)


def test_cli_imports_without_the_extras():
    done = subprocess.run(
        [sys.executable, "-c", _PROBE, ",".join(OPTIONAL)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert done.stdout.strip() == "ok"
