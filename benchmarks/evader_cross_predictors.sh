#!/bin/bash
# Predictors of one learned evader scored on another (issue 34): three evaders (against
# pursuit, seeds 0 and 1; against intercept, seed 0; 5 M steps each), a vanilla and a
# self-aware predictor of each and of the reactive target (2 M steps, seed 0), all in the
# evaders' world (caps in [1.4, 1.8] m/s), then every predictor scored on 500 k held-out steps
# of every target (dyncatch predictor score). Then self-aware predictors of leagues of
# evaders (each evader left out in turn, and all three; --behavior league, evaders only, even
# weights), scored on every evader: does a predictor of several evaders predict a new one?
# Cached: a finished evader or predictor is kept.
#   bash benchmarks/evader_cross_predictors.sh OUT
#   .venv/bin/python benchmarks/score_table.py OUT/scores.jsonl
set -euo pipefail
D=${1:?give the output folder}
B=${DYNCATCH:-.venv/bin/dyncatch}
W="--world.target.speed-min-mps 1.4 --world.target.speed-max-mps 1.8"
mkdir -p "$D"
for e in "pursuit 0" "pursuit 1" "intercept 0"; do
  set -- $e; n=evader_$1_5m_s$2
  [ -f "$D/$n/done" ] && continue
  resume=$([ -f "$D/$n/train_state.safetensors" ] && echo --resume || true)
  $B evader train --against "$1" --total-steps 5000000 --seed "$2" --out "$D/$n" $resume
  touch "$D/$n/done"
done
targets="reactive evader_pursuit_5m_s0 evader_pursuit_5m_s1 evader_intercept_5m_s0"
for t in $targets; do
  for k in vanilla self_aware; do
    o=$D/pred/${t}_$k
    [ -f "$o/predictor.safetensors" ] && continue
    if [ "$t" = reactive ]; then $B predictor train --behavior reactive --kind $k $W --out "$o"
    else $B predictor train --behavior learned --world.target.evader-checkpoint "$D/$t" \
      --kind $k $W --out "$o"; fi
  done
done
evaders=(evader_pursuit_5m_s0 evader_pursuit_5m_s1 evader_intercept_5m_s0)
for out in "${evaders[@]}" none; do
  members=(); for e in "${evaders[@]}"; do [ "$e" != "$out" ] && members+=("$D/$e"); done
  o=$D/pred/league_without_${out}_self_aware
  [ -f "$o/predictor.safetensors" ] && continue
  $B predictor train --behavior league --world.target.league-evaders "${members[@]}" \
    --world.target.league-behaviors --kind self_aware $W --out "$o"
done
P=$(ls "$D"/pred/*/predictor.safetensors)
: > "$D/scores.jsonl"
for t in $targets; do
  if [ "$t" = reactive ]; then $B predictor score $P --behavior reactive $W --eval-steps 500000
  else $B predictor score $P --behavior learned --world.target.evader-checkpoint "$D/$t" $W \
    --eval-steps 500000; fi >> "$D/scores.jsonl"
done
