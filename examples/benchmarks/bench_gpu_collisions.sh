#!/usr/bin/env bash
# fix hardsphere on the GPU against the CPU, side by side in one run: each configuration is run
# with the CPU backend ('gpu no') and with the CUDA backend ('gpu yes', on one rank the
# device-resident step) in turn, `reps` times each, and the medians are printed as a Markdown
# table.
#
#   examples/benchmarks/bench_gpu_collisions.sh lmp plugin [reps] [cases...]
#
#   lmp     LAMMPS executable;  plugin  hardspheregpuplugin.so;  reps  default 3
#   cases   config:size[:steps], default
#           "lattice3d:65536 lattice3d:262144 lattice3d:1048576 fluid:32 fluid:64 fluid:102
#            lattice2d:65536 lattice2d:1048576 dilute:65536 dilute:1048576"
#           config: dilute, lattice2d, lattice3d (examples/hardsphere, size = N) or fluid
#           (examples/benchmarks/in.fluid or $HSGPU_SCENES/in.fluid, size = nx, N = nx^3);
#           steps default 50 (20 from N = 500000)
#
# Columns: N; collisions per step; Modify ms/step (LAMMPS's Modify time per step: the fix
# hardsphere step, transfers included, and fix nve/sphere) on the CPU and the GPU and their
# ratio; fix step ms/step (the fix's own timer of its whole step, f_ID[20], per step after the
# run's first, which allocates and page-locks: the run summary line gives it) on the CPU and
# the GPU and their ratio; the GPU's search and
# resolve ms/step (the fix's timers: search = upload and candidate search, resolve = windows,
# checks and download) and the part of both spent copying (the run summary's seconds);
# collisions per second of the GPU's fix step; steps carried out on the device.  On one rank
# with gpu/keep (the default) most device steps run ahead during LAMMPS's integration: the
# GPU's fix step then counts what the device had not finished when LAMMPS's integration was
# done (and writing the results), its search and resolve the device step's own time; set
# HSGPU_RESIDENT_AHEAD=0 for the fix step of a device step not run ahead.
#
# HSGPU_BENCH_SERIAL=1 adds a third run per repeat, 'gpu yes order serial' (the seed paper's
# loop on the device: one device-wide earliest event per iteration), and three columns: its
# fix step ms/step, its ratio to the default order's on the GPU, and its microseconds per
# event (fix step time over the events the run summary counts).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lmp=${1:?usage: bench_gpu_collisions.sh lmp plugin [reps] [cases...]}
plugin=${2:?usage: bench_gpu_collisions.sh lmp plugin [reps] [cases...]}
lmp=$(readlink -f "$lmp")
plugin=$(readlink -f "$plugin")
reps=${3:-3}
shift $(($# < 3 ? $# : 3))
cases=("$@")
[ ${#cases[@]} -gt 0 ] || cases=(lattice3d:65536 lattice3d:262144 lattice3d:1048576 fluid:32
  fluid:64 fluid:102 lattice2d:65536 lattice2d:1048576 dilute:65536 dilute:1048576)
scenes=${HSGPU_SCENES:-$here}
export OMP_NUM_THREADS=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root"/examples/hardsphere/in.dilute "$root"/examples/hardsphere/in.lattice2d \
  "$root"/examples/hardsphere/in.lattice3d "$work"/
cp "$scenes"/in.fluid "$work"/
for f in "$work"/in.*; do
  sed 's/^\(fix *hs all hardsphere.*\)$/\1 gpu yes/' "$f" > "$f.gpu"
  grep -q 'hardsphere.*gpu yes' "$f.gpu" || { echo "no fix hardsphere line in $f" >&2; exit 2; }
  sed 's/^\(fix *hs all hardsphere.*\)$/\1 gpu yes order serial/' "$f" > "$f.gpus"
done

median() { sort -g | awk '{v[NR] = $1} END {print (NR % 2) ? v[(NR + 1) / 2] : 0.5 * (v[NR / 2] + v[NR / 2 + 1])}'; }

serial=${HSGPU_BENCH_SERIAL:-0}

# One run; prints "modify search resolve transfer collisions resident steps events fixstep".
one() {
  local input=$1 log=$2; shift 2
  (cd "$work" && "$lmp" -in "$input" -var plugin "$plugin" "$@" -log "$log" -echo none \
    -screen none > /dev/null 2>&1) || { echo "run failed: $input $*" >&2; tail -3 "$work/$log" >&2; exit 1; }
  local modify summary dev
  modify=$(awk '/^Modify /{print $5}' "$work/$log")
  summary=$(grep 'Fix hardsphere (' "$work/$log")
  dev=$(grep 'whole on the device' "$work/$log" || true)
  local steps coll search resolve transfer resident events
  steps=$(sed 's/.*backend): \([0-9]*\) steps.*/\1/' <<< "$summary")
  events=$(sed 's/.* collisions and \([0-9.e+]*\) events.*/\1/' <<< "$summary")
  coll=$(sed 's/.* steps, \([0-9.e+]*\) collisions.*/\1/' <<< "$summary")
  search=$(sed 's/.*search \([0-9.e+-]*\) s.*/\1/' <<< "$summary")
  resolve=$(sed 's/.*resolve \([0-9.e+-]*\) s.*/\1/' <<< "$summary")
  fixstep=$(sed "s/.*the fix's step [0-9.e+-]* ms per step (\([0-9.e+-]*\) ms after the first).*/\1/" <<< "$summary")
  transfer=0
  resident=0
  if [ -n "$dev" ]; then
    transfer=$(sed 's/.*device (\([0-9.e+-]*\) s.*/\1/' <<< "$dev")
    resident=$(sed 's/^Fix hardsphere: \([0-9]*\) of.*/\1/' <<< "$dev")
  fi
  echo "$modify $search $resolve $transfer $coll $resident $steps $events $fixstep"
}

head="| config | N | collisions/step | Modify ms/step CPU | Modify ms/step GPU | CPU/GPU | fix step ms CPU | fix step ms GPU | CPU/GPU | GPU search ms/step | GPU resolve ms/step | GPU copying ms/step | GPU collisions/s (fix step) | steps on the device |"
rule="|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
if [ "$serial" = 1 ]; then
  head="$head GPU serial fix step ms | serial/parallel on the GPU | GPU serial us/event |"
  rule="$rule---|---|---|"
fi
echo "$head"
echo "$rule"
for c in "${cases[@]}"; do
  IFS=: read -r config size steps <<< "$c"
  if [ "$config" = fluid ]; then
    n=$((size * size * size))
    args=(-var nx "$size")
  else
    n=$size
    args=(-var N "$size")
  fi
  steps=${steps:-$([ "$n" -ge 500000 ] && echo 20 || echo 50)}
  args+=(-var steps "$steps")
  : > "$work/cpu" && : > "$work/gpu" && : > "$work/gpus"
  for ((r = 0; r < reps; ++r)); do
    one "in.$config" log.cpu "${args[@]}" >> "$work/cpu"
    one "in.$config.gpu" log.gpu "${args[@]}" >> "$work/gpu"
    [ "$serial" = 1 ] && one "in.$config.gpus" log.gpus "${args[@]}" >> "$work/gpus"
  done
  col() { awk -v k="$2" '{print $k}' "$work/$1" | median; }
  st=$(col gpu 7)
  awk -v cfg="$config" -v n="$n" -v coll="$(col gpu 5)" -v mc="$(col cpu 1)" -v mg="$(col gpu 1)" \
    -v sg="$(col gpu 2)" -v rg="$(col gpu 3)" -v tg="$(col gpu 4)" -v dev="$(col gpu 6)" -v st="$st" \
    -v fc="$(col cpu 9)" -v fg="$(col gpu 9)" \
    'BEGIN { printf "| %s | %d | %.0f | %.2f | %.2f | %.1f | %.3f | %.3f | %.1f | %.2f | %.2f | %.2f | %.3g | %d of %d |",
             cfg, n, coll, 1e3 * mc / st, 1e3 * mg / st, mc / mg, fc, fg, fc / fg, 1e3 * sg / st,
             1e3 * rg / st, 1e3 * tg / st, 1e3 * coll / fg, dev, st }'
  if [ "$serial" = 1 ]; then
    awk -v fs="$(col gpus 9)" -v fg="$(col gpu 9)" -v ev="$(col gpus 8)" \
      'BEGIN { printf " %.2f | %.1f | %.2f |", fs, fs / fg, 1e3 * fs / ev }'
  fi
  echo
done
