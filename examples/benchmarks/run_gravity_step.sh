#!/usr/bin/env bash
# Times whole LAMMPS steps of pair_style gravity as LAMMPS reports them ("Loop time").
#   run_gravity_step.sh <lmp> <plugin> "<ranks...>" "<N...>" "<precisions...>" [steps]
# Prints a markdown table: N, precision, ranks, ms per step, and the parallel efficiency
# against the first rank count in the list.
set -euo pipefail
lmp=$1 plugin=$2 ranks=($3) sizes=($4) precs=($5) steps=${6:-20}
here=$(cd "$(dirname "$0")" && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
echo "| N | precision | ranks (GPUs) | ms/step | efficiency |"
echo "|---|---|---|---|---|"
for n in "${sizes[@]}"; do
  for p in "${precs[@]}"; do
    base=""
    for r in "${ranks[@]}"; do
      out=$(mpirun -np "$r" "$lmp" -in "$here/in.gravity_step" -log none -var plugin "$plugin" \
            -var N "$n" -var prec "$p" -var steps "$steps" 2>&1) || { echo "$out" | tail -20; exit 1; }
      loop=$(echo "$out" | sed -n 's/^Loop time of \([0-9.e+-]*\) on.*/\1/p')
      # With HSGPU_TIMING=1: the style's own phase times and LAMMPS's breakdown, to stderr.
      echo "$out" | grep -E "^Pair gravity timing|^Pair  |^Modify  |^Other  |^Comm  " | sed "s/^/# N=$n $p np=$r: /" >&2 || true
      ms=$(awk -v t="$loop" -v s="$steps" 'BEGIN{printf "%.3f", 1000*t/s}')
      if [ -z "$base" ]; then base=$ms; base_r=$r; fi
      eff=$(awk -v b="$base" -v br="$base_r" -v t="$ms" -v r="$r" 'BEGIN{printf "%.0f%%", 100*b*br/(t*r)}')
      echo "| $n | $p | $r | $ms | $eff |"
    done
  done
done
