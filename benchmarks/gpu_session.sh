#!/usr/bin/env bash
# One lease of a GPU machine as one prepared script: a timing of a 30-seed training group,
# then one reproduction (or one part of one) to a wall-clock deadline; what finished is
# packed into OUT without checkpoints or TensorBoard logs (what a merge reads,
# dyncatch.reproduce.parts).
#
#   benchmarks/gpu_session.sh OUT DEADLINE_S NAME [REPRODUCE FLAGS ...]
#   e.g. benchmarks/gpu_session.sh $OUT 780 pb15_random_reactive \
#          --power --seeds 15 --first-seed 30 --part random_reactive --vmap-seeds
#
# Runs from the repository root with the library on PYTHONPATH (src/) and the image's own
# jax/flax/optax; the packages that image lacks (tyro, gymnasium, rliable, tensorboardX and
# their pure-Python needs) come as wheels in .whl/ (docs/scaling.md, "One GPU"). The runs go
# on in their own process sessions, so a second call on the still-warm machine, the same
# command again, finds them (the reproduction resumes its finished stages) and packs again.
# Measured on 2026-12-04 (docs/scaling.md): each `dyncatch bench` took over 55 s there, and a
# 30-seed group 1.76 s an iteration, so plan a lease of 15 minutes on those figures.
set -u
OUT=${1:?usage: gpu_session.sh OUT DEADLINE_S NAME [REPRODUCE FLAGS ...]}
DEADLINE_S=${2:?usage: gpu_session.sh OUT DEADLINE_S NAME [REPRODUCE FLAGS ...]}
NAME=${3:?usage: gpu_session.sh OUT DEADLINE_S NAME [REPRODUCE FLAGS ...]}
shift 3
PY=${PY:-python3}
START=$(date +%s)
WORK=/tmp/dyncatch_gpu
mkdir -p "$OUT" "$WORK"
export PYTHONPATH="$PWD/src:${PYTHONPATH:-}" PYTHONUNBUFFERED=1
export JAX_COMPILATION_CACHE_DIR=$WORK/jax_cache XLA_PYTHON_CLIENT_PREALLOCATE=false
left() { echo $((DEADLINE_S - ($(date +%s) - START))); }
say() { echo "[$(($(date +%s) - START)) s] $*"; }

if [ ! -f "$WORK/env.txt" ]; then
    { nvidia-smi -L; "$PY" -c "import jax, flax, optax; print(jax.__version__, flax.__version__, optax.__version__, jax.devices())"; nproc; } >"$WORK/env.txt" 2>&1
    cat "$WORK/env.txt"
fi

# 1. A 30-seed group of the standard setting, 24 iterations: seconds an iteration from its
#    metrics.csv (time_s), the figure docs/scaling.md compares with the CPU's.
if [ ! -d "$WORK/group30" ] && [ "${GROUP_TIMING:-1}" = 1 ]; then
    timeout 240 "$PY" -m dyncatch.cli.main train --method rl --seeds 30 --eval-every 0 \
        --total-steps 393216 --out "$WORK/group30" >"$WORK/group30.log" 2>&1
    cp "$WORK/group30/seed0/metrics.csv" "$WORK/group30_seed0_metrics.csv" 2>/dev/null
    say "30-seed group timed"
fi

# 2. The reproduction, in its own session, until it writes its report or the deadline.
if [ ! -f "$WORK/$NAME/report.md" ] && ! pgrep -f -- "--out $WORK/$NAME" >/dev/null; then
    setsid nohup "$PY" -m dyncatch.cli.main reproduce "$@" --out "$WORK/$NAME" \
        >>"$WORK/$NAME.log" 2>&1 &
fi
while [ ! -f "$WORK/$NAME/report.md" ] && [ "$(left)" -gt 25 ]; do
    pgrep -f -- "--out $WORK/$NAME" >/dev/null || break
    sleep 5
done
[ -f "$WORK/$NAME/report.md" ] && say "$NAME done"

tar -C "$WORK" -czf "$OUT/$NAME.tgz" --exclude=checkpoint.safetensors --exclude=tb \
    "$NAME" "$NAME.log" 2>/dev/null
cp -f "$WORK"/env.txt "$WORK"/group30.log "$WORK"/group30_seed0_metrics.csv "$OUT/" 2>/dev/null
tail -n 5 "$WORK/$NAME.log"
ls -la "$OUT"
