"""The package's layers import only downward, and no two folders import each other.

Read over ``ast`` (nothing is imported): every ``import``/``from`` statement, at module top
or inside a function, that names a ``dyncatch`` module. ``if TYPE_CHECKING:`` blocks count
too: a type is a dependency.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "dyncatch"

LAYERS = (
    "utils",
    "sim",
    "policies",
    "predictor",
    "fullbody",
    "evaluation",
    "rl",
    "export",
    "viz",
    "gym",
    "bench",
    "reproduce",
    "cli",
)
"""Low to high: a folder may import its own and the ones before it."""

TOP_MAY_IMPORT = {"gym"}
"""What ``dyncatch/__init__.py`` imports (the Gymnasium ids are registered on import)."""


def _folder(module: str) -> str | None:
    """The layer of a dotted ``dyncatch.<folder>...`` name; None for ``dyncatch`` itself."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 and parts[0] == "dyncatch" else None


def imports_of(path: Path, source: str | None = None) -> list[tuple[int, str]]:
    """(line, imported dyncatch module) of every import in the file, local ones included.

    ``from dyncatch import x`` names ``dyncatch.x`` (a sub-package); relative imports are
    resolved against the file's package.
    """
    tree = ast.parse(source if source is not None else path.read_text(), str(path))
    package = ["dyncatch", *path.relative_to(SRC).parent.parts]
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names if a.name.startswith("dyncatch")]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            if module == "dyncatch":
                out += [(node.lineno, f"dyncatch.{a.name}") for a in node.names]
            elif module.startswith("dyncatch."):
                out.append((node.lineno, module))
    return out


def upward_imports(files: dict[Path, str] | None = None) -> list[str]:
    """``file:line: folder imports higher folder (module)`` for each import against LAYERS."""
    rank = {name: i for i, name in enumerate(LAYERS)}
    problems = []
    for path, source in _sources(files).items():
        rel = path.relative_to(SRC)
        own = rel.parts[0] if len(rel.parts) > 1 else None
        for line, module in imports_of(path, source):
            target = _folder(module)
            if target is None or target == own:
                continue
            where = f"src/dyncatch/{rel}:{line}"
            if target not in rank:
                problems.append(f"{where}: {module} is in no layer; add its folder to LAYERS")
            elif own is None:
                if target not in TOP_MAY_IMPORT:
                    problems.append(f"{where}: dyncatch/__init__.py imports {module}")
            elif own not in rank:
                problems.append(f"{where}: folder {own!r} is in no layer; add it to LAYERS")
            elif rank[target] > rank[own]:
                problems.append(f"{where}: {own} imports {module}, a higher layer ({target})")
    return problems


def folder_loops(files: dict[Path, str] | None = None) -> list[str]:
    """One line per pair of folders that import each other, with one import each way."""
    first: dict[tuple[str, str], str] = {}
    for path, source in _sources(files).items():
        rel = path.relative_to(SRC)
        if len(rel.parts) < 2:
            continue
        for line, module in imports_of(path, source):
            target = _folder(module)
            if target is not None and target != rel.parts[0]:
                first.setdefault((rel.parts[0], target), f"src/dyncatch/{rel}:{line} ({module})")
    return [
        f"{a} <-> {b}: {first[(a, b)]} and {first[(b, a)]}"
        for (a, b) in sorted(first)
        if a < b and (b, a) in first
    ]


def _sources(files: dict[Path, str] | None) -> dict[Path, str]:
    if files is not None:
        return files
    return {p: p.read_text() for p in sorted(SRC.rglob("*.py"))}


def test_every_folder_is_a_layer():
    folders = {p.name for p in SRC.iterdir() if p.is_dir() and any(p.glob("*.py"))}
    assert folders == set(LAYERS)


def test_no_layer_imports_a_higher_one():
    problems = upward_imports()
    assert not problems, "imports against the layer order:\n" + "\n".join(problems)


def test_no_two_folders_import_each_other():
    loops = folder_loops()
    assert not loops, "folders that import each other:\n" + "\n".join(loops)


def test_utils_imports_nothing_of_dyncatch():
    found = [
        f"src/dyncatch/{p.relative_to(SRC)}:{line}: {module}"
        for p in sorted((SRC / "utils").rglob("*.py"))
        for line, module in imports_of(p)
        if not module.startswith("dyncatch.utils")
    ]
    assert not found, "utils/ knows nothing of dyncatch:\n" + "\n".join(found)


@pytest.mark.parametrize(
    ("rel", "source", "expected"),
    [
        # A function-local upward import is caught, with its file and line.
        (
            "sim/x.py",
            "import jax\n\n\ndef f():\n    from dyncatch.rl.methods import METHODS\n",
            ["src/dyncatch/sim/x.py:5: sim imports dyncatch.rl.methods, a higher layer (rl)"],
        ),
        # So is one under TYPE_CHECKING, and a relative one.
        (
            "utils/x.py",
            "if TYPE_CHECKING:\n    from ..sim.config import WorldCfg\n",
            ["src/dyncatch/utils/x.py:2: utils imports dyncatch.sim.config, a higher layer (sim)"],
        ),
        (
            "evaluation/x.py",
            "from dyncatch import cli\n",
            [
                "src/dyncatch/evaluation/x.py:1: "
                "evaluation imports dyncatch.cli, a higher layer (cli)"
            ],
        ),  # fmt: skip
        # Downward and same-folder imports pass.
        ("rl/x.py", "from dyncatch.evaluation.grid import EVAL_STREAM\nfrom . import gae\n", []),
    ],
)
def test_upward_imports_are_reported(rel, source, expected):
    assert upward_imports({SRC / rel: source}) == expected


def test_a_loop_between_two_folders_is_reported():
    files = {
        SRC / "rl/a.py": "from dyncatch.evaluation.grid import EVAL_STREAM\n",
        SRC / "evaluation/b.py": "import os\n\n\ndef f():\n    import dyncatch.rl.policy\n",
    }
    assert folder_loops(files) == [
        "evaluation <-> rl: src/dyncatch/evaluation/b.py:5 (dyncatch.rl.policy) and "
        "src/dyncatch/rl/a.py:1 (dyncatch.evaluation.grid)"
    ]
