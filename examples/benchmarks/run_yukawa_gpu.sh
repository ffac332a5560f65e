#!/usr/bin/env bash
# Times pair yukawa/gpu (kappa 0, all pairs in the neighbor list) as LAMMPS reports it.
#   run_yukawa_gpu.sh <lmp built with the GPU package> "<N...>" [steps] ["package gpu options"]
# Prints: N, ms/step, Pair time per step, interactions/s (N (N-1) / Pair time per step; with
# newton off every pair is computed once for each of its atoms), and the device memory in use
# as nvidia-smi reports it during the run.  Stops at the first N that fails.
set -uo pipefail
lmp=$1 sizes=($2) steps=${3:-20} pk=${4:-}
here=$(cd "$(dirname "$0")" && pwd)
echo "package gpu 1 ${pk:-(defaults)}"
echo
echo "| N | ms/step | Pair ms/step | interactions/s | GPU memory (MiB) |"
echo "|---|---|---|---|---|"
for n in "${sizes[@]}"; do
  log=$(mktemp)
  ( "$lmp" -sf gpu -pk gpu 1 $pk -in "$here/in.yukawa_allpairs" -log none -var N "$n" -var steps "$steps" >"$log" 2>&1 ) &
  pid=$!
  mem=0
  while kill -0 $pid 2>/dev/null; do
    m=$(nvidia-smi --query-gpu=memory.used --format=csv,noheader,nounits -i 0 2>/dev/null | head -1)
    [ -n "$m" ] && [ "$m" -gt "$mem" ] && mem=$m
    sleep 0.5
  done
  wait $pid; rc=$?
  loop=$(sed -n 's/^Loop time of \([0-9.e+-]*\) on.*/\1/p' "$log")
  pair=$(sed -n 's/^Pair    | \([0-9.e+-]*\) .*/\1/p' "$log")
  if [ $rc -ne 0 ] || [ -z "$loop" ]; then
    echo "| $n | failed: $(grep -m1 -E 'ERROR|out of memory|Cuda' "$log" | cut -c1-100) | | | $mem |"
    rm -f "$log"; break
  fi
  awk -v n="$n" -v t="$loop" -v p="$pair" -v s="$steps" -v m="$mem" \
    'BEGIN{printf "| %d | %.3f | %.3f | %.3e | %d |\n", n, 1000*t/s, 1000*p/s, n*(n-1)/(p/s), m}'
  rm -f "$log"
done
