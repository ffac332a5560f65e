#!/bin/bash
# Long mode of the hard-case suite (issue 12 item 14, doc/hard_cases.md): every case of
# unittest/lammps/test_hard_cases*.cpp at its long size, run to at least 1e7 events, and the
# table of the results.
#
#   bash tools/hard_cases.sh [build-dir] [one|mpi|all]
#
# build-dir: where the plugin and its tests were built (default build/).  one: the one-rank
# cases; mpi: 1 against 2 and 4 ranks and the restarts; all (default): both.  Environment:
# HSGPU_HARD_EVENTS (events per case, default 1e7), HSGPU_HARD_NP (rank counts, default "2 4").
# GTEST_FILTER picks cases (e.g. GTEST_FILTER="*Pour*").  The full output goes to
# <build-dir>/hard_cases_long_<one|mpi|all>.log; the table is printed at the end.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
build=$(cd "${1:-$HSGPU_ROOT/build}" && pwd)
which=${2:-all}
log=$build/hard_cases_long_$which.log
mpiexec=$(sed -n 's/^MPIEXEC_EXECUTABLE:FILEPATH=//p' "$build/CMakeCache.txt")
cores=$(nproc)
mpi_env
export HSGPU_HARD_LONG=1 OMP_NUM_THREADS=1
: > "$log"
say "hard cases, long mode: $(date -u '+%Y-%m-%d %H:%M UTC'), $cores cores, log in $log"
start=$SECONDS
if [ "$which" != mpi ]; then
  "$build/unittest/test_hard_cases" 2>&1 | tee -a "$log"
fi
if [ "$which" != one ]; then
  for np in ${HSGPU_HARD_NP:-2 4}; do
    "$mpiexec" -n "$np" "$build/unittest/test_hard_cases_mpi" 2>&1 | tee -a "$log"
  done
fi
say "wall time $((SECONDS - start)) s"
echo
echo "| case | N | steps | events | events/s | closest approach | overlaps > 1e-9 | energy balance | events per sphere per step (most in a step) |"
echo "|---|---:|---:|---:|---:|---:|---:|---:|---|"
grep -a '^\[ HARD     \] |' "$log" | sed 's/^\[ HARD     \] //'
grep -aq '^\[  FAILED  \]' "$log" && { say "some cases FAILED (see $log)"; exit 1; }
exit 0
