"""Where the test suite's time goes in JAX: per test, the seconds spent tracing, lowering
and compiling (XLA backend) and how many programs each compiled; per jitted function, the
same summed over the suite (docs/performance.md, "The test suite").

As a pytest plugin (JAX reports each phase through ``jax.monitoring``; each xdist worker
writes its own file, ``OUT.<worker>.json``):

    JAX_COMPILE_PROFILE_OUT=/tmp/prof PYTHONPATH=benchmarks \\
        .venv/bin/python -m pytest -p jax_compile_profile -n 2 --dist loadfile -m "not extended"

then the tables (``--by file``, ``test`` or ``function``; ``--top N`` rows):

    .venv/bin/python benchmarks/jax_compile_profile.py /tmp/prof --by function

A program compiled in under ``SMALL_S`` is counted apart: such compilations are mostly single
operations run eagerly, outside any jit (each compiles on its own, once per process and
shape); a test with hundreds of them runs its set-up op by op.
"""

from __future__ import annotations

import argparse
import collections
import glob
import json
import os
import time

SMALL_S = 0.05
"""A compilation shorter than this is counted as "small" (an eagerly run operation)."""
PHASES = {
    "jaxpr_trace_duration": "trace",
    "jaxpr_to_mlir_module_duration": "lower",
    "backend_compile_duration": "compile",
}
"""``jax.monitoring`` duration events (their last path part) and their column names."""
OUTSIDE = "<outside a test>"

_current: dict[str, str | None] = {"test": None}
_per_test: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)
_per_function: dict[str, collections.Counter] = collections.defaultdict(collections.Counter)


def _on_duration(event: str, seconds: float, **kwargs) -> None:
    phase = PHASES.get(event.rsplit("/", 1)[-1])
    if phase is None:
        return
    test = _current["test"] or OUTSIDE
    name = str(kwargs.get("fun_name", "?"))
    if name.startswith("jit(") and name.endswith(")"):  # lowering and compiling say jit(f)
        name = name[4:-1]
    row, fn = _per_test[test], _per_function[name]
    for counter in (row, fn):
        counter[f"{phase}_s"] += seconds
        counter[f"{phase}_n"] += 1
    if phase == "compile" and seconds < SMALL_S:
        row["small_s"] += seconds
        row["small_n"] += 1
    fn[f"file:{test.split('::')[0]}"] += phase == "compile"


def pytest_configure(config) -> None:
    import jax.monitoring

    jax.monitoring.register_event_duration_secs_listener(_on_duration)


def pytest_runtest_protocol(item, nextitem):  # noqa: ARG001 (pytest's hook signature)
    _current["test"] = item.nodeid
    _per_test[item.nodeid]["start"] = time.perf_counter()


def pytest_runtest_logfinish(nodeid, location):  # noqa: ARG001
    row = _per_test[nodeid]
    row["wall_s"] += time.perf_counter() - row.pop("start", time.perf_counter())
    _current["test"] = None


def pytest_sessionfinish(session) -> None:  # noqa: ARG001
    out = os.environ.get("JAX_COMPILE_PROFILE_OUT")
    if not out:
        return
    worker = os.environ.get("PYTEST_XDIST_WORKER", "main")
    with open(f"{out}.{worker}.json", "w") as f:
        json.dump(
            {
                "tests": {k: dict(v) for k, v in _per_test.items()},
                "functions": {k: dict(v) for k, v in _per_function.items()},
            },
            f,
        )


def load(prefix: str) -> tuple[dict, dict]:
    """The per-test and per-function counters of every worker's file under ``prefix``."""
    tests: dict = collections.defaultdict(collections.Counter)
    functions: dict = collections.defaultdict(collections.Counter)
    paths = sorted(glob.glob(f"{glob.escape(prefix)}.*.json"))
    if not paths:
        raise SystemExit(f"no profile files {prefix}.*.json: run pytest with the plugin first")
    for path in paths:
        with open(path) as f:
            data = json.load(f)
        for key, row in data["tests"].items():
            tests[key].update(row)
        for key, row in data["functions"].items():
            functions[key].update(row)
    return tests, functions


def table(rows: dict, top: int, per_test: bool) -> str:
    cols = ["trace_s", "trace_n", "lower_s", "compile_s", "compile_n"]
    cols = ["wall_s", *cols, "small_s", "small_n"] if per_test else cols
    total = collections.Counter()
    for row in rows.values():
        total.update({c: row.get(c, 0) for c in cols})
    order = sorted(rows, key=lambda k: -rows[k].get("wall_s" if per_test else "compile_s", 0))
    lines = [" ".join(f"{c:>10}" for c in cols) + "  name"]
    for key in ["TOTAL", *order[:top]]:
        row = total if key == "TOTAL" else rows[key]
        lines.append(" ".join(f"{row.get(c, 0):10.1f}" for c in cols) + f"  {key}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("prefix", help="JAX_COMPILE_PROFILE_OUT of the profiled run")
    parser.add_argument("--by", choices=("file", "test", "function"), default="file")
    parser.add_argument("--top", type=int, default=30)
    args = parser.parse_args(argv)
    tests, functions = load(args.prefix)
    if args.by == "function":
        rows = {}
        for name, row in functions.items():
            files = sorted(
                ((n, k[5:]) for k, n in row.items() if k.startswith("file:") and n), reverse=True
            )
            where = ", ".join(f"{f.rsplit('/', 1)[-1]}:{n}" for n, f in files[:4])
            rows[f"{name}  [{len(files)} files: {where}]"] = row
        print(table(rows, args.top, per_test=False))
        return
    if args.by == "file":
        per_file: dict = collections.defaultdict(collections.Counter)
        for key, row in tests.items():
            per_file[key.split("::")[0]].update(row)
        tests = per_file
    print(table(tests, args.top, per_test=True))


if __name__ == "__main__":
    main()
