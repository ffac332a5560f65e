#!/usr/bin/env bash
# Collision benchmark of fix hardsphere: the seed paper's three configurations
# (examples/hardsphere/in.dilute, in.lattice2d, in.lattice3d) and the fluid of
# examples/benchmarks/in.fluid (packing fraction 0.4, dt = 0.01), for N = 1024 ... Nmax (doubling;
# the fluid takes the nearest cube nx^3), side by side in the same run:
#   - parallel: the default order (time windows, groups, the fix's own candidate search);
#   - serial:   the seed paper's loop (one globally earliest event at a time), seed
#               configurations up to N = SERIALMAX only (it costs O(N) per event);
#   - baseline: a plugin built from an earlier commit (optional 6th argument; for example the
#               one before time windows, 14d35eb, whose 'parallel' order and LAMMPS neighbor
#               list are what the windows replaced).
#
#   examples/benchmarks/bench_collisions.sh [lmp] [plugin] [steps] [Nmax] [np] [baseline]
#       [configs] [serialmax]
#
#   lmp        LAMMPS executable (default: the one build/ was configured with)
#   plugin     hardspheregpuplugin.so (default: build/hardspheregpuplugin.so)
#   steps      timesteps per run (default 100; 20 above N = 131072)
#   Nmax       largest N (default 65536)
#   np         MPI ranks (default 1)
#   baseline   plugin of the baseline commit ('' or 'none': no baseline rows)
#   configs    default "dilute lattice2d lattice3d fluid"
#   serialmax  largest N for order serial (default 65536; 0: none)
#
# Prints a Markdown table.  ms/step: LAMMPS's Loop time per step (the whole step).  fix
# ms/step: LAMMPS's Modify time per step (the fixes, mostly fix hardsphere, its own candidate
# search included); for the baseline, Modify plus Neigh, since its candidate pairs came from a
# neighbor list that LAMMPS built for it.  search and resolve: the fix's own timers (f_ID[12],
# f_ID[13]) per step.  coll/part/step: pair collisions per particle per step; events/step: pair
# and wall collisions and resting contacts per step.  largest: the most atoms resolved
# together in one window in any step of the run (and in % of N); windows: per step; repairs:
# groups merged and resolved again in the run; spanning: atoms per step in groups that span
# ranks; gathers: per step.  All from the line fix hardsphere logs at the end of a run.
# HSGPU_BENCH_ARGS (e.g. "-var dt 0.01") is passed to the seed configurations' runs.
# HSGPU_BENCH_GPU=1 adds rows of order "parallel-cuda": the default order with the fix's CUDA
# collision backend ('gpu yes' appended to the fix hardsphere line of a copy of each input).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lmp=${1:-$(sed -n 's/^LAMMPS_BINARY:FILEPATH=//p' "$root/build/CMakeCache.txt" 2>/dev/null || true)}
plugin=${2:-$root/build/hardspheregpuplugin.so}
steps=${3:-100}
nmax=${4:-65536}
np=${5:-1}
baseline=${6:-}
configs=${7:-dilute lattice2d lattice3d fluid}
serialmax=${8:-65536}
[ "$baseline" = none ] && baseline=
[ -x "$lmp" ] || { echo "no LAMMPS executable '$lmp' (pass it as the first argument)" >&2; exit 2; }
[ -f "$plugin" ] || { echo "no plugin '$plugin' (pass it as the second argument)" >&2; exit 2; }
[ -z "$baseline" ] || [ -f "$baseline" ] || { echo "no baseline plugin '$baseline'" >&2; exit 2; }
scenes=${HSGPU_SCENES:-$here}
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
launcher=()
[ "$np" -gt 1 ] && launcher=(mpirun -np "$np")

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root"/examples/hardsphere/in.* "$work"/
if [[ " $configs " == *" fluid "* ]]; then
  [ -f "$scenes/in.fluid" ] || { echo "no $scenes/in.fluid (set HSGPU_SCENES)" >&2; exit 2; }
  cp "$scenes/in.fluid" "$work/in.fluid"
fi
cd "$work"
for f in in.*; do
  sed 's/^\(fix  *hs  *all  *hardsphere.*[^&]\)$/\1 gpu yes/' "$f" > "$f.cuda"
done

# run <config> <N> <order> <plugin> -> one table row
run() {
  local config=$1 n=$2 order=$3 plug=$4 nsteps=$steps log args
  [ "$n" -gt 131072 ] && nsteps=20
  log=$work/log.$config.$n.$order
  if [ "$config" = fluid ]; then
    local nx
    nx=$(awk -v n="$n" 'BEGIN { printf "%d", n^(1/3) + 0.5 }')
    args=(-var nx "$nx" -var steps "$nsteps")
  else
    args=(-var N "$n" -var steps "$nsteps")
    [ "$order" = serial ] && args+=(-var order serial)
    # shellcheck disable=SC2206
    [ -n "${HSGPU_BENCH_ARGS:-}" ] && args+=($HSGPU_BENCH_ARGS)
  fi
  local input=in.$config
  [ "$order" = parallel-cuda ] && input=in.$config.cuda
  if ! "${launcher[@]}" "$lmp" -in "$input" -var plugin "$plug" "${args[@]}" -log "$log" \
      -echo none -screen none >/dev/null 2>&1; then
    echo "| $config | $n | $np | $order | failed | | | | | | | | | | |"
    return
  fi
  awk -v config="$config" -v order="$order" -v np="$np" '
    /^Loop time of/ { loop = $4; nsteps = $9; natoms = $12 }
    /^Modify  *\|/ { modify = $5 }
    /^Neigh  *\|/ { neigh = $5 }
    /^Fix hardsphere \(/ {
      for (i = 1; i <= NF; i++) {
        if ($(i+1) == "collisions" && $(i+2) == "and") coll = $i
        if ($(i+1) == "events" && $(i+2) == "per") ev = $i
        if ($i == "largest" && $(i+1) == "group") largest = $(i+2)
        if ($(i+1) == "windows" && $(i+2) == "and") win = $i
        if ($(i+1) == "repairs,") rep = $i
        if ($(i+1) == "atoms" && $(i+2) == "per") span = $i
        if ($(i+1) == "gathers") gath = $i
        if ($i == "search") search = $(i+1)
        if ($i == "resolve") { resolve = $(i+1); sub(/s$/, "", resolve) }
      }
      summary = 1
    }
    /collisions per particle per step/ && !summary {
      for (i = 1; i <= NF; i++) {
        if ($(i+1) == "collisions" && $(i+2) == "per") rate = $i
        if ($(i+1) == "events" && $(i+2) == "per") ev = $i
      }
    }
    END {
      fix = modify
      if (order == "baseline") fix = modify + neigh
      ms = 1000 / nsteps
      if (summary) {
        printf "| %s | %d | %d | %s | %.3f | %.3f | %.3f | %.3f | %.4f | %.1f | %d | %.2f %% | %.2f | %d | %.0f | %.2f |\n",
          config, natoms, np, order, loop * ms, fix * ms, search * ms, resolve * ms,
          coll / natoms, ev, largest, 100 * largest / natoms, win, rep, span, gath
      } else {
        printf "| %s | %d | %d | %s | %.3f | %.3f | | | %s | %s | | | | | | |\n",
          config, natoms, np, order, loop * ms, fix * ms, rate, ev
      }
    }' "$log"
}

echo "| configuration | N | ranks | order | ms/step | fix ms/step | search ms/step | resolve ms/step | coll/part/step | events/step | largest | largest/N | windows/step | repairs | spanning/step | gathers/step |"
echo "|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for config in $configs; do
  n=1024
  while [ "$n" -le "$nmax" ]; do
    run "$config" "$n" parallel "$plugin"
    [ "${HSGPU_BENCH_GPU:-0}" = 1 ] && run "$config" "$n" parallel-cuda "$plugin"
    if [ "$config" != fluid ] && [ "$n" -le "$serialmax" ]; then
      run "$config" "$n" serial "$plugin"
    fi
    [ -n "$baseline" ] && run "$config" "$n" baseline "$baseline"
    n=$((n * 2))
  done
done
