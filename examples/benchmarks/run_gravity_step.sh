#!/usr/bin/env bash
# Times whole LAMMPS steps of pair_style gravity as LAMMPS reports them ("Loop time").
#   run_gravity_step.sh <lmp> <plugin> "<ranks...>" "<N...>" "<precisions...>" [steps]
#                       ["<newton settings...>"]
# Prints a markdown table: N, precision, newton setting (default: on), ranks, ms per step, the
# parallel efficiency against the first rank count in the list with the same setting, and
# against the fastest run on that first rank count over all settings.
set -euo pipefail
lmp=$1 plugin=$2 ranks=($3) sizes=($4) precs=($5) steps=${6:-20} newtons=(${7:-on})
here=$(cd "$(dirname "$0")" && pwd)
export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
echo "| N | precision | newton | ranks (GPUs) | ms/step | efficiency | vs fastest on ${ranks[0]} |"
echo "|---|---|---|---|---|---|---|"
for n in "${sizes[@]}"; do
  for p in "${precs[@]}"; do
    rows=() best=""
    for nw in "${newtons[@]}"; do
      base=""
      for r in "${ranks[@]}"; do
        out=$(mpirun -np "$r" "$lmp" -in "$here/in.gravity_step" -log none -var plugin "$plugin" \
              -var N "$n" -var prec "$p" -var steps "$steps" -var newton "$nw" 2>&1) ||
          { echo "$out" | tail -20; exit 1; }
        loop=$(echo "$out" | sed -n 's/^Loop time of \([0-9.e+-]*\) on.*/\1/p')
        # With HSGPU_TIMING=1: the style's own phase times and LAMMPS's breakdown, to stderr.
        echo "$out" | grep -E "^Pair gravity timing|^Pair  |^Modify  |^Other  |^Comm  " |
          sed "s/^/# N=$n $p newton $nw np=$r: /" >&2 || true
        ms=$(awk -v t="$loop" -v s="$steps" 'BEGIN{printf "%.3f", 1000*t/s}')
        if [ -z "$base" ]; then base=$ms; base_r=$r; fi
        if [ -z "$best" ] || awk -v a="$base" -v b="$best" 'BEGIN{exit !(a < b)}'; then best=$base; fi
        eff=$(awk -v b="$base" -v br="$base_r" -v t="$ms" -v r="$r" 'BEGIN{printf "%.0f%%", 100*b*br/(t*r)}')
        rows+=("$n|$p|$nw|$r|$ms|$eff")
      done
    done
    for row in "${rows[@]}"; do
      IFS='|' read -r rn rp rnw rr rms reff <<<"$row"
      vs=$(awk -v b="$best" -v br="$base_r" -v t="$rms" -v r="$rr" 'BEGIN{printf "%.0f%%", 100*b*br/(t*r)}')
      echo "| $rn | $rp | $rnw | $rr | $rms | $reff | $vs |"
    done
  done
done
