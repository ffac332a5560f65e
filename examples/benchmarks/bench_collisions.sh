#!/usr/bin/env bash
# Collision benchmark of fix hardsphere: the seed paper's three configurations
# (examples/hardsphere/in.dilute, in.lattice2d, in.lattice3d) for N = 1024 ... 65536 (doubling),
# each with the default order ('parallel': independent components) and with 'serial' (the seed
# paper's loop: one globally earliest event at a time), side by side in the same run.
#
#   examples/benchmarks/bench_collisions.sh [lmp] [plugin] [steps] [Nmax] [np]
#
#   lmp     LAMMPS executable (default: the one build/ was configured with)
#   plugin  hardspheregpuplugin.so (default: build/hardspheregpuplugin.so)
#   steps   timesteps per run (default 200, as the examples)
#   Nmax    largest N (default 65536)
#   np      MPI ranks (default 1)
#
# Prints a Markdown table: milliseconds per step (whole LAMMPS step, and the part spent in
# fixes, mostly fix hardsphere), collisions per particle per step (from f_hs[2]) and events
# (pair and wall collisions, resting contacts) per step (from f_hs[6]).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lmp=${1:-$(sed -n 's/^LAMMPS_BINARY:FILEPATH=//p' "$root/build/CMakeCache.txt" 2>/dev/null || true)}
plugin=${2:-$root/build/hardspheregpuplugin.so}
steps=${3:-200}
nmax=${4:-65536}
np=${5:-1}
[ -x "$lmp" ] || { echo "no LAMMPS executable '$lmp' (pass it as the first argument)" >&2; exit 2; }
[ -f "$plugin" ] || { echo "no plugin '$plugin' (pass it as the second argument)" >&2; exit 2; }
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
launcher=()
[ "$np" -gt 1 ] && launcher=(mpirun -np "$np")

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root"/examples/hardsphere/in.* "$work"/
cd "$work"

echo "| configuration | N | order | ms/step | fixes ms/step | collisions/particle/step | events/step |"
echo "|---|---:|---|---:|---:|---:|---:|"
for config in dilute lattice2d lattice3d; do
  n=1024
  while [ "$n" -le "$nmax" ]; do
    for order in parallel serial; do
      log=$work/log.$config.$n.$order
      "${launcher[@]}" "$lmp" -in "in.$config" -var plugin "$plugin" -var N "$n" \
        -var steps "$steps" -var order "$order" -log "$log" -echo none >/dev/null 2>&1 || {
        echo "| $config | $n | $order | failed | | | |"
        continue
      }
      awk -v config="$config" -v n="$n" -v order="$order" '
        /^Loop time of/ { loop = $4; nsteps = $9 }
        /^Modify  *\|/ { modify = $5 }
        /collisions per particle per step/ {
          for (i = 1; i <= NF; i++) {
            if ($(i+1) == "collisions" && $(i+2) == "per") rate = $i
            if ($(i+1) == "events" && $(i+2) == "per") ev = $i
          }
        }
        END {
          printf "| %s | %d | %s | %.3f | %.3f | %s | %s |\n", config, n, order,
                 1000 * loop / nsteps, 1000 * modify / nsteps, rate, ev
        }' "$log"
    done
    n=$((n * 2))
  done
done
