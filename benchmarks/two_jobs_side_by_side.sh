#!/bin/bash
# Two training seeds side by side on a 2-core machine against one seed alone
# (docs/scaling.md, "Two jobs at a time on 2 cores"). Run it on an idle machine:
#   bash benchmarks/two_jobs_side_by_side.sh OUT [STEPS]
# A: one seed on both cores; B: two seeds, each pinned to a core with Eigen on one thread;
# C: two seeds at once with the default flags (what `--executor ray --ray-workers 2` does).
# It prints each variant's wall seconds and whether C's and B's seed 0 are A's run (every
# tensor and the metadata of the checkpoint equal).
set -euo pipefail
OUT=${1:?usage: two_jobs_side_by_side.sh OUT [STEPS]}
S=${2:-2000000}
BIN=${DYNCATCH:-.venv/bin/dyncatch}
mkdir -p "$OUT"
train() {  # name seed
  "$BIN" train --method rl --total-steps "$S" --eval-every 0 --seed "$2" --out "$OUT/$1" > "$OUT/$1.log" 2>&1
}
now() { date +%s.%N; }
one_thread="--xla_cpu_multi_thread_eigen=false"
# Warm the compilation cache for both flag sets (a short run each), so no variant compiles.
"$BIN" train --method rl --total-steps 32768 --eval-every 0 --out "$OUT/warm_a" > /dev/null 2>&1
XLA_FLAGS=$one_thread taskset -c 0 "$BIN" train --method rl --total-steps 32768 --eval-every 0 \
    --out "$OUT/warm_b" > /dev/null 2>&1
s=$(now); train a 0; echo "A one seed, both cores: $(echo "$(now) - $s" | bc) s"
s=$(now)
(XLA_FLAGS=$one_thread taskset -c 0 "$BIN" train --method rl --total-steps "$S" --eval-every 0 \
    --seed 0 --out "$OUT/b0" > "$OUT/b0.log" 2>&1) &
(XLA_FLAGS=$one_thread taskset -c 1 "$BIN" train --method rl --total-steps "$S" --eval-every 0 \
    --seed 1 --out "$OUT/b1" > "$OUT/b1.log" 2>&1) &
wait
echo "B two seeds, a core each, Eigen on one thread: $(echo "$(now) - $s" | bc) s"
s=$(now); (train c0 0) & (train c1 1) & wait
echo "C two seeds at once, default flags: $(echo "$(now) - $s" | bc) s"
PY=${PYTHON:-.venv/bin/python}
for v in c0 b0; do  # tensors and metadata (the file's bytes may order its header otherwise)
  "$PY" - "$OUT/a/checkpoint.safetensors" "$OUT/$v/checkpoint.safetensors" "$v" <<'PYEOF'
import sys

import numpy as np
from safetensors import safe_open

def read(path):
    with safe_open(path, "np") as f:
        return {k: f.get_tensor(k) for k in f.keys()}, f.metadata()

(a, meta_a), (b, meta_b) = read(sys.argv[1]), read(sys.argv[2])
same = meta_a == meta_b and a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
print(f"{sys.argv[3]}: {'the same run as A' if same else 'another run than A'}")
PYEOF
done
