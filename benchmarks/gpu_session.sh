#!/usr/bin/env bash
# One lease of a GPU machine, as one prepared script (issue 30's GPU figures, issue 31's
# replication): the throughput benchmarks, then the power run's second seed set, then the
# full reproduction, each until a wall-clock deadline; what finished is packed into OUT.
#
#   benchmarks/gpu_session.sh OUT DEADLINE_S [PYTHON]
#
# Runs from the repository root with the library on PYTHONPATH (src/) and the image's own
# jax/flax/optax; the packages that image lacks (tyro, gymnasium, rliable, tensorboardX and
# their pure-Python needs) come as wheels in .whl/ (benchmarks/README.md, "On a GPU
# machine"). The runs go on in their own process sessions, so a second call on the still-warm
# machine can collect them: `benchmarks/gpu_session.sh OUT DEADLINE_S` again skips what is
# done (the reproduction resumes its finished stages) and packs again.
set -u
OUT=${1:?usage: gpu_session.sh OUT DEADLINE_S [PYTHON]}
DEADLINE_S=${2:?usage: gpu_session.sh OUT DEADLINE_S [PYTHON]}
PY=${3:-python3}
START=$(date +%s)
WORK=/tmp/dyncatch_gpu
mkdir -p "$OUT" "$WORK"
export PYTHONPATH="$PWD/src:${PYTHONPATH:-}" PYTHONUNBUFFERED=1
export JAX_COMPILATION_CACHE_DIR=$WORK/jax_cache XLA_PYTHON_CLIENT_PREALLOCATE=false
left() { echo $((DEADLINE_S - ($(date +%s) - START))); }
dc() { "$PY" -m dyncatch.cli.main "$@"; }

pack() {
    # results.json, report.md, plan.json, wall.json and figures of each run; no checkpoints.
    for run in power_b full; do
        [ -d "$WORK/$run" ] || continue
        tar -C "$WORK" -czf "$OUT/$run.tgz" --exclude='*.safetensors' --exclude='*.gif' \
            --exclude='*.mp4' --exclude='tb' "$run" "$run.log" 2>/dev/null
    done
    cp -f "$WORK"/*.jsonl "$WORK"/env.txt "$OUT/" 2>/dev/null
}

# wait_for NAME: until NAME's reproduction has written its report, or the deadline.
wait_for() {
    while [ ! -f "$WORK/$1/report.md" ] && [ "$(left)" -gt 20 ]; do
        if ! pgrep -f -- "--out $WORK/$1" >/dev/null; then return 1; fi
        sleep 5
    done
    [ -f "$WORK/$1/report.md" ]
}

launch() {  # launch NAME ARGS...: a reproduction in its own session, resumable
    local name=$1
    shift
    pgrep -f -- "--out $WORK/$name" >/dev/null && return 0
    [ -f "$WORK/$name/report.md" ] && return 0
    setsid nohup "$PY" -m dyncatch.cli.main reproduce "$@" --out "$WORK/$name" \
        >>"$WORK/$name.log" 2>&1 &
}

if [ ! -f "$WORK/env.txt" ]; then
    { nvidia-smi -L; "$PY" -c "import jax, flax, optax; print(jax.__version__, flax.__version__, optax.__version__, jax.devices())"; nproc; } >"$WORK/env.txt" 2>&1
    cat "$WORK/env.txt"
fi

# 1. The power run's second seed set (issue 31's replication), seeds 30-59.
launch power_b --power --vmap-seeds --first-seed 30
wait_for power_b && echo "[$(($(date +%s) - START)) s] power_b done"

# 2. Throughput, alone on the machine (after the power run, before the full one): PPO at 1,
#    10 and 30 vmap-ped seeds and at a wide batch, then the env at batch sizes up to 262,144.
if [ -f "$WORK/power_b/report.md" ] && [ ! -f "$WORK/bench.jsonl" ] && [ "$(left)" -gt 200 ] &&
    ! pgrep -f -- "--out $WORK/full" >/dev/null; then
    for s in ${BENCH_SEEDS:-1 10 30}; do
        timeout 60 "$PY" -m dyncatch.cli.main bench ppo --json --seeds "$s" >>"$WORK/bench.part" 2>>"$WORK/bench.err"
    done
    # A wider batch (docs/scaling.md, "One GPU"): another training run, not this one faster.
    timeout 60 "$PY" -m dyncatch.cli.main bench ppo --json --ppo.num-envs ${WIDE_ENVS:-8192} --ppo.num-minibatches 8 >>"$WORK/bench.part" 2>>"$WORK/bench.err"
    timeout 60 "$PY" -m dyncatch.cli.main bench env --json --num-envs ${ENV_SIZES:-1 1024 4096 16384 65536 262144} >>"$WORK/bench.part" 2>>"$WORK/bench.err"
    mv "$WORK/bench.part" "$WORK/bench.jsonl"
    tail -n 5 "$WORK/bench.err"
fi
echo "[$(($(date +%s) - START)) s] benchmarks done"

# 3. The full reproduction, 10 seeds, on what is left (its wall.json keeps the stage times).
if [ -f "$WORK/power_b/report.md" ]; then
    launch full --vmap-seeds
    wait_for full && echo "[$(($(date +%s) - START)) s] full done"
fi
pack
tail -n 4 "$WORK/power_b.log" "$WORK/full.log" 2>/dev/null
ls -la "$OUT"
