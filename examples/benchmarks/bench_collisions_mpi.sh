#!/usr/bin/env bash
# MPI scaling of fix hardsphere on the CPU: the fluid of examples/benchmarks/in.fluid (N = 32768,
# 50 steps) and examples/hardsphere/in.lattice3d (N = 65536, 100 steps) on 1, 2, 4, 8 ranks
# (mpirun --bind-to core), the plugin under test three times each (HSGPU_BENCH_REPS) and a
# baseline plugin once.
# Prints one line per run: LAMMPS's Loop, Modify and Neigh times and the fix's run summary
# (search and resolve times, groups spanning ranks, gathers); doc/bench_collisions.md takes the
# median of the three Modify times.
#
#   examples/benchmarks/bench_collisions_mpi.sh lmp plugin [baseline] [ranks]
#
#   baseline  plugin of an earlier commit ('' or 'none': none); ranks default "1 2 4 8"
#   HSGPU_SCENES: folder with in.fluid (default: this folder, examples/benchmarks)
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
root=$(cd "$here/../.." && pwd)
lmp=${1:?lmp}
plugin=$(cd "$(dirname "$2")" && pwd)/$(basename "$2")
baseline=${3:-}
[ "$baseline" = none ] && baseline=
[ -n "$baseline" ] && baseline=$(cd "$(dirname "$baseline")" && pwd)/$(basename "$baseline")
ranks=${4:-1 2 4 8}
reps=${HSGPU_BENCH_REPS:-3}
scenes=${HSGPU_SCENES:-$here}
export OMP_NUM_THREADS=1 OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
export OMPI_MCA_rmaps_base_oversubscribe=1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cp "$root/examples/hardsphere/in.lattice3d" "$scenes/in.fluid" "$work"/
cd "$work"
echo "host: $(nproc --all) cores, $(lscpu | sed -n 's/^Model name: *//p'); $(date -u)"
run() { # tag np plugin input args...
  local tag=$1 np=$2 plug=$3 inp=$4
  shift 4
  if ! mpirun -np "$np" --bind-to core "$lmp" -in "$inp" -var plugin "$plug" "$@" \
      -log "log.$tag.$np" -echo none -screen none >/dev/null 2>&1; then
    echo "$tag np=$np FAILED: $(grep ERROR "log.$tag.$np" | head -1)"
    return
  fi
  echo "$tag np=$np loop=$(awk '/Loop time/ {print $4}' "log.$tag.$np")" \
    "modify=$(awk '/^Modify / {print $5}' "log.$tag.$np")" \
    "neigh=$(awk '/^Neigh / {print $5}' "log.$tag.$np")" \
    "| $(sed -n 's/^Fix hardsphere (.*steps, //p' "log.$tag.$np")"
}
# The rank counts take turns within each repetition, so that a slow spell of a shared host
# weighs on all of them alike.
for rep in $(seq "$reps"); do
  for np in $ranks; do
    run fluid "$np" "$plugin" in.fluid -var steps 50
    run lattice3d "$np" "$plugin" in.lattice3d -var N 65536 -var steps 100
  done
done
if [ -n "$baseline" ]; then
  for np in $ranks; do
    run fluid_baseline "$np" "$baseline" in.fluid -var steps 50
    run lattice3d_baseline "$np" "$baseline" in.lattice3d -var N 65536 -var steps 100
  done
fi
